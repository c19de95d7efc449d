// Model "penalty" (prototype A): a rigid organ; the force on the hand is Hooke's law on the
// penetration of the device below the god-object proxy, along the shaded normal there:
// f = k d n, d = (proxy - x) . n (engine/haptics/contact.hpp). n and d are continuous as the
// proxy slides from face to face, so is f.
#include <algorithm>
#include <nlohmann/json.hpp>

#include "common/json_check.hpp"
#include "engine/models/model.hpp"

namespace palplab::engine {

namespace {

class PenaltyModel final : public SceneModel {
 public:
  PenaltyModel(const SceneMesh& m, double k) : mesh_(m), k_(k) {}
  const char* kind() const override { return "penalty"; }
  bool deformable() const override { return false; }
  ModelOutput step(const ContactInput& c, double) override {
    ModelOutput o;
    if (c.node >= 0) o.force = k_ * std::max(0.0, c.depth) * c.n;
    return o;
  }
  void reset() override {}
  void stats(SceneStats& s) const override { s.nodes = s.coarse_nodes = mesh_.V.rows(); }
  void surface(mesh::Positions& V, mesh::Faces& F) const override {
    V = mesh_.V;
    F = mesh_.F;
  }

 private:
  const SceneMesh& mesh_;  // owned by the scene (shared cache entry)
  double k_;
};

void read_penalty(json::Checker& c, const nlohmann::json& m, const std::string& path, SceneConfig&,
                  const std::vector<std::string>&) {
  c.keys(m, path, {"kind"});
}

std::unique_ptr<SceneModel> make_penalty(const SceneConfig& cfg, const SceneMesh& m) {
  return std::make_unique<PenaltyModel>(m, cfg.contact.stiffness);
}

}  // namespace

const ModelKind& penalty_model_kind() {
  static const ModelKind k{"penalty", "rigid organ, Hooke's law on the penetration (prototype A)",
                           &read_penalty, nullptr, &make_penalty};
  return k;
}

}  // namespace palplab::engine
