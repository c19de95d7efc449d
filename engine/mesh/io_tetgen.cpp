// TetGen .node/.ele/.face/.neigh (+ palplab's .names side table) and read_mesh dispatch.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "engine/mesh/io.hpp"
#include "engine/mesh/text_reader.hpp"

namespace palplab::mesh {

using detail::finish_out;
using detail::open_out;
using detail::TextReader;

namespace {

// Reads the index of a TetGen record and checks it follows the previous one.
long record_index(TextReader& r, const std::string& t, long expected, long& base, bool first) {
  const long i = r.integer(t, "the record index");
  if (first) {
    if (i != 0 && i != 1) r.fail("the first index must be 0 or 1 (TetGen numbering), got " + t);
    base = i;
  } else if (i != expected + base) {
    r.fail("expected index " + std::to_string(expected + base) + ", got " + t);
  }
  return i;
}

}  // namespace

std::string tetgen_base(const std::string& path) {
  for (const char* e : {".node", ".ele", ".face", ".neigh", ".names"}) {
    const std::string s = e;
    if (path.size() > s.size() && path.compare(path.size() - s.size(), s.size(), s) == 0)
      return path.substr(0, path.size() - s.size());
  }
  return path;
}

bool is_tetgen_path(const std::string& path) {
  const std::string e = extension(path);
  return e == ".node" || e == ".ele";
}

TetMesh read_tetgen(const std::string& path) {
  const std::string base = tetgen_base(path);
  std::vector<std::string> t;
  // .node
  TextReader rn(base + ".node");
  if (!rn.tokens(t) || t.size() < 2) rn.fail("expected `<#points> 3 [<#attributes> <#markers>]`");
  const long nv = rn.integer(t[0], "the point count");
  detail::check_count(rn, nv, "point");
  if (rn.integer(t[1], "the dimension") != 3) rn.fail("only 3-dimensional points are supported");
  const long nattr = t.size() > 2 ? rn.integer(t[2], "the attribute count") : 0;
  const long nmark = t.size() > 3 ? rn.integer(t[3], "the marker count") : 0;
  if (nattr < 0 || nmark < 0 || nmark > 1) rn.fail("bad attribute or marker count");
  Positions V(nv, 3);
  long node_base = 0;
  for (long i = 0; i < nv; ++i) {
    if (!rn.tokens(t))
      rn.fail("unexpected end of file: " + std::to_string(nv) + " points announced, " +
              std::to_string(i) + " found");
    if (static_cast<long>(t.size()) != 4 + nattr + nmark)
      rn.fail("expected `index x y z` + " + std::to_string(nattr) + " attributes + " +
              std::to_string(nmark) + " markers");
    record_index(rn, t[0], i, node_base, i == 0);
    for (int c = 0; c < 3; ++c) V(i, c) = rn.number(t[1 + c], "a coordinate");
  }
  // A line past the announced count is a count that is wrong (or a file cut and joined): taken
  // silently, the mesh would lose it.
  if (rn.tokens(t))
    rn.fail("unexpected data after the " + std::to_string(nv) + " points the file announces");
  // .ele
  TextReader re(base + ".ele");
  if (!re.tokens(t) || t.size() < 2) re.fail("expected `<#tets> <nodes per tet> [<#attributes>]`");
  const long nt = re.integer(t[0], "the tet count");
  detail::check_count(re, nt, "tet");
  const long npt = re.integer(t[1], "the nodes per tet");
  if (npt != 4 && npt != 10) re.fail("nodes per tet must be 4 or 10");
  const long ta = t.size() > 2 ? re.integer(t[2], "the attribute count") : 0;
  if (ta < 0 || ta > 16) re.fail("bad attribute count");
  Tets T(nt, 4);
  Eigen::VectorXi A = Eigen::VectorXi::Zero(nt), R = Eigen::VectorXi::Constant(nt, -1);
  long ele_base = 0;
  for (long i = 0; i < nt; ++i) {
    if (!re.tokens(t))
      re.fail("unexpected end of file: " + std::to_string(nt) + " tets announced, " +
              std::to_string(i) + " found");
    if (static_cast<long>(t.size()) != 1 + npt + ta)
      re.fail("expected `index` + " + std::to_string(npt) + " nodes + " + std::to_string(ta) +
              " attributes");
    record_index(re, t[0], i, ele_base, i == 0);
    for (int k = 0; k < 4; ++k) {
      const long raw = re.integer(t[1 + k], "a node index");
      if (raw < node_base || raw - node_base >= nv)  // (no subtraction that could overflow)
        re.fail("node index " + t[1 + k] + " out of range: the .node file numbers its " +
                std::to_string(nv) + " nodes from " + std::to_string(node_base) + " (" +
                std::to_string(node_base) + " to " + std::to_string(node_base + nv - 1) +
                "), and the .ele must use the same numbering");
      const long v = raw - node_base;
      T(i, k) = static_cast<int>(v);
    }
    for (long a = 0; a < ta && a < 2; ++a) {
      const double x = re.number(t[1 + npt + a], "an attribute");
      if (x != std::round(x) || std::abs(x) > 1e9)
        re.fail("attribute " + t[1 + npt + a] + " is not an integer in [-1e9, 1e9]");
      (a == 0 ? A : R)[i] = static_cast<int>(x);
    }
  }
  if (re.tokens(t))
    re.fail("unexpected data after the " + std::to_string(nt) + " tets the file announces");
  Regions regions;
  const std::string names_path = base + ".names";
  if (std::filesystem::exists(names_path)) {
    TextReader rr(names_path);
    if (!rr.tokens(t) || t.size() != 1) rr.fail("expected the number of region names");
    const long n = rr.integer(t[0], "the region count");
    detail::check_count(rr, n, "region", 100000);
    regions.names.assign(n, "");
    // Each id once, each name once, nothing after the last (review 2026-12-06, second: an id
    // given twice left another without a name; a shorter list read lines of nothing).
    std::vector<char> named(n, 0);
    std::map<std::string, long> id_of;
    for (long i = 0; i < n; ++i) {
      if (!rr.tokens(t))
        rr.fail("the file announces " + std::to_string(n) + " region names but holds " +
                std::to_string(i));
      if (t.size() < 2) rr.fail("expected `<id> <name>`");
      const long id = rr.integer(t[0], "a region id");
      if (id < 0 || id >= n)
        rr.fail("region id " + t[0] + " out of range [0, " + std::to_string(n) + ")");
      if (named[id]) rr.fail("region id " + t[0] + " is named twice");
      std::string name = t[1];
      for (size_t c = 2; c < t.size(); ++c) name += " " + t[c];
      if (const auto [it, fresh] = id_of.emplace(name, id); !fresh)
        rr.fail("region name \"" + name + "\" is given to ids " + std::to_string(it->second) +
                " and " + t[0] + " (expected one id per region)");
      named[id] = 1;
      regions.names[id] = name;
    }
    if (rr.tokens(t))
      rr.fail("more lines than the " + std::to_string(n) + " region names the file announces");
    if (ta < 2)
      throw InputError(base + ".names gives region names but " + base +
                       ".ele has no second (region) attribute");
    for (long i = 0; i < nt; ++i)
      if (R[i] < -1 || R[i] >= n)
        throw InputError(SourceLocation{base + ".ele"},
                         "tet " + std::to_string(i) + " has region id " + std::to_string(R[i]) +
                             " but " + names_path + " names " + std::to_string(n) + " regions");
    regions.id = R;
  }
  try {
    detail::check_region_names(regions.names, names_path);
    return make_tet_mesh(std::move(V), std::move(T), std::move(A), std::move(regions));
  } catch (const InputError& e) {
    throw InputError(e.what(), base + ".ele");
  }
}

void write_tetgen(const std::string& path, const TetMesh& m) {
  const std::string base = tetgen_base(path);
  const bool regions = !m.regions.empty();
  {
    auto out = open_out(base + ".node");
    out << m.V.rows() << " 3 0 0\n";
    for (int i = 0; i < m.V.rows(); ++i)
      out << i << " " << format_exact(m.V(i, 0)) << " " << format_exact(m.V(i, 1)) << " "
          << format_exact(m.V(i, 2)) << "\n";
    finish_out(out, base + ".node");
  }
  {
    auto out = open_out(base + ".ele");
    out << m.T.rows() << " 4 " << (regions ? 2 : 1) << "\n";
    for (int t = 0; t < m.T.rows(); ++t) {
      out << t << " " << m.T(t, 0) << " " << m.T(t, 1) << " " << m.T(t, 2) << " " << m.T(t, 3)
          << " " << m.attribute[t];
      if (regions) out << " " << m.regions.id[t];
      out << "\n";
    }
    finish_out(out, base + ".ele");
  }
  {
    const BoundaryFaces b = boundary_faces(m);
    auto out = open_out(base + ".face");
    out << b.F.rows() << " 1\n";
    for (int f = 0; f < b.F.rows(); ++f)
      out << f << " " << b.F(f, 0) << " " << b.F(f, 1) << " " << b.F(f, 2) << " "
          << m.attribute[b.tet[f]] << "\n";
    finish_out(out, base + ".face");
  }
  {
    const Tets N = tet_neighbours(m);
    auto out = open_out(base + ".neigh");
    out << N.rows() << " 4\n";
    for (int t = 0; t < N.rows(); ++t)
      out << t << " " << N(t, 0) << " " << N(t, 1) << " " << N(t, 2) << " " << N(t, 3) << "\n";
    finish_out(out, base + ".neigh");
  }
  if (regions) {
    auto out = open_out(base + ".names");
    out << m.regions.names.size() << "\n";
    for (size_t i = 0; i < m.regions.names.size(); ++i)
      out << i << " " << m.regions.names[i] << "\n";
    finish_out(out, base + ".names");
  } else {
    std::filesystem::remove(base + ".names");  // a stale table would mislabel the new mesh
  }
}

Faces read_tetgen_face(const std::string& path, Eigen::VectorXi* markers) {
  TextReader r(path);
  std::vector<std::string> t;
  if (!r.tokens(t) || t.size() < 1) r.fail("expected `<#faces> [<marker flag>]`");
  const long n = r.integer(t[0], "the face count");
  detail::check_count(r, n, "face");
  const long nm = t.size() > 1 ? r.integer(t[1], "the marker flag") : 0;
  Faces F(n, 3);
  if (markers) markers->setZero(n);
  long base = 0;
  for (long i = 0; i < n; ++i) {
    if (!r.tokens(t) || static_cast<long>(t.size()) != 4 + nm)
      r.fail("expected `index a b c [marker]`");
    record_index(r, t[0], i, base, i == 0);
    for (int k = 0; k < 3; ++k) F(i, k) = r.int32(t[1 + k], "a node index", base);
    if (nm && markers) (*markers)[i] = r.int32(t[4], "a marker");
  }
  if (r.tokens(t))
    r.fail("unexpected data after the " + std::to_string(n) + " faces the file announces");
  return F;
}

Tets read_tetgen_neigh(const std::string& path) {
  TextReader r(path);
  std::vector<std::string> t;
  if (!r.tokens(t) || t.size() != 2) r.fail("expected `<#tets> 4`");
  const long n = r.integer(t[0], "the tet count");
  detail::check_count(r, n, "tet");
  Tets N(n, 4);
  long base = 0;
  for (long i = 0; i < n; ++i) {
    if (!r.tokens(t) || t.size() != 5) r.fail("expected `index n0 n1 n2 n3`");
    record_index(r, t[0], i, base, i == 0);
    for (int k = 0; k < 4; ++k) {
      const long v = r.integer(t[1 + k], "a neighbour index");
      N(i, k) = v < 0 ? -1 : r.int32(t[1 + k], "a neighbour index", base);
    }
  }
  if (r.tokens(t))
    r.fail("unexpected data after the " + std::to_string(n) + " tets the file announces");
  return N;
}

}  // namespace palplab::mesh
