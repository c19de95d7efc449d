// Model "fem" (prototype D, issue 12): the tissue finite element model (FemModel) of a tet scene
// mesh behind the SceneModel interface. Per-tet materials come from the tissue table (the mesh's
// tissue attribute, or the prototype's tissue with optional E/density overrides; rigid tissue is
// fixed), the pinned nodes from the support (fixed_region, fixed_z_below) as for prototype C.
// The device couples through the same proxy contact as C: Scene::step gives the contact point's
// surface face and barycentric weights, this model puts the probe face there as a contact patch
// (the pads of the face's three vertices — surface nodes within contact.patch_radius, weighted
// by their lumped surface area — blended by the barycentric weights, so the force is continuous
// as the contact slides from node to node) and FemModel renders the patch's penalty force
// (fem_model.hpp).
//
// Condensed formulation: the solved (operational) tets are those whose centroid lies within
// fem.operational_radius of a surface node of fem.operational_region; patch nodes outside the
// operational tets are dropped from the patch. A touch whose centre node lies outside them is
// rendered by inverse-stiffness contact with the full linear model (SPEC §4): the probe face
// (the contact face's vertex pads with all their surface nodes, blended by the barycentric
// weights as in the main path, so the force is continuous across node changes) has the 3x3
// compliance C = G^T K^-1 G (G = sum_v w_v G_v, G_v = sum_i s_vi E_i, K the full stiffness with
// foundation and constraints, factorised once at construction; the columns K^-1 G_v are solved
// at the first touch of each vertex and cached, C is blended from their 3x3 blocks), and the force
// is the quasi-static equilibrium of the penalty spring in series with the tissue,
// F = k d / (1 + k n^T C n) n — the force the full model settles on. No dynamics there and the
// rendered surface does not deform (the interior of the condensed part is not advanced); such
// touches are counted in model_info ("outside_contacts").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <unordered_map>

#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/models/fem_model.hpp"
#include "engine/models/model.hpp"
#include "engine/models/tet_mesh_checks.hpp"
#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

namespace {

const mesh::Material* find_tissue(const std::string& name) {
  for (const auto& e : mesh::default_materials().materials)
    if (e.name == name) return &e;
  return nullptr;
}

class FemSceneModel final : public SceneModel {
 public:
  FemSceneModel(const SceneConfig& cfg, const SceneMesh& cm, const mesh::TetMesh& tm,
                const TetMaterials& mat, std::vector<std::uint8_t> fixed, FemModelOptions opt)
      : fem_(tm, mat, std::move(fixed), std::move(opt)),
        surface_to_model_(cm.surface_to_model),
        F_(cm.F),
        X0_(cm.model_V),
        patch_radius_(cfg.contact.patch_radius),
        contact_k_(cfg.contact.stiffness),
        update_rate_hz_(cfg.fem.update_rate_hz) {
    const long n = cm.model_V.rows();
    area_.setZero(n);
    for (size_t i = 0; i < cm.surface_to_model.size(); ++i)
      area_[cm.surface_to_model[i]] = cm.vertex_area[static_cast<long>(i)];
    // Node adjacency through the tet edges (for the patch's breadth-first walk).
    adj_start_.assign(n + 1, 0);
    for (long e = 0; e < cm.model_E.rows(); ++e) {
      ++adj_start_[cm.model_E(e, 0) + 1];
      ++adj_start_[cm.model_E(e, 1) + 1];
    }
    for (long i = 0; i < n; ++i) adj_start_[i + 1] += adj_start_[i];
    adj_.resize(adj_start_[n]);
    std::vector<int> fill(adj_start_.begin(), adj_start_.end() - 1);
    for (long e = 0; e < cm.model_E.rows(); ++e) {
      const int a = cm.model_E(e, 0), b = cm.model_E(e, 1);
      adj_[fill[a]++] = b;
      adj_[fill[b]++] = a;
    }
    mark_.assign(n, 0);
    slot_.assign(n, -1);
    faces_.resize(cm.F.rows(), 3);
    for (long f = 0; f < cm.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) faces_(f, k) = cm.surface_to_model[cm.F(f, k)];
    mass_ = fem_.system().m_lumped.sum() / 3.0;
    if (fem_.formulation() == FemFormulation::condensed) {
      full_ = std::make_unique<StaticSolver>();
      static_precompute(fem_.system().K, node_to_dof_flags(fem_.fixed_nodes()), *full_);
    }
  }

  const char* kind() const override { return "fem"; }
  // The model's precomputation for a .psim file (FemModel::save_precomputation).
  std::string save(double h) { return fem_.save_precomputation(h); }

  ModelOutput step(const ContactInput& c, double dt) override {
    const int mnode = c.node >= 0 ? surface_to_model_[c.node] : -1;
    ModelOutput o;
    const bool solved = mnode >= 0 && (fem_.solves_node(mnode) || fem_.fixed_nodes()[mnode]);
    if (mnode >= 0 && solved) {
      const int face = pad_face(c.face);
      if ((face >= 0 ? face : -1 - mnode) != pad_key_) compute_pad(face, mnode);
      fem_.contact_node = mnode;
      fem_.contact_point = c.x + blend_pad(face, c.w, c.n, mnode) * c.n;
      fem_.contact_normal = c.n;
      fem_.contact_k = contact_k_;
    } else {
      fem_.contact_node = -1;
    }
    fem_.step(dt);
    if (mnode >= 0 && solved) {
      o.force = fem_.device_force();
      o.deformation = (fem_.node_position(mnode) - X0_.row(mnode).transpose()).norm();
    } else if (mnode >= 0) {
      // Outside the operational region of a condensed model: inverse-stiffness contact (top),
      // on the probe face of the main path (the face's vertex pads blended by the barycentric
      // weights, every surface node in reach), so the force is continuous across node changes.
      const int face = c.face >= 0 && c.face < faces_.rows() ? c.face : -1;
      if ((face >= 0 ? face : -1 - mnode) != outside_key_) outside_face(face, mnode);
      double d = 0;
      Eigen::Vector3d Yn_node = Eigen::Vector3d::Zero();  // K^-1 G n at the contact node
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();        // G^T K^-1 G of the blend
      for (int a = 0; a < outside_nv_; ++a) {
        const double wa = face >= 0 ? c.w[a] : 1.0;
        const OutsidePad& P = *outside_pad_[a];
        const Eigen::Vector3d xv = X0_.row(outside_v_[a]).transpose();
        for (size_t q = 0; q < P.nodes.size(); ++q) {
          const Eigen::Vector3d xi = X0_.row(P.nodes[q]).transpose();
          d += wa * P.w[q] * ((xi - c.x).dot(c.n) - std::max(0.0, (xi - xv).dot(c.n)));
        }
        for (int b = 0; b < outside_nv_; ++b)
          C += wa * (face >= 0 ? c.w[b] : 1.0) * outside_B_[a][b];
        Yn_node += wa * (P.Y.middleRows<3>(3 * mnode) * c.n);
      }
      if (d > 0) {
        ++outside_contacts_;
        const double compliance = c.n.dot(0.5 * (C + C.transpose()) * c.n);
        const double f = contact_k_ * d / (1 + contact_k_ * compliance);
        o.force = f * c.n;
        o.deformation = f * Yn_node.norm();
      }
    }
    return o;
  }

  void reset() override {
    fem_.reset();
    fem_.contact_node = -1;
    pad_key_ = kNoPad;
    outside_contacts_ = 0;  // (the outside compliance columns stay valid: K is constant)
  }

  void stats(SceneStats& st) const override {
    // The condensed interior is recovered on demand (graphics rate): positions() is not const.
    FemModel& f = const_cast<FemModel&>(fem_);
    st.nodes = X0_.rows();
    st.springs = 0;
    st.coarse_nodes = st.nodes;
    st.total_mass = mass_;
    st.max_rest_error = (f.positions() - X0_).rowwise().norm().maxCoeff();
    st.awake_nodes = f.dofs() / 3;
    nlohmann::json info = {{"fem",
                            {{"formulation", to_string(f.formulation())},
                             {"dofs", f.dofs()},
                             {"total_dofs", f.total_dofs()},
                             {"solver", f.solver()},
                             {"factor_ms", f.factor_ms()},
                             {"patch_nodes", static_cast<long>(f.contact_nodes.size())},

                             {"outside_contacts", outside_contacts_}}}};
    if (f.formulation() == FemFormulation::corotational_multirate) {
      info["fem"]["update_rate_hz"] = update_rate_hz_;  // deformation updates per second
      info["fem"]["relinearisations"] = f.relinearisations();
      info["fem"]["pad_solves"] = f.pad_solves();  // pads solved in the haptic step
    }
    st.model_info = info.dump();
  }

  void surface(mesh::Positions& V, mesh::Faces& F) const override {
    FemModel& f = const_cast<FemModel&>(fem_);
    const mesh::Positions& X = f.positions();
    V.resize(static_cast<long>(surface_to_model_.size()), 3);
    for (size_t i = 0; i < surface_to_model_.size(); ++i)
      V.row(static_cast<long>(i)) = X.row(surface_to_model_[i]);
    F = F_;
  }

 private:
  // The face whose vertex pads make the probe face, or -1 (the node's pad alone): a face every
  // vertex of which the per-step solve moves (or holds fixed).
  int pad_face(int face) const {
    if (face < 0 || face >= faces_.rows()) return -1;
    for (int k = 0; k < 3; ++k) {
      const int v = faces_(face, k);
      if (!fem_.solves_node(v) && !fem_.fixed_nodes()[v]) return -1;
    }
    return face;
  }
  // The pads of the face's three vertices (surface nodes within patch_radius of the vertex,
  // reached through tet edges between surface nodes so that a pad never jumps a gap, weighted
  // by their lumped surface area — the rule of the mass-spring model, mass_spring_model.cpp),
  // or of `node` alone when face < 0.
  void compute_pad(int face, int node) {
    pad_key_ = face >= 0 ? face : -1 - node;
    pad_.clear();
    for (int k = 0; k < (face >= 0 ? 3 : 1); ++k) {
      patch_nodes(face >= 0 ? faces_(face, k) : node, false, tmp_nodes_, tmp_w_);
      for (size_t q = 0; q < tmp_nodes_.size(); ++q) pad_.push_back({tmp_nodes_[q], k, tmp_w_[q]});
    }
    // The same pads for the multi-rate model's per-pad compliance cache (fem_model.hpp).
    std::vector<FemModel::ContactPad>& pads = fem_.contact_pads;
    pads.assign(face >= 0 ? 3 : 1, {});
    for (const PadEntry& e : pad_) {
      pads[e.slot].nodes.push_back(e.node);
      pads[e.slot].weights.push_back(e.w);
    }
  }
  // This step's patch on the FemModel: the vertex pads weighted by the barycentric weights w
  // (each node once), so the patch moves continuously with the contact point. Each vertex pad
  // yields to nodes above ITS vertex's tangent plane (offset o = max(0, (X0_i - X0_v) . n));
  // FemModel measures offsets from contact_node, so the difference of the weighted offset sums
  // is returned (m): the caller moves the contact plane by it along n, which makes FemModel's
  // penetration exactly sum_v w_v sum_i s_vi ((x_i - x) . n - o_vi).
  double blend_pad(int face, const Eigen::Vector3d& w, const Eigen::Vector3d& n, int node) {
    std::vector<int>& nodes = fem_.contact_nodes;
    std::vector<double>& wt = fem_.contact_weights;
    nodes.clear();
    wt.clear();
    const auto offset = [&](int i, int v) {
      return std::max(0.0, (X0_.row(i) - X0_.row(v)).dot(n.transpose()));
    };
    for (size_t a = 0; a < fem_.contact_pads.size(); ++a)
      fem_.contact_pads[a].blend = face >= 0 ? w[static_cast<long>(a)] : 1.0;
    double own = 0.0;
    for (const PadEntry& e : pad_) {
      const double we = (face >= 0 ? w[e.slot] : 1.0) * e.w;
      if (!(we > 0.0)) continue;
      own += we * offset(e.node, face >= 0 ? faces_(face, e.slot) : node);
      if (slot_[e.node] < 0) {
        slot_[e.node] = static_cast<int>(nodes.size());
        nodes.push_back(e.node);
        wt.push_back(0.0);
      }
      wt[slot_[e.node]] += we;
    }
    double fem = 0.0;
    for (size_t q = 0; q < nodes.size(); ++q) {
      fem += wt[q] * offset(nodes[q], node);
      slot_[nodes[q]] = -1;
    }
    return own - fem;
  }
  // The vertex pads of an outside touch's face (or of `node` alone when face < 0): each pad
  // (every surface node in reach of its vertex) with its compliance columns K^-1 G_v (3
  // back-substitutions, cached per vertex: a slide onto a neighbouring face solves only its new
  // vertex), and the 3x3 blocks G_a^T K^-1 G_b of every pair, so that a step blends them by the
  // barycentric weights: G = sum_a w_a G_a is linear in the weights, C = sum_ab w_a w_b B_ab.
  void outside_face(int face, int node) {
    outside_key_ = face >= 0 ? face : -1 - node;
    outside_nv_ = face >= 0 ? 3 : 1;
    if (outside_pads_.size() > 64) outside_pads_.clear();  // bounded memory (3#V x 3 each)
    for (int a = 0; a < outside_nv_; ++a) {
      const int v = face >= 0 ? faces_(face, a) : node;
      outside_v_[a] = v;
      auto [it, fresh] = outside_pads_.try_emplace(v);
      OutsidePad& P = it->second;
      if (fresh) {
        patch_nodes(v, true, P.nodes, P.w);
        const long n3 = 3 * X0_.rows();
        Eigen::VectorXd g = Eigen::VectorXd::Zero(n3);
        P.Y.resize(n3, 3);
        for (int k = 0; k < 3; ++k) {
          g.setZero();
          for (size_t q = 0; q < P.nodes.size(); ++q) g[3 * P.nodes[q] + k] += P.w[q];
          P.Y.col(k) = static_solve(*full_, g);
        }
      }
      outside_pad_[a] = &P;
    }
    for (int a = 0; a < outside_nv_; ++a)
      for (int b = 0; b < outside_nv_; ++b) {
        Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
        const OutsidePad& Pa = *outside_pad_[a];
        for (size_t q = 0; q < Pa.nodes.size(); ++q)
          B += Pa.w[q] * outside_pad_[b]->Y.middleRows<3>(3 * Pa.nodes[q]);
        outside_B_[a][b] = B;
      }
  }
  // Surface nodes within patch_radius of the centre; all = false keeps only the nodes the
  // per-step solve moves (or fixed ones).
  void patch_nodes(int center, bool all, std::vector<int>& nodes, std::vector<double>& w) {
    nodes.clear();
    w.clear();
    const Eigen::Vector3d c = X0_.row(center).transpose();
    const double r2 = patch_radius_ * patch_radius_;
    nodes.push_back(center);
    mark_[center] = 1;
    for (size_t q = 0; q < nodes.size(); ++q) {
      const int i = nodes[q];
      for (int k = adj_start_[i]; k < adj_start_[i + 1]; ++k) {
        const int j = adj_[k];
        if (mark_[j] || !(area_[j] > 0.0) || (X0_.row(j).transpose() - c).squaredNorm() > r2)
          continue;
        mark_[j] = 1;
        if (all || fem_.solves_node(j) || fem_.fixed_nodes()[j]) nodes.push_back(j);
      }
    }
    double sum = 0.0;
    for (int i : nodes) sum += area_[i];
    for (int i : nodes) w.push_back(sum > 0 ? area_[i] / sum : 1.0 / nodes.size());
    std::fill(mark_.begin(), mark_.end(), 0);
  }

  FemModel fem_;
  std::vector<int> surface_to_model_;
  mesh::Faces F_;
  mesh::Positions X0_;
  Eigen::VectorXd area_;  // #M lumped surface area (m^2), 0 inside
  std::vector<int> adj_start_, adj_;
  std::vector<std::uint8_t> mark_;
  double patch_radius_, contact_k_, update_rate_hz_, mass_ = 0;
  // The probe pad (compute_pad): one entry per (face vertex, pad node).
  struct PadEntry {
    int node, slot;  // pad node; face vertex 0..2
    double w;        // its share of that vertex's pad
  };
  static constexpr int kNoPad = 1 << 30;
  mesh::Faces faces_;     // surface faces in model nodes
  int pad_key_ = kNoPad;  // face, or -1 - node, the pad was built for
  std::vector<PadEntry> pad_;
  std::vector<int> tmp_nodes_, slot_;  // slot_: node -> its index in the patch, -1
  std::vector<double> tmp_w_;
  long outside_contacts_ = 0;
  // Outside touches of a condensed model (inverse-stiffness contact, see top).
  std::unique_ptr<StaticSolver> full_;  // the full linear K, factorised
  struct OutsidePad {
    std::vector<int> nodes;                      // surface nodes within patch_radius of the vertex
    std::vector<double> w;                       // their area weights (sum 1)
    Eigen::Matrix<double, Eigen::Dynamic, 3> Y;  // 3#V by 3: K^-1 G_v (m/N)
  };
  std::unordered_map<int, OutsidePad> outside_pads_;  // per vertex
  int outside_key_ = kNoPad;                          // face, or -1 - node, of the blocks
  int outside_nv_ = 0, outside_v_[3] = {-1, -1, -1};
  const OutsidePad* outside_pad_[3] = {nullptr, nullptr, nullptr};
  Eigen::Matrix3d outside_B_[3][3];  // G_a^T K^-1 G_b (m/N)
};

// The "model" object of a FEM prototype (docs/FORMATS.md). Defaults are the config's.
void read_fem(json::Checker& c, const nlohmann::json& m, const std::string& P, SceneConfig& cfg,
              const std::vector<std::string>& regions) {
  c.keys(m, P,
         {"kind", "formulation", "material", "rayleigh_alpha", "rayleigh_beta", "lumped_mass",
          "jacobian", "operational_region", "operational_radius", "fixed_region", "fixed_z_below",
          "support_modulus", "update_rate_hz", "deterministic_update"});
  FemConfig& f = cfg.fem;
  if (auto fo = c.text(m, P, "formulation", false,
                       {"linear", "corotational", "condensed", "corotational_multirate"}))
    f.formulation = fem_formulation_from_string(*fo);
  read_material(c, m, P, cfg.material);
  f.rayleigh_alpha =
      c.number(m, P, "rayleigh_alpha", false, 0, 1e4, "the mass-proportional damping (1/s)")
          .value_or(f.rayleigh_alpha);
  f.rayleigh_beta =
      c.number(m, P, "rayleigh_beta", false, 0, 10, "the stiffness-proportional damping (s)")
          .value_or(f.rayleigh_beta);
  f.lumped_mass = c.boolean(m, P, "lumped_mass", false).value_or(f.lumped_mass);
  f.update_rate_hz =
      c.number(m, P, "update_rate_hz", false, 1, 1e4,
               "the deformation updates per second of the multi-rate co-rotational model (Hz)")
          .value_or(f.update_rate_hz);
  f.multirate_deterministic =
      c.boolean(m, P, "deterministic_update", false).value_or(f.multirate_deterministic);
  if (m.contains("deterministic_update") && f.formulation != FemFormulation::corotational_multirate)
    c.err(P + ".deterministic_update", "only the corotational_multirate formulation has updates");
  if (m.contains("update_rate_hz") && f.formulation != FemFormulation::corotational_multirate)
    c.err(P + ".update_rate_hz", "only the corotational_multirate formulation has an update rate");
  if (auto j = c.text(m, P, "jacobian", false, {"exact", "warped"}))
    f.exact_jacobian = *j == "exact";
  f.operational_radius =
      c.number(m, P, "operational_radius", false, 0, 10,
               "the distance from the operational region within which tets are solved (m)")
          .value_or(f.operational_radius);
  if (auto r = c.text(m, P, "operational_region", false)) {
    if (std::find(regions.begin(), regions.end(), *r) == regions.end())
      c.err(P + ".operational_region",
            "unknown region \"" + *r + "\" of the mesh" + json::did_you_mean(*r, regions));
    else
      f.operational_region = *r;
  }
  if (f.formulation == FemFormulation::condensed) {
    if (!m.contains("operational_region"))  // (a bad name is reported above)
      c.err(P, "the condensed formulation needs \"operational_region\" (a region of the mesh)");
    if (!f.lumped_mass) c.err(P + ".lumped_mass", "the condensed formulation uses lumped mass");
  }
  read_support(c, m, P, cfg.support, regions);
}

// What the FEM needs of its mesh, checked by `validate` and `run` before anything runs (the
// kind's check_mesh) and by make_fem: tets, each positively oriented and not flat (an inverted
// or zero-volume tet has no element stiffness; the same bound as tet_shape's), of tissue
// attributes the material table covers.
void check_fem_mesh(const SceneConfig& cfg, const SceneMesh& cm) {
  if (!cm.tet)
    throw InputError(
        "model \"fem\" needs a tetrahedral mesh (generator model_c or a tet mesh "
        "file); mesh " +
            cfg.mesh.key() + " is a surface",
        cfg.source);
  check_tet_connectivity(cfg, cm);
  for (long t = 0; t < cm.model_T.rows(); ++t) {
    const double v = mesh::signed_volume(cm.model_V, cm.model_T, static_cast<int>(t));
    double longest = 0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        longest = std::max(
            longest, (cm.model_V.row(cm.model_T(t, a)) - cm.model_V.row(cm.model_T(t, b))).norm());
    const bool flat = !(std::abs(v) > 1e-14 * longest * longest * longest);
    if (v < 0 || flat) {
      std::string nodes, where;
      for (int k = 0; k < 4; ++k) {
        if (k) nodes += ' ';
        nodes += std::to_string(cm.model_T(t, k));
      }
      const std::string file = tet_problem_file(cfg, &where);
      char vol[32];
      std::snprintf(vol, sizeof vol, "%.3g", v);
      throw InputError(
          where + "tet " + std::to_string(t) + " (in file order from 0; nodes " + nodes + "): " +
              (flat ? std::string("degenerate tetrahedron (zero volume, ") + vol +
                          " m^3): model \"fem\" needs every tet to have a volume (`palplab mesh "
                          "check` lists every degenerate tet; `mesh tetrahedralize` remeshes)"
                    : std::string("inverted tetrahedron (signed volume ") + vol +
                          " m^3): model \"fem\" needs every tet positively oriented (swap two "
                          "of its nodes; `palplab mesh check` lists every inverted tet)"),
          file);
    }
  }
  check_tet_attributes(cfg, cm, false);  // per tet from the attribute, whatever tissue is named
}

std::unique_ptr<SceneModel> make_fem(const SceneConfig& cfg, const SceneMesh& cm) {
  check_fem_mesh(cfg, cm);
  const long nm = cm.model_V.rows(), nt = cm.model_T.rows();
  mesh::TetMesh tm = mesh::make_tet_mesh(cm.model_V, cm.model_T, cm.tet_attribute);
  const mesh::MaterialTable& table = mesh::default_materials();
  TetMaterials mat = tet_materials(tm, table);  // per tet from the attribute (tissue table)
  const MaterialConfig& mc = cfg.material;
  if (!mc.tissue.empty() || mc.youngs_modulus || mc.density) {
    const mesh::Material* named = mc.tissue.empty() ? nullptr : find_tissue(mc.tissue);
    if (!mc.tissue.empty() && !named)
      throw InputError("unknown tissue \"" + mc.tissue + "\"", cfg.source);
    for (long t = 0; t < nt; ++t) {
      if (mat.rigid[t]) continue;  // bone stays bone
      if (named) {
        mat.youngs_modulus[t] = named->youngs_modulus;
        mat.poisson_ratio[t] = named->poisson_ratio;
        mat.density[t] = named->density;
      }
      if (mc.youngs_modulus) mat.youngs_modulus[t] = *mc.youngs_modulus;
      if (mc.density) mat.density[t] = *mc.density;
    }
  }
  // Pinned nodes: the fixed region and everything below fixed_z_below (as the mass-spring
  // model); rigid tissue is fixed by FemModel.
  std::vector<std::uint8_t> fixed(nm, 0);
  const auto region_index = [&](const std::string& name, const char* what) {
    const auto it = std::find(cm.region_names.begin(), cm.region_names.end(), name);
    if (it == cm.region_names.end())
      throw InputError(std::string("unknown ") + what + " \"" + name + "\"", cfg.source);
    return static_cast<int>(it - cm.region_names.begin());
  };
  if (!cfg.support.fixed_region.empty()) {
    const int r = region_index(cfg.support.fixed_region, "fixed region");
    for (size_t i = 0; i < cm.vertex_region.size(); ++i)
      if (cm.vertex_region[i] == r) fixed[cm.surface_to_model[i]] = 1;
  }
  if (cfg.support.fixed_z_below > 0.0) {
    const double z0 = cm.model_V.col(2).minCoeff();
    for (long i = 0; i < nm; ++i)
      if (cm.model_V(i, 2) < z0 + cfg.support.fixed_z_below) fixed[i] = 1;
  }
  const FemConfig& fc = cfg.fem;
  FemModelOptions opt;
  opt.formulation = fc.formulation;
  opt.rayleigh_alpha = fc.rayleigh_alpha;
  opt.rayleigh_beta = fc.rayleigh_beta;
  opt.lumped_mass = fc.lumped_mass;
  opt.jacobian = fc.exact_jacobian ? CorotJacobian::exact : CorotJacobian::warped;
  opt.update_interval = 1.0 / fc.update_rate_hz;
  opt.multirate_deterministic = fc.multirate_deterministic;
  if (cm.model_blob_kind == "fem") opt.precomputed = &cm.model_blob;  // a .psim file's (no copy)
  if (cfg.support.modulus > 0) {  // per unit area of the surface it holds, as for C
    opt.support_stiffness.setZero(3 * nm);
    for (size_t i = 0; i < cm.surface_to_model.size(); ++i)
      opt.support_stiffness.segment<3>(3 * cm.surface_to_model[i])
          .setConstant(cfg.support.modulus * cm.vertex_area[static_cast<long>(i)]);
  }
  if (fc.formulation == FemFormulation::condensed) {
    if (fc.operational_region.empty())
      throw InputError("the condensed FEM needs an operational region", cfg.source);
    const int r = region_index(fc.operational_region, "operational region");
    std::vector<int> rn;
    for (size_t i = 0; i < cm.vertex_region.size(); ++i)
      if (cm.vertex_region[i] == r) rn.push_back(static_cast<int>(i));
    const double r2 = fc.operational_radius * fc.operational_radius;
    opt.operational_tet.assign(nt, 0);
    long count = 0;
    for (long t = 0; t < nt; ++t) {
      Eigen::RowVector3d ctr = Eigen::RowVector3d::Zero();
      for (int k = 0; k < 4; ++k) ctr += cm.model_V.row(cm.model_T(t, k));
      ctr /= 4.0;
      for (int i : rn)
        if ((cm.V.row(i) - ctr).squaredNorm() <= r2) {
          opt.operational_tet[t] = 1;
          ++count;
          break;
        }
    }
    if (count == 0)
      throw InputError(
          "no tet lies within operational_radius of region \"" + fc.operational_region + "\"",
          cfg.source);
  }
  try {
    return std::make_unique<FemSceneModel>(cfg, cm, tm, mat, std::move(fixed), std::move(opt));
  } catch (const std::runtime_error& e) {
    if (dynamic_cast<const InputError*>(&e)) throw;
    throw InputError(std::string("model \"fem\": ") + e.what() +
                         " (pin the body: fixed_region or fixed_z_below)",
                     cfg.source);
  }
}

// The .psim hook (ModelKind::save): the linear model's factorisation at the haptic step.
std::string save_fem(const SceneConfig& cfg, const SceneMesh& cm) {
  auto m = make_fem(cfg, cm);
  return static_cast<FemSceneModel&>(*m).save(cfg.dt);
}

}  // namespace

const ModelKind& fem_model_kind() {
  static const ModelKind k{"fem",
                           "linear, co-rotational, condensed or multi-rate co-rotational "
                           "tetrahedral FEM of the tissue (prototype D)",
                           &read_fem,
                           nullptr,
                           &make_fem,
                           &save_fem,
                           &check_fem_mesh};
  return k;
}

}  // namespace palplab::engine
