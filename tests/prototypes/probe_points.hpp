#pragma once
// Two points the physics tests press at on the tract of prototypes C, C1 and C2 (m, the mesh's
// frame): over the ovary (the feature) and over the body of the tract.
#include <Eigen/Core>

namespace palplab::engine::testing {

inline const Eigen::Vector3d kOvary(-0.0522, 0.0430, 0.3179);
inline const Eigen::Vector3d kBody(-0.014, -0.021, 0.152);

}  // namespace palplab::engine::testing
