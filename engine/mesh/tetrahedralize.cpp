#include "engine/mesh/tetrahedralize.hpp"

#include <tetgen.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "common/input_error.hpp"
#include "engine/mesh/io.hpp"
#include "engine/spatial/octree.hpp"

namespace palplab::mesh {

namespace {

std::string tetgen_error(int code) {
  switch (code) {
    case 1:
      return "TetGen ran out of memory";
    case 2:
      return "TetGen internal error";
    case 3:
      return "TetGen found self-intersecting input faces (run `palplab mesh check`)";
    case 4:
      return "TetGen found a very small input feature (faces or edges nearly touching)";
    case 5:
      return "TetGen found two very close input facets";
    case 10:
      return "TetGen rejected the input (open or inconsistent surface?)";
    default:
      return "TetGen failed with code " + std::to_string(code);
  }
}

}  // namespace

std::vector<RegionSeed> read_region_seeds(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("cannot open region file", path);
  std::string line;
  int lineno = 0, expected = -1;
  std::vector<RegionSeed> seeds;
  auto where = [&](int col = 0) { return SourceLocation{path, lineno, col}; };
  while (std::getline(in, line)) {
    ++lineno;
    if (auto h = line.find('#'); h != std::string::npos) line.erase(h);
    std::istringstream ls(line);
    std::string first;
    if (!(ls >> first)) continue;
    ls.seekg(0);
    if (expected < 0) {
      long n;
      if (!(ls >> n) || n < 0 || n > 1000000)
        throw InputError(where(1), "expected the number of regions (a non-negative integer)");
      expected = static_cast<int>(n);
      continue;
    }
    RegionSeed s;
    if (!(ls >> s.index >> s.point.x() >> s.point.y() >> s.point.z() >> s.region_id))
      throw InputError(where(1), "expected `index x y z region_id attribute`");
    if (!(ls >> s.max_volume)) s.max_volume = 0;
    std::string extra;
    if (ls >> extra)
      throw InputError(where(), "unexpected text '" + extra + "' after the attribute");
    if (!s.point.allFinite()) throw InputError(where(), "region point is not finite");
    seeds.push_back(s);
  }
  if (expected < 0) throw InputError("empty region file (expected the number of regions)", path);
  if (static_cast<int>(seeds.size()) != expected)
    throw InputError(SourceLocation{path, lineno}, "the first line announces " +
                                                       std::to_string(expected) + " regions but " +
                                                       std::to_string(seeds.size()) + " follow");
  return seeds;
}

void write_region_seeds(const std::string& path, const std::vector<RegionSeed>& seeds) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write region file", path);
  out << seeds.size() << "\n";
  for (auto& s : seeds)
    out << s.index << " " << format_exact(s.point.x()) << " " << format_exact(s.point.y()) << " "
        << format_exact(s.point.z()) << " " << s.region_id << " " << format_exact(s.max_volume)
        << "\n";
}

std::string tetgen_switches(const TetOptions& opt) {
  // p: PLC input; z: number from 0; Q: quiet; Y: keep the surface as given.
  std::string s = "pzQ";
  if (opt.keep_surface) s += "Y";
  if (opt.quality > 0) s.append("q").append(format_exact(opt.quality));
  if (opt.quality > 0 && opt.min_dihedral > 0) s.append("/").append(format_exact(opt.min_dihedral));
  if (opt.max_volume > 0) s.append("a").append(format_exact(opt.max_volume));
  if (!opt.seeds.empty()) {
    s += "A";
    bool per_region = std::any_of(opt.seeds.begin(), opt.seeds.end(),
                                  [](const RegionSeed& r) { return r.max_volume > 0; });
    if (per_region && opt.max_volume <= 0) s += "a";  // bare -a: use the region constraints
  }
  return s;
}

TetMesh tetrahedralize(const SurfaceMesh& s, const TetOptions& opt) {
  if (opt.quality < 0 || (opt.quality > 0 && opt.quality < 1.0))
    throw InputError("--quality must be 0 (off) or a radius-edge ratio >= 1.0, got " +
                     format_exact(opt.quality));
  if (opt.max_volume < 0)
    throw InputError("--max-volume must be > 0, got " + format_exact(opt.max_volume));
  tetgenio in, out;
  in.firstnumber = 0;
  in.numberofpoints = static_cast<int>(s.V.rows());
  in.pointlist = new REAL[3 * in.numberofpoints];
  for (int i = 0; i < in.numberofpoints; ++i)
    for (int k = 0; k < 3; ++k) in.pointlist[3 * i + k] = s.V(i, k);
  in.numberoffacets = static_cast<int>(s.F.rows());
  in.facetlist = new tetgenio::facet[in.numberoffacets];
  in.facetmarkerlist = new int[in.numberoffacets];
  for (int f = 0; f < in.numberoffacets; ++f) {
    tetgenio::facet& fc = in.facetlist[f];
    tetgenio::init(&fc);
    fc.numberofpolygons = 1;
    fc.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&fc.polygonlist[0]);
    fc.polygonlist[0].numberofvertices = 3;
    fc.polygonlist[0].vertexlist = new int[3]{s.F(f, 0), s.F(f, 1), s.F(f, 2)};
    in.facetmarkerlist[f] = 1;
  }
  if (!opt.seeds.empty()) {
    in.numberofregions = static_cast<int>(opt.seeds.size());
    in.regionlist = new REAL[5 * in.numberofregions];
    for (int r = 0; r < in.numberofregions; ++r) {
      const RegionSeed& g = opt.seeds[r];
      REAL* x = in.regionlist + 5 * r;
      x[0] = g.point.x();
      x[1] = g.point.y();
      x[2] = g.point.z();
      x[3] = g.region_id;
      x[4] = g.max_volume > 0 ? g.max_volume : -1;
    }
  }
  std::string sw = tetgen_switches(opt);
  std::vector<char> swbuf(sw.begin(), sw.end());
  swbuf.push_back('\0');
  try {
    ::tetrahedralize(swbuf.data(), &in, &out);
  } catch (int code) {
    throw InputError(tetgen_error(code));
  }
  if (out.numberoftetrahedra <= 0) throw InputError("TetGen produced no tetrahedra");

  Positions V(out.numberofpoints, 3);
  for (int i = 0; i < out.numberofpoints; ++i)
    V.row(i) << out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2];
  Tets T(out.numberoftetrahedra, 4);
  Eigen::VectorXi A = Eigen::VectorXi::Constant(out.numberoftetrahedra, opt.default_attribute);
  for (int t = 0; t < out.numberoftetrahedra; ++t) {
    for (int k = 0; k < 4; ++k) T(t, k) = out.tetrahedronlist[out.numberofcorners * t + k];
    if (!opt.seeds.empty() && out.numberoftetrahedronattributes > 0) {
      const double a = out.tetrahedronattributelist[out.numberoftetrahedronattributes * t];
      // Tets in no seeded region get attribute 0 from TetGen: keep the default for them.
      if (a != 0) A[t] = static_cast<int>(std::lround(a));
    }
  }
  Regions regions;
  if (!s.regions.empty()) {
    regions.names = s.regions.names;
    regions.id.resize(T.rows());
    const Eigen::VectorXi vr = vertex_regions(s);
    const int ns = static_cast<int>(s.V.rows());
    const int nr = static_cast<int>(regions.names.size());
    spatial::Octree tree;
    bool have_tree = false;
    for (int t = 0; t < T.rows(); ++t) {
      std::vector<int> votes(nr, 0);
      int any = 0;
      for (int k = 0; k < 4; ++k)
        if (T(t, k) < ns && vr[T(t, k)] >= 0) {
          ++votes[vr[T(t, k)]];
          ++any;
        }
      if (any) {
        regions.id[t] =
            static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
      } else {
        if (!have_tree) {
          tree = spatial::build_octree(s.V, 12, 8);
          have_tree = true;
        }
        Vec3 c = Vec3::Zero();
        for (int k = 0; k < 4; ++k) c += row3(V, T(t, k)) / 4;
        regions.id[t] = vr[spatial::nearest(tree, s.V, c)];
      }
    }
  }
  return make_tet_mesh(std::move(V), std::move(T), std::move(A), std::move(regions));
}

}  // namespace palplab::mesh
