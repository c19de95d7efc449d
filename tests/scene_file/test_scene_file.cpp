// Simulation files (.psim, engine/haptics/scene_file.hpp): the prepared mesh survives the round
// trip bit for bit, and a scripted press through a scene loaded from the file renders exactly
// (==) the forces of a scene built from the sources, for prototypes A, B, C and D (C slides, so
// that its scope moves and its linear exterior -- restored from the file -- is solved again).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/contact.hpp"
#include "engine/haptics/press.hpp"
#include "engine/haptics/scene_file.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_model.hpp"
#include "engine/models/mass_spring_material.hpp"
#include "engine/models/mass_spring_model.hpp"
#include "engine/models/model.hpp"
#include "engine/solvers/far_field.hpp"
#include "engine/spatial/octree.hpp"
#include "prototypes/factory.hpp"

namespace {

using namespace palplab;
namespace fs = std::filesystem;

std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}

fs::path scratch() {
  const fs::path d = fs::temp_directory_path() / ("palplab_scene_file_" + std::to_string(getpid()));
  fs::create_directories(d);
  return d;
}

// Forces, contact nodes and deformations of a press-hold-release at the region node of "body"
// (or node 0 without that region).
struct Track {
  std::vector<Eigen::Vector3d> force;
  std::vector<int> node;
  std::vector<double> deformation;
  nlohmann::json info;  // the model's statistics at the end (SceneStats::model_info)
};

// `slide` (m/s): the press slides along the surface while it holds, for 0.6 s.
Track press(const engine::SceneConfig& cfg, double slide = 0.0) {
  engine::Scene s = engine::make_scene(cfg);
  const auto& g = s.geometry();
  const int node = g.region_index("body") >= 0 ? g.region_node("body") : 0;
  engine::PressSpec spec = engine::press_at(g, node, 1.0, slide > 0 ? 1.0 : 0.05, 0.05);
  if (slide > 0) {  // along a tangent of the surface at the press point
    const Eigen::Vector3d a =
        std::abs(spec.normal.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    spec.slide = slide * (a - a.dot(spec.normal) * spec.normal).normalized();
  }
  engine::PressDevice dev(spec);
  engine::LockstepOptions opt;
  opt.duration = 5.0;
  opt.frame_period = 0.0;
  Track t;
  engine::run_lockstep(s, dev, opt, [&](const engine::Rendered& r, const engine::Sample&) {
    t.force.push_back(r.force);
    t.node.push_back(r.contact_node);
    t.deformation.push_back(r.visible_deformation);
  });
  const std::string info = s.stats().model_info;
  if (!info.empty()) t.info = nlohmann::json::parse(info);
  return t;
}

template <class M>
void expect_same(const M& a, const M& b, const char* what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  EXPECT_TRUE(a.size() == 0 ||
              std::memcmp(a.data(), b.data(), sizeof(typename M::Scalar) * a.size()) == 0)
      << what;
}

void expect_same_mesh(const engine::SceneMesh& a, const engine::SceneMesh& b) {
  expect_same(a.V, b.V, "V");
  expect_same(a.N, b.N, "N");
  expect_same(a.F, b.F, "F");
  expect_same(a.E, b.E, "E");
  EXPECT_EQ(a.vertex_region, b.vertex_region);
  EXPECT_EQ(a.region_names, b.region_names);
  expect_same(a.vertex_area, b.vertex_area, "vertex_area");
  EXPECT_EQ(a.mean_edge, b.mean_edge);
  EXPECT_EQ(a.octree->order, b.octree->order);
  EXPECT_EQ(a.octree->leaf_of, b.octree->leaf_of);
  ASSERT_EQ(a.octree->nodes.size(), b.octree->nodes.size());
  for (size_t i = 0; i < a.octree->nodes.size(); ++i) {
    const auto &x = a.octree->nodes[i], &y = b.octree->nodes[i];
    EXPECT_TRUE(x.cell.min() == y.cell.min() && x.cell.max() == y.cell.max() &&
                x.box.min() == y.box.min() && x.box.max() == y.box.max() &&
                std::equal(x.child, x.child + 8, y.child) && x.begin == y.begin && x.end == y.end &&
                x.depth == y.depth && x.leaf == y.leaf)
        << "octree node " << i;
  }
  EXPECT_EQ(a.rings->first.offset, b.rings->first.offset);
  EXPECT_EQ(a.rings->first.index, b.rings->first.index);
  EXPECT_EQ(a.rings->second.offset, b.rings->second.offset);
  EXPECT_EQ(a.rings->second.index, b.rings->second.index);
  // The contact tracker's face index (format 4): the loaded one is used as stored.
  ASSERT_TRUE(a.face_index && b.face_index);
  const engine::FaceIndex &fa = *a.face_index, &fb = *b.face_index;
  EXPECT_EQ(fa.vf_offset, fb.vf_offset);
  EXPECT_EQ(fa.vf, fb.vf);
  EXPECT_EQ(fa.edge_face, fb.edge_face);
  EXPECT_EQ(fa.mean_edge, fb.mean_edge);
  EXPECT_EQ(fa.order, fb.order);
  EXPECT_EQ(fa.closed, fb.closed);
  ASSERT_EQ(fa.face_box.size(), fb.face_box.size());
  for (size_t i = 0; i < fa.face_box.size(); ++i)
    EXPECT_TRUE(fa.face_box[i].min() == fb.face_box[i].min() &&
                fa.face_box[i].max() == fb.face_box[i].max())
        << "face box " << i;
  ASSERT_EQ(fa.bvh.size(), fb.bvh.size());
  for (size_t i = 0; i < fa.bvh.size(); ++i) {
    const auto &x = fa.bvh[i], &y = fb.bvh[i];
    EXPECT_TRUE(x.box.min() == y.box.min() && x.box.max() == y.box.max() && x.left == y.left &&
                x.right == y.right && x.begin == y.begin && x.end == y.end)
        << "face hierarchy node " << i;
  }
  EXPECT_EQ(a.tet, b.tet);
  expect_same(a.model_V, b.model_V, "model_V");
  expect_same(a.model_E, b.model_E, "model_E");
  expect_same(a.model_T, b.model_T, "model_T");
  expect_same(a.tet_attribute, b.tet_attribute, "tet_attribute");
  expect_same(a.model_F, b.model_F, "model_F");
  expect_same(a.boundary_tet, b.boundary_tet, "boundary_tet");
  EXPECT_EQ(a.surface_to_model, b.surface_to_model);
}

class SceneFileRoundTrip : public ::testing::TestWithParam<const char*> {};

TEST_P(SceneFileRoundTrip, LoadedSceneIsBitIdentical) {
  const engine::SceneConfig cfg = prototypes::load_prototype(proto(GetParam()));
  engine::install_scene_mesh(cfg.mesh, nullptr);  // built from the sources
  const auto built = engine::scene_mesh(cfg.mesh);
  ASSERT_TRUE(built->model_blob.empty());
  // C's linear exterior is re-solved whenever the scope re-centres (the contact 5 mm from its
  // centre): slide 3 cm/s for 1 s. (0.6 s moved it twice while the sliding hold pushed along the
  // start normal; along the force, issue 9, the contact crosses one node in 0.6 s: one move.)
  const bool mass_spring = cfg.model == "mass_spring";
  const double slide = mass_spring ? 0.03 : 0.0;
  const Track a = press(cfg, slide);

  const fs::path file = scratch() / (std::string(GetParam()) + ".psim");
  const engine::SceneFileInfo info = engine::write_scene_file(file.string(), cfg);
  EXPECT_EQ(info.model_kind, cfg.model);
  engine::install_scene_mesh(cfg.mesh, nullptr);
  const engine::SceneConfig loaded_cfg =
      engine::load_scene_file(file.string(), prototypes::load_prototype);
  const auto loaded = engine::scene_mesh(cfg.mesh);
  ASSERT_NE(loaded.get(), built.get()) << "the scene must come from the file";
  EXPECT_EQ(loaded->model_blob_kind, cfg.model);
  EXPECT_EQ(!loaded->model_blob.empty(), info.model_blob);
  expect_same_mesh(*built, *loaded);
  const Track b = press(loaded_cfg, slide);
  if (mass_spring) {  // the far field's factorisation was stored, restored and solved again
    EXPECT_TRUE(info.model_blob);
    const auto &x = a.info["mass_spring"], &y = b.info["mass_spring"];
    ASSERT_EQ(x["exterior"], "linear");
    EXPECT_FALSE(x["exterior_factor_restored"].get<bool>());
    EXPECT_TRUE(y["exterior_factor_restored"].get<bool>());
    EXPECT_GE(y["exterior_solves"].get<long>(), 3) << "the scope must move (twice)";
    EXPECT_EQ(x["exterior_solves"], y["exterior_solves"]);
  }

  ASSERT_EQ(a.force.size(), b.force.size());
  ASSERT_GT(a.force.size(), 50u);
  double peak = 0;
  for (size_t i = 0; i < a.force.size(); ++i) {
    ASSERT_TRUE(a.force[i] == b.force[i]) << "step " << i;  // bit-identical, not close
    ASSERT_EQ(a.node[i], b.node[i]) << "step " << i;
    ASSERT_EQ(a.deformation[i], b.deformation[i]) << "step " << i;
    peak = std::max(peak, a.force[i].norm());
  }
  EXPECT_GT(peak, 0.9);  // the press really pressed (target 1 N)
  fs::remove(file);
}

INSTANTIATE_TEST_SUITE_P(Prototypes, SceneFileRoundTrip,
                         ::testing::Values("A", "B", "C", "C1", "D", "N"));

// A stored face index is checked against its surface before the tracker uses it: a file that
// passed its checksums but holds an index out of range, a face order that is not a permutation
// or a hierarchy that is not a tree (a loop would never end) is refused.
TEST(SceneFile, DamagedFaceIndexIsRefused) {
  const engine::SceneConfig cfg = prototypes::load_prototype(proto("B"));
  const auto mesh = engine::scene_mesh(cfg.mesh);
  const long nv = mesh->V.rows(), nf = mesh->F.rows();
  const engine::FaceIndex good = engine::build_face_index(mesh->V, mesh->F);
  ASSERT_EQ(engine::check_face_index(good, nv, nf), "");
  ASSERT_GT(good.bvh.size(), 10u);
  auto bad = [&](auto&& damage, const char* what) {
    engine::FaceIndex ix = good;
    damage(ix);
    EXPECT_NE(engine::check_face_index(ix, nv, nf), "") << what;
  };
  bad([](auto& ix) { ix.vf[7] = -1; }, "vertex-face entry");
  bad([&](auto& ix) { ix.vf[7] = static_cast<int>(nf); }, "vertex-face entry");
  bad([](auto& ix) { std::swap(ix.vf_offset[3], ix.vf_offset[4]); }, "offsets not monotone");
  bad([](auto& ix) { ix.vf_offset.pop_back(); }, "offsets size");
  bad([&](auto& ix) { ix.edge_face[5] = static_cast<int>(nf); }, "edge face");
  bad([](auto& ix) { ix.edge_face[5] = -2; }, "edge face");
  bad([](auto& ix) { ix.order[1] = ix.order[0]; }, "order not a permutation");
  bad([](auto& ix) { ix.face_box.pop_back(); }, "face boxes");
  bad([](auto& ix) { ix.bvh[0].left = 0; }, "self loop");
  bad([](auto& ix) { ix.bvh[1].right = ix.bvh[0].right; }, "two parents");
  bad([&](auto& ix) { ix.bvh[0].right = static_cast<int>(ix.bvh.size()); }, "child range");
  bad([](auto& ix) { ix.bvh[0].right = -1; }, "one child");
  bad([&](auto& ix) { ix.bvh.back().end = static_cast<int>(nf) + 1; }, "run range");
  bad([](auto& ix) { ix.bvh[1].end -= 1; }, "children do not split");
  bad([](auto& ix) { ix.bvh.clear(); }, "no hierarchy");
  bad([](auto& ix) { ix.mean_edge = NAN; }, "mean edge");
}

// The payload checksum's paths (AVX2 where the CPU has it, SSE2, portable) give the same bytes for
// every length (every tail length, whole 1 KiB blocks and one stripe past them, where the
// scramble runs) and every alignment of the data; one flipped bit anywhere changes the result.
TEST(SceneFile, PayloadChecksumPathsAgree) {
  std::string buf(4096 + 200, '\0');
  std::uint64_t x = 0x0123456789ABCDEFULL;
  for (char& c : buf) {  // xorshift bytes
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    c = static_cast<char>(x >> 56);
  }
  using engine::ChecksumPath;
  std::vector<ChecksumPath> paths = {ChecksumPath::portable};
#if defined(__SSE2__)
  paths.push_back(ChecksumPath::sse2);
#endif
  if (engine::psim_checksum_has_avx2()) paths.push_back(ChecksumPath::avx2);
  std::vector<std::size_t> lengths;
  for (std::size_t n = 0; n <= 200; ++n) lengths.push_back(n);
  for (std::size_t n : {1023, 1024, 1025, 1087, 1088, 2048, 2111, 3000, 4096}) lengths.push_back(n);
  for (std::size_t off : {0, 1, 8, 13})
    for (std::size_t n : lengths) {
      const char* p = buf.data() + off;
      const auto ref = engine::psim_payload_checksum(p, n, ChecksumPath::portable);
      for (ChecksumPath path : paths)
        ASSERT_EQ(engine::psim_payload_checksum(p, n, path), ref)
            << "path " << static_cast<int>(path) << " length " << n << " offset " << off;
      ASSERT_EQ(engine::psim_payload_checksum(p, n), ref) << "length " << n;
    }
  const auto whole = engine::psim_payload_checksum(buf.data(), 4096);
  for (std::size_t at = 0; at < 4096; at += 97) {
    std::string b = buf;
    b[at] ^= 0x10;
    for (ChecksumPath path : paths)
      EXPECT_NE(engine::psim_payload_checksum(b.data(), 4096, path), whole) << "byte " << at;
  }
}

// The reader never trusts the file: every prefix of a valid file and every single flipped byte
// is an InputError (never a crash or a silently different scene).
TEST(SceneFile, EveryTruncationAndSampledByteFlipIsAnInputError) {
  const engine::SceneConfig cfg = prototypes::load_prototype(proto("A"));
  const fs::path file = scratch() / "A_corrupt.psim", bad = scratch() / "bad.psim";
  engine::write_scene_file(file.string(), cfg);
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), engine::kSceneFileHeaderBytes + 1000);
  auto write = [&](const std::string& b) {
    std::ofstream out(bad, std::ios::binary | std::ios::trunc);
    out.write(b.data(), static_cast<std::streamsize>(b.size()));
  };
  for (size_t n : {size_t{0}, size_t{4}, size_t{8}, size_t{100}, size_t{127}, size_t{128},
                   size_t{129}, bytes.size() / 2, bytes.size() - 1}) {
    write(bytes.substr(0, n));
    EXPECT_THROW(engine::read_scene_file(bad.string()), InputError) << "truncated at " << n;
  }
  for (size_t at = 0; at < bytes.size(); at += bytes.size() / 61 + 1) {
    std::string b = bytes;
    b[at] ^= 0x20;
    write(b);
    EXPECT_THROW(engine::read_scene_file(bad.string()), InputError) << "flipped byte " << at;
  }
  write(bytes + "x");
  EXPECT_THROW(engine::read_scene_file(bad.string()), InputError);
  write(bytes);
  EXPECT_NO_THROW(engine::read_scene_file(bad.string()));
  fs::remove(file);
  fs::remove(bad);
}

}  // namespace

namespace {

// The mass-spring hook on its own (engine/solvers/far_field.hpp), on prototype C's system: the
// stored factorisation is restored bit for bit and solves bit-identically; a system with one
// spring changed, or a damaged blob, ignores it and factorises (the same as a fresh build).
TEST(SceneFileMassSpring, StoredFarFieldRestoresExactlyAndOnlyForTheSameSystem) {
  using namespace palplab::engine;
  const SceneConfig cfg = prototypes::load_prototype(proto("C"));
  const AdaptiveMassSpring model = mass_spring_adaptive(cfg, *scene_mesh(cfg.mesh));
  const MassSpringSystem& sys = model.sys;
  FarField built;
  far_field_build(sys, built);
  EXPECT_FALSE(built.restored);
  const std::string blob = far_field_save(sys, built);
  ASSERT_FALSE(blob.empty());

  auto same_factor = [](const FarField& x, const FarField& y) {
    return x.dof == y.dof && x.factor.D == y.factor.D &&
           x.factor.P.indices() == y.factor.P.indices() &&
           x.factor.Pinv.indices() == y.factor.Pinv.indices() &&
           x.factor.L.nonZeros() == y.factor.L.nonZeros() &&
           std::memcmp(x.factor.L.outerIndexPtr(), y.factor.L.outerIndexPtr(),
                       sizeof(int) * (x.factor.L.cols() + 1)) == 0 &&
           std::memcmp(x.factor.L.innerIndexPtr(), y.factor.L.innerIndexPtr(),
                       sizeof(int) * x.factor.L.nonZeros()) == 0 &&
           std::memcmp(x.factor.L.valuePtr(), y.factor.L.valuePtr(),
                       sizeof(double) * x.factor.L.nonZeros()) == 0;
  };
  FarField loaded;
  far_field_build(sys, loaded, &blob);
  EXPECT_TRUE(loaded.restored);
  ASSERT_TRUE(same_factor(built, loaded));
  std::vector<int> patch;  // three nodes that are not fixed
  for (int i = 0; i < static_cast<int>(sys.nodes()) && patch.size() < 3; ++i)
    if (!sys.fixed[i]) patch.push_back(i);
  const std::vector<double> w = {0.5, 0.3, 0.2};
  far_field_solve(built, patch, w, Eigen::Vector3d(0, 0.6, -0.8));
  far_field_solve(loaded, patch, w, Eigen::Vector3d(0, 0.6, -0.8));
  EXPECT_TRUE(built.g == loaded.g);  // bit-identical
  EXPECT_GT(built.g.norm(), 0.0);

  MassSpringSystem other = sys;  // one spring 1 % stiffer: another K
  other.springs.ks[other.springs.size() / 2] *= 1.01;
  FarField fresh, ignored;
  far_field_build(other, fresh);
  far_field_build(other, ignored, &blob);
  EXPECT_FALSE(ignored.restored);
  EXPECT_TRUE(same_factor(fresh, ignored));
  EXPECT_FALSE(same_factor(built, ignored));

  for (const std::size_t cut :
       {std::size_t(0), std::size_t(7), std::size_t(40), blob.size() / 2, blob.size() - 1}) {
    FarField f;
    const std::string bad = blob.substr(0, cut);
    far_field_build(sys, f, &bad);
    EXPECT_FALSE(f.restored) << "cut at " << cut;
    EXPECT_TRUE(same_factor(built, f));
  }
  std::string longer = blob + '\0';
  FarField f;
  far_field_build(sys, f, &longer);
  EXPECT_FALSE(f.restored);
}

// tet_springs takes the scene mesh's stored tet edges (a loaded file need not sort them again)
// only when they are exactly unique_edges(T): the same springs bit for bit, and any other edge
// list (reordered, one missing, one extra, out of range) falls back to computing them.
TEST(SceneFileMassSpring, TetSpringsUseGivenEdgesOnlyWhenTheyAreTheTetsEdges) {
  using namespace palplab::engine;
  const SceneConfig cfg = prototypes::load_prototype(proto("C"));
  const auto cm = scene_mesh(cfg.mesh);
  ASSERT_TRUE(cm->tet);
  const Eigen::VectorXd E = Eigen::VectorXd::LinSpaced(cm->model_T.rows(), 5e4, 2e5);
  const Springs ref = tet_springs(cm->model_V, cm->model_T, E, 0.002);
  auto same = [&](const Springs& s) {
    return s.E == ref.E && s.rest == ref.rest && s.ks == ref.ks && s.kd == ref.kd;
  };
  EXPECT_TRUE(same(tet_springs(cm->model_V, cm->model_T, E, 0.002, &cm->model_E)));
  RowMatX2i swapped = cm->model_E;
  swapped.row(3).swap(swapped.row(4));
  RowMatX2i missing = cm->model_E.topRows(cm->model_E.rows() - 1);
  RowMatX2i extra(cm->model_E.rows() + 1, 2);
  extra << cm->model_E, cm->model_V.rows() - 2, cm->model_V.rows() - 1;
  RowMatX2i flipped = cm->model_E;
  std::swap(flipped(0, 0), flipped(0, 1));
  RowMatX2i range = cm->model_E;
  range(range.rows() - 1, 1) = static_cast<int>(cm->model_V.rows());
  for (const RowMatX2i* e : {&swapped, &missing, &extra, &flipped, &range})
    EXPECT_TRUE(same(tet_springs(cm->model_V, cm->model_T, E, 0.002, e)));
}

// The FEM hook on its own: a linear model built from the stored precomputation restores it
// (no assembly, no factorisation) and steps bit-identically under a stiff contact; a model with
// other inputs (another Young's modulus, another step) ignores it and computes.
TEST(SceneFileFem, StoredLinearPrecomputationRestoresExactlyAndOnlyForTheSameInputs) {
  using namespace palplab;
  using namespace palplab::engine;
  const mesh::TetMesh tm = fem_block_mesh(4, 4, 3, Eigen::Vector3d(0.04, 0.04, 0.03));
  const TetMaterials mat = uniform_materials(tm.T.rows(), 5e4, 0.45, 1000.0);
  std::vector<std::uint8_t> fixed(tm.V.rows(), 0);
  for (long i = 0; i < tm.V.rows(); ++i) fixed[i] = tm.V(i, 2) < 1e-9;
  int top = 0;  // the node nearest to the centre of the top face
  const Eigen::RowVector3d centre(0.02, 0.02, 0.03);
  for (long i = 0; i < tm.V.rows(); ++i)
    if ((tm.V.row(i) - centre).norm() < (tm.V.row(top) - centre).norm()) top = static_cast<int>(i);
  FemModelOptions opt;
  opt.rayleigh_alpha = 1.0;
  opt.rayleigh_beta = 0.002;
  const double h = 1e-3;
  FemModel built(tm, mat, fixed, opt);
  const std::string blob = built.save_precomputation(h);
  ASSERT_FALSE(blob.empty());
  EXPECT_FALSE(built.precomputation_loaded());

  FemModelOptions with = opt;
  with.precomputed = &blob;
  FemModel loaded(tm, mat, fixed, with);
  EXPECT_TRUE(loaded.precomputation_loaded());
  FemModel fresh(tm, mat, fixed, opt);
  for (FemModel* m : {&loaded, &fresh}) {
    m->contact_node = top;
    m->contact_normal = Eigen::Vector3d::UnitZ();
    m->contact_k = 2000.0;
  }
  double peak = 0;
  for (int s = 0; s < 300; ++s) {
    const Eigen::Vector3d x = tm.V.row(top).transpose() - Eigen::Vector3d(0, 0, 1e-5 * s);
    loaded.contact_point = fresh.contact_point = x;
    loaded.step(h);
    fresh.step(h);
    ASSERT_TRUE(loaded.device_force() == fresh.device_force()) << "step " << s;
    peak = std::max(peak, fresh.device_force().norm());
  }
  EXPECT_TRUE(loaded.displacement() == fresh.displacement());
  EXPECT_GT(peak, 1.0);  // it pressed (3 mm at 2000 N/m, minus the tissue's give)

  // Other inputs: the blob is ignored, the model computes (and still works).
  const TetMaterials stiffer = uniform_materials(tm.T.rows(), 6e4, 0.45, 1000.0);
  FemModel other(tm, stiffer, fixed, with);
  EXPECT_FALSE(other.precomputation_loaded());
  FemModelOptions damped = with;
  damped.rayleigh_beta = 0.003;
  EXPECT_FALSE(FemModel(tm, mat, fixed, damped).precomputation_loaded());
  // A damaged blob is ignored, never trusted.
  FemModelOptions bad = opt;
  const std::string damaged = blob.substr(0, blob.size() - 3);
  bad.precomputed = &damaged;
  EXPECT_FALSE(FemModel(tm, mat, fixed, bad).precomputation_loaded());
  // A different step size refactorises on the first step (correct, just not from the file).
  FemModel loaded2(tm, mat, fixed, with);
  FemModel fresh2(tm, mat, fixed, opt);
  loaded2.step(2e-3);
  fresh2.step(2e-3);
  EXPECT_TRUE(loaded2.displacement() == fresh2.displacement());
}

}  // namespace

namespace {

// Prototype N (needle, issue 16): the file stores the needle model's precomputation (interface
// faces, target surface, point-location grid, tissue surfaces) and the finger's layer table.
// A scene loaded from it palpates with the finger at several skin nodes and then inserts the
// needle through the layers with bit-identical forces, events and tip-to-target distances.
struct NeedleTrack {
  std::vector<Eigen::Vector3d> force;
  std::vector<double> tip_to_target;
  std::vector<std::pair<int, double>> events;  // kind, value
};

NeedleTrack palpate_then_insert(const engine::SceneConfig& cfg) {
  engine::Scene s = engine::make_scene(cfg);
  const auto& g = s.geometry();
  NeedleTrack t;
  auto record = [&](const engine::Rendered& r) {
    t.force.push_back(r.force);
    t.tip_to_target.push_back(r.visible_tip_to_target);
    for (const auto& e : r.events) t.events.push_back({static_cast<int>(e.kind), e.value});
  };
  // The finger: press 4 mm into every 40th skin node.
  for (long v = 0; v < g.V.rows(); v += 40) {
    const Eigen::Vector3d p = g.V.row(v).transpose(), n = g.N.row(v).transpose();
    for (int i = 0; i <= 40; ++i) record(s.step(p + (0.005 - 0.009 * i / 40.0) * n));
    for (int i = 0; i < 20; ++i) record(s.step(p + 0.01 * n));
  }
  // The needle: straight along +y at x = -2 mm, z = 0 (skin, fat, muscle, capsule).
  s.set_tool("needle", Eigen::Vector3d::UnitY());
  for (double y = -0.09; y <= -0.01; y += 2e-5) record(s.step(Eigen::Vector3d(-0.002, y, 0.0)));
  return t;
}

TEST(SceneFileNeedle, StoredNeedlePrecomputationLoadsAndStepsBitIdentically) {
  const engine::SceneConfig cfg = prototypes::load_prototype(proto("N"));
  engine::install_scene_mesh(cfg.mesh, nullptr);
  const auto built = engine::scene_mesh(cfg.mesh);
  const NeedleTrack a = palpate_then_insert(cfg);
  std::shared_ptr<const engine::TissueSurfaces> tissues_built;
  {
    engine::Scene s = engine::make_scene(cfg);
    tissues_built = s.geometry().tissues;
  }

  const fs::path file = scratch() / "N.psim";
  const engine::SceneFileInfo info = engine::write_scene_file(file.string(), cfg);
  EXPECT_TRUE(info.model_blob) << "the needle model's precomputation must be stored";
  engine::install_scene_mesh(cfg.mesh, nullptr);
  const engine::SceneConfig loaded_cfg =
      engine::load_scene_file(file.string(), prototypes::load_prototype);
  const auto loaded = engine::scene_mesh(cfg.mesh);
  ASSERT_NE(loaded.get(), built.get()) << "the scene must come from the file";
  EXPECT_EQ(loaded->model_blob_kind, "needle");
  ASSERT_FALSE(loaded->model_blob.empty());
  expect_same_mesh(*built, *loaded);
  const NeedleTrack b = palpate_then_insert(loaded_cfg);

  ASSERT_EQ(a.force.size(), b.force.size());
  double finger_peak = 0;
  for (size_t i = 0; i < a.force.size(); ++i) {
    ASSERT_TRUE(a.force[i] == b.force[i]) << "step " << i;
    ASSERT_EQ(a.tip_to_target[i], b.tip_to_target[i]) << "step " << i;
    finger_peak = std::max(finger_peak, a.force[i].norm());
  }
  EXPECT_GT(finger_peak, 0.5);  // the finger really pressed
  EXPECT_EQ(a.events, b.events);
  int entered = 0;
  for (const auto& [k, v] : a.events)
    entered += k == static_cast<int>(engine::EventKind::tissue_entered);
  EXPECT_GE(entered, 4);  // the needle really went through the layers to the capsule

  engine::Scene s = engine::make_scene(loaded_cfg);
  ASSERT_TRUE(s.geometry().tissues && tissues_built);
  expect_same(tissues_built->V, s.geometry().tissues->V, "tissue surface V");
  expect_same(tissues_built->F, s.geometry().tissues->F, "tissue surface F");
  EXPECT_EQ(tissues_built->vertex_region, s.geometry().tissues->vertex_region);
  EXPECT_EQ(tissues_built->soft_regions, s.geometry().tissues->soft_regions);
  fs::remove(file);
}

// A file's mesh goes into the cache before the prototype is read (so reading it does not
// regenerate the mesh); a stale file must not leave that mesh behind.
TEST(SceneFileNeedle, AStaleFileLeavesTheCacheAsItWas) {
  const fs::path dir = scratch() / "stale_n";
  fs::create_directories(dir);
  const fs::path p = dir / "N.json";
  fs::copy_file(proto("N"), p, fs::copy_options::overwrite_existing);
  const engine::SceneConfig cfg = prototypes::load_prototype(p.string());
  const fs::path file = dir / "N.psim";
  engine::write_scene_file(file.string(), cfg);
  engine::install_scene_mesh(cfg.mesh, nullptr);
  {
    std::ofstream out(p, std::ios::app);
    out << "\n";  // the prototype changed: the file is stale
  }
  EXPECT_THROW(engine::load_scene_file(file.string(), prototypes::load_prototype), InputError);
  EXPECT_EQ(engine::cached_scene_mesh(cfg.mesh.key()), nullptr);
  fs::remove_all(dir);
}

}  // namespace
