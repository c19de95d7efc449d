#pragma once
// The FEM formulations of model "fem" (fem_model.hpp), in a header of its own so that
// engine::SceneConfig can hold one without pulling in the sparse FEM headers.
#include <string>

namespace palplab::engine {

enum class FemFormulation { linear, corotational, condensed, corotational_multirate };
// Throws InputError naming the accepted values.
FemFormulation fem_formulation_from_string(const std::string& s);
const char* to_string(FemFormulation f);

}  // namespace palplab::engine
