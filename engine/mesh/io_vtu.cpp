// VTK XML unstructured grid (ASCII): writer for ParaView and a reader for palplab's own files.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "common/escape.hpp"
#include "engine/mesh/io.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/mesh/text_reader.hpp"

namespace palplab::mesh {

namespace {

void header(std::ostringstream& out, const Positions& V, long cells, const Regions& r) {
  out << "<?xml version=\"1.0\"?>\n";
  if (!r.empty()) {
    out << "<!-- palplab regions:";
    for (size_t i = 0; i < r.names.size(); ++i) out << " " << i << "=" << r.names[i];
    out << " -->\n";
  }
  out << "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
      << "<UnstructuredGrid>\n<Piece NumberOfPoints=\"" << V.rows() << "\" NumberOfCells=\""
      << cells << "\">\n<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" "
      << "format=\"ascii\">\n";
  for (int i = 0; i < V.rows(); ++i)
    out << format_exact(V(i, 0)) << " " << format_exact(V(i, 1)) << " " << format_exact(V(i, 2))
        << "\n";
  out << "</DataArray>\n</Points>\n";
}

template <class M>
void cells(std::ostringstream& out, const M& C, int type) {
  out << "<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (int c = 0; c < C.rows(); ++c) {
    for (int k = 0; k < C.cols(); ++k) out << (k ? " " : "") << C(c, k);
    out << "\n";
  }
  out << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (int c = 0; c < C.rows(); ++c) out << (c + 1) * C.cols() << "\n";
  out << "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
  for (int c = 0; c < C.rows(); ++c) out << type << "\n";
  out << "</DataArray>\n</Cells>\n";
}

template <class F>
void cell_array(std::ostringstream& out, const char* type, const char* name, long n, F value) {
  out << "<DataArray type=\"" << type << "\" Name=\"" << name << "\" format=\"ascii\">\n";
  for (long i = 0; i < n; ++i) out << value(i) << "\n";
  out << "</DataArray>\n";
}

void footer(std::ostringstream& out, const std::string& path) {
  out << "</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  detail::finish_out(out, path);
}

}  // namespace

void write_vtu(const std::string& path, const SurfaceMesh& m) {
  std::ostringstream out;
  header(out, m.V, m.F.rows(), m.regions);
  cells(out, m.F, 5);
  if (!m.regions.empty()) {
    out << "<CellData Scalars=\"region\">\n";
    cell_array(out, "Int32", "region", m.F.rows(), [&](long i) { return m.regions.id[i]; });
    out << "</CellData>\n";
  }
  footer(out, path);
}

void write_vtu(const std::string& path, const TetMesh& m, const MaterialTable* mat) {
  if (mat)
    for (long i = 0; i < m.T.rows(); ++i)
      if (!mat->find(m.attribute[i]))
        throw InputError("tet " + std::to_string(i) + " has tissue attribute " +
                             std::to_string(m.attribute[i]) + ", which the material table " +
                             mat->source + " does not define (it defines " + mat->describe() +
                             "): no material cell data for it",
                         path);
  std::ostringstream out;
  header(out, m.V, m.T.rows(), m.regions);
  cells(out, m.T, 10);
  out << "<CellData Scalars=\"attribute\">\n";
  cell_array(out, "Int32", "attribute", m.T.rows(), [&](long i) { return m.attribute[i]; });
  if (!m.regions.empty())
    cell_array(out, "Int32", "region", m.T.rows(), [&](long i) { return m.regions.id[i]; });
  cell_array(out, "Float64", "volume", m.T.rows(),
             [&](long i) { return format_exact(m.volume[i]); });
  if (mat) {
    auto prop = [&](long i, auto get) {
      return format_exact(get(*mat->find(m.attribute[i])));  // checked above
    };
    cell_array(out, "Float64", "youngs_modulus", m.T.rows(),
               [&](long i) { return prop(i, [](const Material& x) { return x.youngs_modulus; }); });
    cell_array(out, "Float64", "poisson_ratio", m.T.rows(),
               [&](long i) { return prop(i, [](const Material& x) { return x.poisson_ratio; }); });
    cell_array(out, "Float64", "density", m.T.rows(),
               [&](long i) { return prop(i, [](const Material& x) { return x.density; }); });
  }
  out << "</CellData>\n";
  footer(out, path);
}

namespace {

// Text of the DataArray named `name` (or the first inside <Points>), with the line it starts on.
bool data_array(const std::string& d, const std::string& name, std::string& text, int& line) {
  size_t p = 0;
  for (;;) {
    p = d.find("<DataArray", p);
    if (p == std::string::npos) return false;
    const size_t close = d.find('>', p);
    if (close == std::string::npos) return false;
    const std::string tag = d.substr(p, close - p);
    const bool match = name.empty() ? true : tag.find("Name=\"" + name + "\"") != std::string::npos;
    if (match) {
      const size_t end = d.find("</DataArray>", close);
      if (end == std::string::npos) return false;
      text = d.substr(close + 1, end - close - 1);
      line = 1 + static_cast<int>(std::count(d.begin(), d.begin() + close, '\n'));
      return true;
    }
    p = close;
  }
}

std::vector<double> numbers(const std::string& path, const std::string& text, int line,
                            const char* what) {
  std::vector<double> v;
  std::istringstream is(text);
  std::string t;
  while (is >> t) {
    double x;
    auto r = std::from_chars(t.data(), t.data() + t.size(), x);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size())
      throw InputError(SourceLocation{path, line},
                       std::string("bad number '") + t + "' in " + what);
    v.push_back(x);
  }
  return v;
}

// The count a <Piece> declares (NumberOfPoints, NumberOfCells), when it declares one: it must
// match what the arrays hold (a file cut or edited by hand).
void check_declared_count(const std::string& path, const std::string& d, const char* attribute,
                          size_t actual) {
  const size_t piece = d.find("<Piece");
  if (piece == std::string::npos) return;
  const size_t close = d.find('>', piece);
  const std::string tag =
      d.substr(piece, close == std::string::npos ? std::string::npos : close - piece);
  const std::string key = std::string(attribute) + "=\"";
  const size_t at = tag.find(key);
  if (at == std::string::npos) return;
  const size_t from = at + key.size(), to = tag.find('"', from);
  const std::string text = tag.substr(from, to == std::string::npos ? 0 : to - from);
  size_t n = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), n);
  const int line = 1 + static_cast<int>(std::count(d.begin(), d.begin() + piece, '\n'));
  if (r.ec != std::errc() || r.ptr != text.data() + text.size() || n != actual)
    throw InputError(SourceLocation{path, line},
                     std::string(attribute) + "=\"" + shown_text(text, 40) +
                         "\" but the arrays hold " + std::to_string(actual) +
                         " (expected the count of what the file holds)");
}

}  // namespace

AnyMesh read_mesh(const std::string& path) {
  AnyMesh a;
  if (is_tetgen_path(path)) {
    a.is_tet = true;
    a.tet = read_tetgen(path);
    if (a.tet.T.rows() == 0)
      throw InputError("no geometry: the TetGen files hold no tetrahedra", path);
    return a;
  }
  // TetGen's other files are read with the mesh, from its .node/.ele: given alone, they were
  // "unknown surface format '.face'" with the surface formats only.
  if (const std::string e = extension(path); e == ".face" || e == ".neigh" || e == ".names")
    throw InputError(std::string(std::filesystem::exists(path) ? "" : "no such file; ") +
                         "a TetGen mesh's " + e + " file is read with the mesh: give its .ele (" +
                         path.substr(0, path.size() - e.size()) +
                         ".ele) or .node (expected a mesh file: .obj, .stl, .off, .ply, .vtu, or "
                         "TetGen .node/.ele)",
                     path);
  if (extension(path) != ".vtu") {
    a.surface = read_surface(path);
    return a;
  }
  const std::string d = detail::read_file(path);
  if (d.find("<VTKFile") == std::string::npos || d.find("UnstructuredGrid") == std::string::npos)
    throw InputError("not a VTK XML unstructured grid", path);
  if (d.find("format=\"binary\"") != std::string::npos ||
      d.find("format=\"appended\"") != std::string::npos)
    throw InputError("only ASCII VTU files (as palplab writes them) can be read", path);
  std::string text;
  int line = 0;
  const size_t points = d.find("<Points>");
  if (points == std::string::npos) throw InputError("VTU file without <Points>", path);
  if (!data_array(d.substr(points), "", text, line))
    throw InputError("VTU <Points> without a DataArray", path);
  line += static_cast<int>(std::count(d.begin(), d.begin() + points, '\n'));
  const auto pts = numbers(path, text, line, "Points");
  if (pts.size() % 3)
    throw InputError(SourceLocation{path, line}, "point count is not a multiple of 3");
  std::vector<double> conn, offs, types;
  for (auto [name, dst] :
       {std::pair{"connectivity", &conn}, {"offsets", &offs}, {"types", &types}}) {
    if (!data_array(d, name, text, line))
      throw InputError(std::string("VTU file without the '") + name + "' array", path);
    *dst = numbers(path, text, line, name);
  }
  if (types.empty() || offs.size() != types.size())
    throw InputError("VTU cells: offsets and types differ in length", path);
  const int type = types[0] == 10 ? 10 : 5;  // checked below (no cast of an arbitrary double)
  for (double t : types)
    if (t != type || (type != 5 && type != 10))
      throw InputError("VTU: only all-triangle (5) or all-tetra (10) cells are supported", path);
  const int k = type == 5 ? 3 : 4;
  if (conn.size() != types.size() * k) throw InputError("VTU: connectivity size mismatch", path);
  const long nv = static_cast<long>(pts.size() / 3);
  check_declared_count(path, d, "NumberOfPoints", pts.size() / 3);
  check_declared_count(path, d, "NumberOfCells", types.size());
  Positions V(nv, 3);
  for (long i = 0; i < nv; ++i) V.row(i) << pts[3 * i], pts[3 * i + 1], pts[3 * i + 2];
  Eigen::MatrixXi C(types.size(), k);
  for (size_t c = 0; c < types.size(); ++c)
    for (int j = 0; j < k; ++j) {
      const double v = conn[c * k + j];
      if (!(v >= 0 && v < nv) || v != std::floor(v))  // NaN fails too
        throw InputError("VTU: connectivity index " + format_exact(v) + " of cell " +
                             std::to_string(c) + " is not a vertex index in [0, " +
                             std::to_string(nv) + ")",
                         path);
      C(c, j) = static_cast<int>(v);
    }
  Regions regions;
  if (auto p = d.find("<!-- palplab regions:"); p != std::string::npos) {
    const auto end = d.find("-->", p);
    if (end == std::string::npos) throw InputError("VTU: unterminated region list comment", path);
    const std::string list = d.substr(p + 21, end - p - 21);
    std::istringstream is(list);
    std::string item;
    std::map<int, std::string> names;
    while (is >> item) {
      const auto eq = item.find('=');
      if (eq == std::string::npos) throw InputError("VTU: malformed region list comment", path);
      int id = -1;
      auto rc = std::from_chars(item.data(), item.data() + eq, id);
      if (rc.ec != std::errc() || rc.ptr != item.data() + eq || id < 0 || id > 100000)
        throw InputError("VTU: region list entry '" + shown_text(item, 40) +
                             "' is not <id>=<name> with an id in [0, 100000]",
                         path);
      names[id] = item.substr(eq + 1);
    }
    for (auto& [id, n] : names) {
      if (id != static_cast<int>(regions.names.size()))
        throw InputError("VTU: region ids must be 0..n-1", path);
      regions.names.push_back(n);
    }
    if (data_array(d, "region", text, line)) {
      auto r = numbers(path, text, line, "region");
      if (r.size() != types.size()) throw InputError("VTU: region array size mismatch", path);
      regions.id.resize(static_cast<int>(r.size()));
      const double n = static_cast<double>(regions.names.size());
      for (size_t i = 0; i < r.size(); ++i) {
        if (!(r[i] >= -1 && r[i] < n) || r[i] != std::floor(r[i]))
          throw InputError(SourceLocation{path, line},
                           "region id " + format_exact(r[i]) + " of cell " + std::to_string(i) +
                               " is not -1 (none) or one of the " +
                               std::to_string(regions.names.size()) + " declared regions");
        regions.id[i] = static_cast<int>(r[i]);
      }
    } else {
      regions = {};
    }
  }
  if (type == 5) {
    a.surface = make_surface_mesh(std::move(V), Faces(C), std::move(regions));
  } else {
    Eigen::VectorXi attr;
    if (data_array(d, "attribute", text, line)) {
      auto r = numbers(path, text, line, "attribute");
      if (r.size() != types.size()) throw InputError("VTU: attribute array size mismatch", path);
      attr.resize(static_cast<int>(r.size()));
      for (size_t i = 0; i < r.size(); ++i) {
        if (!(std::abs(r[i]) <= 1e9) || r[i] != std::floor(r[i]))
          throw InputError(SourceLocation{path, line},
                           "attribute " + format_exact(r[i]) + " of cell " + std::to_string(i) +
                               " is not an integer tissue type (|a| <= 1e9)");
        attr[i] = static_cast<int>(r[i]);
      }
    }
    a.is_tet = true;
    a.tet = make_tet_mesh(std::move(V), Tets(C), std::move(attr), std::move(regions));
  }
  if ((a.is_tet ? a.tet.T.rows() : a.surface.F.rows()) == 0)
    throw InputError("no geometry: the VTU file holds no cells", path);
  detail::check_region_names(a.is_tet ? a.tet.regions.names : a.surface.regions.names, path);
  return a;
}

}  // namespace palplab::mesh
