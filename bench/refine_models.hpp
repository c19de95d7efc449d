#pragma once
// The models of the refinement benchmarks (bench/bench_engine_refine.cpp and `palplab bench
// refinement`, app/bench_section_refinement.cpp), built once here so both measure the same.
#include <utility>

#include "engine/mesh/generate.hpp"
#include "engine/mesh/rings.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/models/mass_spring_material.hpp"
#include "engine/models/refinement.hpp"

namespace palplab::bench {

// A surface (membrane) model: 5 mm wall of 10 kPa tissue, 1000 kg/m^3, on a 2e5 N/m^3
// foundation (the stomach of the original work; the tract surface with the same material).
inline engine::AdaptiveMassSpring surface_model(const mesh::SurfaceMesh& m) {
  using namespace engine;
  MassSpringSystem s;
  s.X_rest = m.V;
  s.X = m.V;
  const Eigen::VectorXd c = Eigen::VectorXd::Constant(m.F.rows(), 1e4 * 0.005);
  const Eigen::VectorXd area = lumped_area(m.V, m.F);
  s.mass = area * (1000.0 * 0.005);
  s.home_ks = 2e5 * area;
  s.home_kd = 200.0 * area;
  s.springs = membrane_springs(m.V, m.F, c, 0.002);
  return make_adaptive(std::move(s), m.F, c, 0.002, 1e-3);
}

// Model-C as a tet model with prototype C's material: E = 100 kPa, 1000 kg/m^3, foundation
// 2e5 N/m^3 under the boundary. Built with its tets, as engine/models/mass_spring_model.cpp
// builds it: refinement re-divides the coarse tets under the refined surface (the code path
// prototype C runs), not the surface alone. `surface_vertices`: the base resolution (the
// refinement tests compare several).
inline engine::AdaptiveMassSpring tet_model_c(int surface_vertices = mesh::kModelCSurfaceVertices) {
  using namespace engine;
  const mesh::TetMesh tm = mesh::generate_model_c(0, surface_vertices);
  const mesh::BoundaryFaces bf = mesh::boundary_faces(tm);
  MassSpringSystem s;
  s.X_rest = tm.V;
  s.X = tm.V;
  const Eigen::VectorXd E = Eigen::VectorXd::Constant(tm.T.rows(), 1e5);
  s.mass = tet_lumped_mass(tm.V, tm.T, Eigen::VectorXd::Constant(tm.T.rows(), 1000.0));
  s.springs = tet_springs(tm.V, tm.T, E, 0.002);
  const Eigen::VectorXd area = lumped_area(tm.V, bf.F);
  s.home_ks = 2e5 * area;
  s.home_kd = 200.0 * area;
  return make_adaptive(std::move(s), bf.F, boundary_membrane(tm.V, tm.T, bf.F, bf.tet, E), 0.002,
                       1e-3,
                       CoarseTets{tm.T, E, bf.tet, Eigen::VectorXd::Constant(tm.T.rows(), 0.45)});
}

}  // namespace palplab::bench
