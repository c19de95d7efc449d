#pragma once
// Stills shared by `palplab render` and `palplab report`: the WIDTHxHEIGHT option and the
// StillMaker that draws the report's prototypes under one press (analysis/report.hpp) with the
// headless renderer (engine/render/still.hpp). It lives in the binary because the analysis
// library has no renderer and the renderer no prototype loader.
#include <memory>
#include <string>
#include <utility>

#include "analysis/report.hpp"

namespace palplab::app {

// "800x600" -> {800, 600}; each side a whole number in 16..8192, else InputError naming `flag`.
std::pair<int, int> parse_image_size(const std::string& flag, const std::string& text);

// Draws each request with one EGL context for the whole report: the stored prototype file (its
// SHA-256 must still be the stored one, mesh files included, else the still is skipped with the
// reason) pressed with engine/render's press_for_still, seen by camera_facing_press.
std::shared_ptr<analysis::StillMaker> make_still_maker();

}  // namespace palplab::app
