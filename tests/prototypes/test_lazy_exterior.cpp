// Prototype C's linear exterior is written lazily (engine/models/mass_spring_model.cpp: each
// contact step writes only the exterior's frontier, the rest catches up before anything reads
// it). Against the eager path (engine::set_lazy_exterior(false): the whole exterior written every
// step) the forces must be bit-identical at every step and the surfaces wherever both are read
// (the lazy run reads its surface only every 50th step, so the exterior catches up only there).
// Three presses on different regions (the scope moves, a new exterior is solved and adopted, the
// contact is released in between), with the exterior solved beside the loop (worker, as shipped)
// and inside the step (sync). The body press holds at the device's force limit, where the contact
// tracker slides the contact: the scope re-centres in contact, and nodes woken under the old scope
// stay awake in the new exterior (the case the lazy path once got wrong, from its step 233).
#include <gtest/gtest.h>

#include "engine/models/mass_spring_model.hpp"
#include "prototypes/factory.hpp"
#include "tests/prototypes/press_run.hpp"

using namespace palplab;

namespace {

struct PressRun {
  std::vector<double> force;           // |F| per step (N)
  std::vector<mesh::Positions> shape;  // the surface every 50th step
};

// lazy = false: the eager exterior, and the surface read at every step.
PressRun two_presses(bool worker, bool lazy) {
  engine::set_lazy_exterior(lazy);
  const int read_every = lazy ? 50 : 1;
  engine::SceneConfig cfg =
      prototypes::load_prototype(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
  cfg.scope.exterior_worker = worker;
  engine::Scene s = engine::make_scene(cfg);
  PressRun out;
  long step = 0;
  mesh::Positions V;
  mesh::Faces F;
  for (const char* region : {"ovary_left", "body", "ovary_right"}) {
    engine::PressDevice d(engine::testing::depth_press(s, region, 0.005, 0.1));
    engine::run_lockstep(s, d, {.duration = 0.45, .frame_period = 0.0},
                         [&](const engine::Rendered& r, const engine::Sample&) {
                           out.force.push_back(r.force.norm());
                           if (step % read_every == 0) s.current_surface(V, F);
                           if (step % 50 == 0) out.shape.push_back(V);
                           ++step;
                         });
  }
  engine::set_lazy_exterior(true);  // the shipped default
  return out;
}

}  // namespace

TEST(LazyExterior, BitIdenticalToWritingTheWholeExteriorEveryStep) {
  for (bool worker : {true, false}) {
    const PressRun eager = two_presses(worker, false), lazy = two_presses(worker, true);
    ASSERT_EQ(eager.force.size(), lazy.force.size());
    ASSERT_EQ(eager.shape.size(), lazy.shape.size());
    double peak = 0.0;
    for (size_t k = 0; k < eager.force.size(); ++k) {
      peak = std::max(peak, eager.force[k]);
      ASSERT_EQ(eager.force[k], lazy.force[k]) << "step " << k << ", worker " << worker;
    }
    EXPECT_GT(peak, 1.0);  // both presses reached the tissue
    double moved = 0.0;
    for (size_t k = 0; k < eager.shape.size(); ++k) {
      ASSERT_EQ(eager.shape[k].rows(), lazy.shape[k].rows());
      EXPECT_EQ((eager.shape[k] - lazy.shape[k]).cwiseAbs().maxCoeff(), 0.0) << "frame " << k;
      moved = std::max(moved, (eager.shape[k] - eager.shape.front()).cwiseAbs().maxCoeff());
    }
    EXPECT_GT(moved, 1e-3);  // the surface deformed (m)
  }
}
