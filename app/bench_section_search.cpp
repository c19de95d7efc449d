// `palplab bench search`: the touched-node search, linear scan vs octree (depth and leaf size
// varied), on geodesic spheres of 642 ... 23042 vertices, the tract surfaces of the SPEC's figures
// (994 and 14392 vertices; published on a Pentium IV 2.0 GHz: 994 -> linear 1.05 ms vs octree
// 0.17 ms, 14392 -> 14.84 vs 1.10 ms) and the three organ models (Model-A tract 1500, the
// stomach 192, Model-C's tet-mesh nodes 2426). Queries are mesh nodes displaced by up to 5 mm
// (where a haptic contact point is). Each repetition times the same query batch with every
// method in turn, so the ratios are measured in the same run; every octree answer is checked
// against the linear scan (metric "mismatches" must be 0).
#include <chrono>
#include <random>

#include "analysis/svg.hpp"
#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/spatial/octree.hpp"

namespace {
using namespace palplab;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;
using Clock = std::chrono::steady_clock;

struct Case {
  std::string name, what;
  mesh::Positions V;
};

struct SearchVariant {
  std::string name;
  int depth, leaf;  // depth 0 = linear scan
};

std::vector<BenchResult> run_search(const BenchOptions& o) {
  std::vector<Case> cases;
  auto sphere = [&](int n) {
    mesh::SurfaceMesh m = mesh::generate_sphere(n);
    cases.push_back({"sphere" + std::to_string(m.V.rows()),
                     "sphere, " + std::to_string(m.V.rows()) + " vertices", m.V});
  };
  auto tract = [&](int n, const std::string& label) {
    mesh::SurfaceMesh m = mesh::generate_tract({n, 0});
    cases.push_back({"tract" + std::to_string(m.V.rows()),
                     label + ", " + std::to_string(m.V.rows()) + " vertices", m.V});
  };
  for (int n : o.quick ? std::vector<int>{642, 10242} : std::vector<int>{642, 2562, 10242, 23522})
    sphere(n);
  tract(994, "tract (SPEC: linear 1.05 ms, octree 0.17 ms)");
  tract(14392, "tract (SPEC: linear 14.84 ms, octree 1.10 ms)");
  tract(1500, "Model-A tract");
  {
    mesh::SurfaceMesh m = mesh::generate_stomach(0);
    cases.push_back({"stomach", "stomach, " + std::to_string(m.V.rows()) + " vertices", m.V});
  }
  if (!o.quick) {
    mesh::TetMesh tm = mesh::generate_model_c();
    cases.push_back(
        {"model_c", "Model-C tet nodes, " + std::to_string(tm.V.rows()) + " nodes", tm.V});
  }
  const std::vector<SearchVariant> variants =
      o.quick ? std::vector<SearchVariant>{{"linear", 0, 0}, {"octree_d10_l8", 10, 8}}
              : std::vector<SearchVariant>{{"linear", 0, 0},
                                           {"octree_d10_l8", 10, 8},
                                           {"octree_d10_l2", 10, 2},
                                           {"octree_d10_l32", 10, 32},
                                           {"octree_d4_l8", 4, 8}};
  const int reps = o.quick ? 5 : 9;
  const int nq = o.quick ? 400 : 2000;
  std::vector<BenchResult> out;
  for (const Case& c : cases) {
    std::mt19937_64 rng(1);
    std::uniform_int_distribution<int> pick(0, static_cast<int>(c.V.rows()) - 1);
    std::normal_distribution<double> nd(0, 0.005 / std::sqrt(3.0));
    std::vector<mesh::Vec3> q(nq);
    for (auto& x : q) x = mesh::row3(c.V, pick(rng)) + mesh::Vec3(nd(rng), nd(rng), nd(rng));
    std::vector<spatial::Octree> trees;
    std::vector<double> build_s;
    for (const SearchVariant& v : variants) {
      const auto t0 = Clock::now();
      trees.push_back(v.depth ? spatial::build_octree(c.V, v.depth, v.leaf) : spatial::Octree{});
      build_s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    std::vector<int> truth(nq);
    for (int i = 0; i < nq; ++i) truth[i] = spatial::linear_nearest(c.V, q[i]);
    std::vector<std::vector<double>> per_query(variants.size());
    std::vector<double> cold(variants.size());
    std::vector<long> mismatches(variants.size(), 0);
    for (int rep = 0; rep <= reps; ++rep)  // rep 0: cold
      for (size_t k = 0; k < variants.size(); ++k) {
        long bad = 0;
        const auto t0 = Clock::now();
        for (int i = 0; i < nq; ++i) {
          const int got = variants[k].depth ? spatial::nearest(trees[k], c.V, q[i])
                                            : spatial::linear_nearest(c.V, q[i]);
          bad += got != truth[i];
        }
        const double s = std::chrono::duration<double>(Clock::now() - t0).count() / nq;
        mismatches[k] += bad;
        if (rep == 0)
          cold[k] = s;
        else
          per_query[k].push_back(s);
      }
    const double lin = engine::median(per_query[0]);
    for (size_t k = 0; k < variants.size(); ++k) {
      const SearchVariant& v = variants[k];
      BenchResult r =
          app::result_from_samples(c.name + "_" + v.name,
                                   c.what + ": " +
                                       (v.depth ? "octree depth " + std::to_string(v.depth) +
                                                      ", <= " + std::to_string(v.leaf) + " per leaf"
                                                : std::string("linear scan")) +
                                       " (s per query)",
                                   per_query[k], cold[k]);
      r.metrics = {{"vertices", static_cast<double>(c.V.rows())},
                   {"linear_over_this", lin / r.median_s},
                   {"mismatches", static_cast<double>(mismatches[k])}};
      if (v.depth) {
        r.metrics.push_back({"leaves", static_cast<double>(spatial::count_leaves(trees[k]))});
        r.metrics.push_back({"build_s", build_s[k]});
      }
      out.push_back(r);
    }
  }
  // Figure: time per query against vertex count (spheres), log10 on both axes.
  std::vector<analysis::Series> series;
  for (size_t k = 0; k < variants.size(); ++k) {
    analysis::Series s;
    s.name = variants[k].name;
    s.colour = static_cast<int>(k);
    for (const BenchResult& r : out)
      if (r.name.rfind("sphere", 0) == 0 && r.name.size() > variants[k].name.size() &&
          r.name.compare(r.name.size() - variants[k].name.size(), std::string::npos,
                         variants[k].name) == 0) {
        s.x.push_back(std::log10(r.metrics[0].second));
        s.y.push_back(std::log10(r.median_s * 1e6));
        s.lo.push_back(std::log10(r.min_s * 1e6));
        s.hi.push_back(std::log10(r.max_s * 1e6));
      }
    series.push_back(s);
  }
  app::write_figure(o, "search.svg",
                    analysis::svg_line_plot(series, "Touched-node search on spheres",
                                            "log10 vertices", "log10 time per query (us)"));
  return out;
}

palplab::app::BenchSectionRegistration section_search{
    "search", "touched-node search: linear scan vs octree (depth, leaf size), per query",
    run_search};
}  // namespace
