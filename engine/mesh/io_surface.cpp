// Surface readers/writers: OBJ, STL (ASCII/binary), OFF, PLY (ASCII/binary), dispatch.
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <unordered_map>

#include "common/escape.hpp"
#include "engine/mesh/io.hpp"
#include "engine/mesh/text_reader.hpp"

namespace palplab::mesh {

using detail::TextReader;

std::string extension(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot);
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

namespace {

// Collects faces and their region names while reading.
struct SurfaceBuilder {
  std::vector<double> v;
  std::vector<std::array<int, 3>> f;
  std::vector<int> region;
  std::vector<std::string> names;
  bool any_region = false;

  int region_id(const std::string& name) {
    auto it = std::find(names.begin(), names.end(), name);
    if (it != names.end()) return static_cast<int>(it - names.begin());
    names.push_back(name);
    return static_cast<int>(names.size()) - 1;
  }
  // Fan-triangulates a polygon.
  void polygon(const std::vector<int>& idx, int reg) {
    for (size_t k = 1; k + 1 < idx.size(); ++k) {
      f.push_back({idx[0], idx[k], idx[k + 1]});
      region.push_back(reg);
    }
  }
  SurfaceMesh build(const std::string& path) {
    Positions V(static_cast<int>(v.size() / 3), 3);
    for (int i = 0; i < V.rows(); ++i) V.row(i) << v[3 * i], v[3 * i + 1], v[3 * i + 2];
    Faces F(static_cast<int>(f.size()), 3);
    for (int i = 0; i < F.rows(); ++i) F.row(i) << f[i][0], f[i][1], f[i][2];
    Regions r;
    if (any_region && !names.empty()) {
      r.names = names;
      r.id = Eigen::Map<Eigen::VectorXi>(region.data(), static_cast<int>(region.size()));
    }
    try {
      return make_surface_mesh(std::move(V), std::move(F), std::move(r));
    } catch (const InputError& e) {
      throw InputError(e.what(), path);
    }
  }
};

int region_of(const SurfaceMesh& m, int f) {
  return m.regions.empty() ? -1 : m.regions.id[f];
}

}  // namespace

// ---------------------------------------------------------------- OBJ

SurfaceMesh read_obj(const std::string& path) {
  std::vector<std::string> preset_names;
  // Region ids in file order: `# region <id> <name>` comments (written by palplab) come first.
  {
    TextReader pre(path, '\0');
    std::vector<std::string> t;
    std::vector<std::pair<long, std::string>> declared;
    while (pre.tokens(t))
      if (t.size() >= 4 && t[0] == "#" && t[1] == "region") {
        std::string name = t[3];
        for (size_t c = 4; c < t.size(); ++c) name += " " + t[c];
        declared.push_back({pre.integer(t[2], "a region id"), name});
      }
    if (!declared.empty()) {
      SurfaceBuilder probe;
      for (auto& [id, name] : declared)
        if (id != probe.region_id(name))
          pre.fail("`# region` comments must number the regions 0, 1, 2, ... in order");
      preset_names = probe.names;
    }
  }
  TextReader r(path);
  SurfaceBuilder b;
  b.names = preset_names;
  int current = -1;
  std::vector<std::string> t;
  std::vector<int> idx;
  long n_vt = 0, n_vn = 0;  // texture coordinates and normals defined so far
  while (r.tokens(t)) {
    const std::string& k = t[0];
    if (k == "vt") ++n_vt;
    if (k == "vn") ++n_vn;
    if (k == "v") {
      if (t.size() < 4) r.fail("expected `v x y z`");
      for (int c = 1; c <= 3; ++c) b.v.push_back(r.number(t[c], "a coordinate"));
    } else if (k == "f") {
      if (t.size() < 4) r.fail("a face needs at least 3 vertices");
      idx.clear();
      const long nv = static_cast<long>(b.v.size() / 3);
      for (size_t c = 1; c < t.size(); ++c) {
        const std::string s = t[c].substr(0, t[c].find('/'));
        // v, v/vt, v//vn or v/vt/vn: the texture and normal indices are not used, but must be
        // indices of what the file defines (`3/x` was taken).
        std::vector<std::string> parts{""};
        for (char ch : t[c]) {
          if (ch == '/')
            parts.emplace_back();
          else
            parts.back().push_back(ch);
        }
        if (parts.size() > 3)
          r.fail("expected a face corner v, v/vt, v//vn or v/vt/vn, got '" + t[c] + "'");
        for (size_t j = 1; j < parts.size(); ++j) {
          if (parts[j].empty()) {
            if (j == 1 && parts.size() == 3) continue;  // v//vn
            r.fail("expected a face corner v, v/vt, v//vn or v/vt/vn, got '" + t[c] + "'");
          }
          const long defined = j == 1 ? n_vt : n_vn;
          long q = r.integer(parts[j], j == 1 ? "a texture index" : "a normal index");
          if (q < 0 && q >= -defined) q = defined + q + 1;
          if (q < 1 || q > defined)
            r.fail(std::string(j == 1 ? "texture" : "normal") + " index " + parts[j] +
                   " out of range (" + std::to_string(defined) + (j == 1 ? " vt" : " vn") +
                   " defined so far)");
        }
        long i = r.integer(s, "a vertex index");
        if (i < 0 && i >= -nv) i = nv + i + 1;  // relative index (-1 = the last vertex)
        if (i < 1 || i > nv)
          r.fail("vertex index " + s + " out of range (" + std::to_string(nv) +
                 " vertices defined so far" +
                 (i == 0 ? std::string("; OBJ indices start at 1, or count back from -1") : "") +
                 ")");
        idx.push_back(static_cast<int>(i - 1));
      }
      b.polygon(idx, current);
    } else if (k == "g") {
      b.any_region = true;
      if (t.size() == 1) {
        current = -1;
      } else {
        std::string name = t[1];
        for (size_t c = 2; c < t.size(); ++c) name += " " + t[c];
        current = b.region_id(name);
      }
    } else if (k == "vn" || k == "vt" || k == "vp" || k == "o" || k == "s" || k == "usemtl" ||
               k == "mtllib" || k == "l" || k == "p") {
      // Not geometry we use (normals, texture, materials, lines, points).
    } else {
      // A binary file read as OBJ text (a binary STL, a database, an image): control bytes or
      // bytes that are not UTF-8 anywhere on the line; said as such, its first bytes shown cut,
      // every byte outside printable ASCII as \xNN.
      const auto binary_byte = [](char c) {
        return (static_cast<unsigned char>(c) < 0x20 && c != '\t') || c == '\x7f';
      };
      const bool binary = std::any_of(t.begin(), t.end(), [&](const std::string& w) {
        return std::any_of(w.begin(), w.end(), binary_byte) || !is_valid_utf8(w);
      });
      if (binary) {
        std::string shown;
        for (size_t i = 0; i < k.size() && i < 16; ++i) {
          const auto c = static_cast<unsigned char>(k[i]);
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\x%02x", c);
          shown += c >= 0x20 && c < 0x7f ? std::string(1, k[i]) : std::string(buf);
        }
        r.fail("not OBJ text: binary bytes (a binary STL, a database, an image?) in '" + shown +
               (k.size() > 16 ? "…" : "") + "'");
      }
      r.fail("unsupported OBJ statement '" + shown_text(k, 40) +
             "' (palplab reads v, f, g and ignores vn, vt, "
             "vp, o, s, usemtl, mtllib, l, p)");
    }
  }
  return b.build(path);
}

void write_obj(const std::string& path, const SurfaceMesh& m) {
  auto out = detail::open_out(path);
  out << "# palplab surface: " << m.V.rows() << " vertices, " << m.F.rows() << " faces (m)\n";
  for (size_t i = 0; i < m.regions.names.size(); ++i)
    out << "# region " << i << " " << m.regions.names[i] << "\n";
  for (int i = 0; i < m.V.rows(); ++i)
    out << "v " << format_exact(m.V(i, 0)) << " " << format_exact(m.V(i, 1)) << " "
        << format_exact(m.V(i, 2)) << "\n";
  int current = -2;
  for (int f = 0; f < m.F.rows(); ++f) {
    const int reg = region_of(m, f);
    if (!m.regions.empty() && reg != current) {
      out << (reg >= 0 ? "g " + m.regions.names[reg] : std::string("g")) << "\n";
      current = reg;
    }
    out << "f " << m.F(f, 0) + 1 << " " << m.F(f, 1) + 1 << " " << m.F(f, 2) + 1 << "\n";
  }
  detail::finish_out(out, path);
}

// ---------------------------------------------------------------- STL

namespace {

struct Weld {
  std::map<std::array<double, 3>, int> ids;
  SurfaceBuilder& b;
  int operator()(double x, double y, double z) {
    auto [it, fresh] = ids.emplace(std::array<double, 3>{x, y, z}, static_cast<int>(ids.size()));
    if (fresh) {
      b.v.push_back(x);
      b.v.push_back(y);
      b.v.push_back(z);
    }
    return it->second;
  }
};

SurfaceMesh read_stl_ascii(const std::string& path, std::string data) {
  TextReader r(path, std::move(data), '\0');
  SurfaceBuilder b;
  Weld weld{{}, b};
  std::vector<std::string> t;
  std::vector<std::string> solid_names;
  std::vector<int> solid_of_face;
  auto expect = [&](const char* word) {
    if (!r.tokens(t) || t[0] != word)
      r.fail(std::string("expected '") + word + "'" + (t.empty() ? "" : ", got '" + t[0] + "'"));
  };
  int solids = 0;
  while (r.tokens(t)) {
    if (t[0] != "solid") r.fail("expected 'solid', got '" + t[0] + "'");
    std::string name;
    for (size_t c = 1; c < t.size(); ++c) name += (c > 1 ? " " : "") + t[c];
    ++solids;
    solid_names.push_back(name);
    for (;;) {
      if (!r.tokens(t)) r.fail("unexpected end of file inside solid '" + name + "'");
      if (t[0] == "endsolid") break;
      if (t[0] != "facet" || t.size() != 5 || t[1] != "normal")
        r.fail("expected 'facet normal nx ny nz' or 'endsolid'");
      expect("outer");
      std::array<int, 3> tri;
      for (int k = 0; k < 3; ++k) {
        if (!r.tokens(t) || t[0] != "vertex" || t.size() != 4) r.fail("expected 'vertex x y z'");
        tri[k] = weld(r.number(t[1], "x"), r.number(t[2], "y"), r.number(t[3], "z"));
      }
      expect("endloop");
      expect("endfacet");
      b.f.push_back(tri);
      solid_of_face.push_back(solids - 1);
    }
  }
  if (solids == 0) r.fail("empty STL file");
  if (solids > 1) {  // several solids: their names are the regions
    b.any_region = true;
    for (int s : solid_of_face)
      b.region.push_back(solid_names[s].empty() ? -1 : b.region_id(solid_names[s]));
  }
  b.region.resize(b.f.size(), -1);
  return b.build(path);
}

template <class T>
T get_le(const std::string& d, size_t off) {
  T v;
  std::memcpy(&v, d.data() + off, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) {
    auto* p = reinterpret_cast<unsigned char*>(&v);
    std::reverse(p, p + sizeof(T));
  }
  return v;
}

SurfaceMesh read_stl_binary(const std::string& path, const std::string& d) {
  const std::uint32_t n = get_le<std::uint32_t>(d, 80);
  SurfaceBuilder b;
  Weld weld{{}, b};
  for (std::uint32_t i = 0; i < n; ++i) {
    const size_t base = 84 + 50 * static_cast<size_t>(i);
    std::array<int, 3> tri;
    for (int k = 0; k < 3; ++k) {
      float c[3];
      for (int a = 0; a < 3; ++a) {
        const size_t off = base + 12 + 12 * k + 4 * a;
        c[a] = get_le<float>(d, off);
        if (!std::isfinite(c[a]))
          throw InputError(SourceLocation{path, 0, 0, static_cast<long>(off)},
                           "non-finite coordinate in triangle " + std::to_string(i));
      }
      tri[k] = weld(c[0], c[1], c[2]);
    }
    b.f.push_back(tri);
  }
  return b.build(path);
}

}  // namespace

SurfaceMesh read_stl(const std::string& path) {
  std::string d = detail::read_file(path);
  if (d.size() >= 84) {
    const std::uint64_t n = get_le<std::uint32_t>(d, 80);
    if (84 + 50 * n == d.size()) return read_stl_binary(path, d);
  }
  size_t s = 0;
  while (s < d.size() && std::isspace(static_cast<unsigned char>(d[s]))) ++s;
  if (d.compare(s, 5, "solid") == 0) return read_stl_ascii(path, std::move(d));
  if (d.size() < 84)
    throw InputError(SourceLocation{path, 0, 0, static_cast<long>(d.size())},
                     "file too short for a binary STL (84-byte header) and not ASCII STL");
  throw InputError(SourceLocation{path, 0, 0, 80},
                   "binary STL announces " + std::to_string(get_le<std::uint32_t>(d, 80)) +
                       " triangles (" + std::to_string(84 + 50ull * get_le<std::uint32_t>(d, 80)) +
                       " bytes) but the file has " + std::to_string(d.size()) + " bytes");
}

void write_stl(const std::string& path, const SurfaceMesh& m, bool binary) {
  const Positions N = face_normals(m.V, m.F);
  auto out = detail::open_out(path, binary);
  if (binary) {
    char header[80] = {};
    std::snprintf(header, sizeof header, "palplab binary STL, %ld triangles, metres",
                  static_cast<long>(m.F.rows()));
    out.write(header, 80);
    auto put = [&](auto v) {
      if constexpr (std::endian::native == std::endian::big) {
        auto* p = reinterpret_cast<unsigned char*>(&v);
        std::reverse(p, p + sizeof v);
      }
      out.write(reinterpret_cast<const char*>(&v), sizeof v);
    };
    put(static_cast<std::uint32_t>(m.F.rows()));
    for (int f = 0; f < m.F.rows(); ++f) {
      for (int a = 0; a < 3; ++a) put(static_cast<float>(N(f, a)));
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) put(static_cast<float>(m.V(m.F(f, k), a)));
      put(std::uint16_t{0});
    }
  } else {
    int f = 0;
    const int nf = static_cast<int>(m.F.rows());
    do {  // one solid per run of faces of the same region
      const int reg = nf ? region_of(m, f) : -1;
      const std::string name = reg >= 0 ? m.regions.names[reg] : "palplab";
      out << "solid " << name << "\n";
      for (; f < nf && region_of(m, f) == reg; ++f) {
        out << "  facet normal " << format_exact(N(f, 0)) << " " << format_exact(N(f, 1)) << " "
            << format_exact(N(f, 2)) << "\n    outer loop\n";
        for (int k = 0; k < 3; ++k) {
          const int v = m.F(f, k);
          out << "      vertex " << format_exact(m.V(v, 0)) << " " << format_exact(m.V(v, 1)) << " "
              << format_exact(m.V(v, 2)) << "\n";
        }
        out << "    endloop\n  endfacet\n";
      }
      out << "endsolid " << name << "\n";
    } while (f < nf);
  }
  detail::finish_out(out, path);
}

// ---------------------------------------------------------------- OFF

SurfaceMesh read_off(const std::string& path) {
  TextReader r(path);
  std::vector<std::string> t;
  if (!r.tokens(t) || t[0] != "OFF") r.fail("expected the 'OFF' header");
  if (t.size() == 1 && !r.tokens(t)) r.fail("expected `vertices faces edges` counts");
  if (t[0] == "OFF") t.erase(t.begin());
  if (t.size() < 2) r.fail("expected `vertices faces edges` counts");
  const long nv = r.integer(t[0], "the vertex count"), nf = r.integer(t[1], "the face count");
  detail::check_count(r, nv, "vertex");
  detail::check_count(r, nf, "face");
  SurfaceBuilder b;
  for (long i = 0; i < nv; ++i) {
    if (!r.tokens(t))
      r.fail("unexpected end of file: " + std::to_string(nv) + " vertices announced, " +
             std::to_string(i) + " found");
    if (t.size() != 3) r.fail("expected `x y z` for vertex " + std::to_string(i));
    for (int c = 0; c < 3; ++c) b.v.push_back(r.number(t[c], "a coordinate"));
  }
  std::vector<int> idx;
  for (long i = 0; i < nf; ++i) {
    if (!r.tokens(t))
      r.fail("unexpected end of file: " + std::to_string(nf) + " faces announced, " +
             std::to_string(i) + " found");
    const long k = r.integer(t[0], "the face's vertex count");
    if (k < 3 || static_cast<long>(t.size()) < k + 1)
      r.fail("expected `n i1 ... in` with n >= 3 for face " + std::to_string(i));
    idx.clear();
    for (long c = 1; c <= k; ++c) {
      const long v = r.integer(t[c], "a vertex index");
      if (v < 0 || v >= nv)
        r.fail("vertex index " + t[c] + " out of range [0, " + std::to_string(nv) + ")");
      idx.push_back(static_cast<int>(v));
    }
    b.polygon(idx, -1);
  }
  if (r.tokens(t)) r.fail("unexpected data after the last face");
  return b.build(path);
}

void write_off(const std::string& path, const SurfaceMesh& m) {
  auto out = detail::open_out(path);
  out << "OFF\n" << m.V.rows() << " " << m.F.rows() << " " << m.E.rows() << "\n";
  for (int i = 0; i < m.V.rows(); ++i)
    out << format_exact(m.V(i, 0)) << " " << format_exact(m.V(i, 1)) << " "
        << format_exact(m.V(i, 2)) << "\n";
  for (int f = 0; f < m.F.rows(); ++f)
    out << "3 " << m.F(f, 0) << " " << m.F(f, 1) << " " << m.F(f, 2) << "\n";
  detail::finish_out(out, path);
}

// ---------------------------------------------------------------- PLY

namespace {

enum class PlyType { i8, u8, i16, u16, i32, u32, f32, f64 };

bool ply_type(const std::string& s, PlyType& t) {
  static const std::map<std::string, PlyType> m = {
      {"char", PlyType::i8},    {"int8", PlyType::i8},     {"uchar", PlyType::u8},
      {"uint8", PlyType::u8},   {"short", PlyType::i16},   {"int16", PlyType::i16},
      {"ushort", PlyType::u16}, {"uint16", PlyType::u16},  {"int", PlyType::i32},
      {"int32", PlyType::i32},  {"uint", PlyType::u32},    {"uint32", PlyType::u32},
      {"float", PlyType::f32},  {"float32", PlyType::f32}, {"double", PlyType::f64},
      {"float64", PlyType::f64}};
  auto it = m.find(s);
  if (it == m.end()) return false;
  t = it->second;
  return true;
}

int ply_size(PlyType t) {
  switch (t) {
    case PlyType::i8:
    case PlyType::u8:
      return 1;
    case PlyType::i16:
    case PlyType::u16:
      return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32:
      return 4;
    case PlyType::f64:
      return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::f32;
  bool list = false;
  PlyType count_type = PlyType::u8;
};

struct PlyElement {
  std::string name;
  long count = 0;
  std::vector<PlyProperty> props;
};

// Reads values of a body (ASCII tokens or binary with the given endianness), with locations.
struct PlyBody {
  const std::string& path;
  const std::string& d;
  size_t pos;
  bool ascii, big;
  int line;  // ASCII: current line number
  std::vector<std::string> tok;
  size_t ti = 0;

  [[noreturn]] void fail(const std::string& what) const {
    if (ascii) throw InputError(SourceLocation{path, line}, what);
    throw InputError(SourceLocation{path, 0, 0, static_cast<long>(pos)}, what);
  }
  // ASCII: each element instance is one line.
  void begin_instance() {
    if (!ascii) return;
    for (;;) {
      if (pos >= d.size()) fail("unexpected end of file in the PLY body");
      size_t e = d.find('\n', pos);
      if (e == std::string::npos) e = d.size();
      std::string l = d.substr(pos, e - pos);
      pos = e + 1;
      ++line;
      tok = detail::split_ws(l);
      ti = 0;
      if (!tok.empty()) return;
    }
  }
  void end_instance() {
    if (ascii && ti != tok.size()) fail("more values on the line than the header declares");
  }
  double value(PlyType t) {
    if (ascii) {
      if (ti >= tok.size()) fail("fewer values on the line than the header declares");
      const std::string& s = tok[ti++];
      double v;
      auto r = std::from_chars(s.data(), s.data() + s.size(), v);
      if (r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(v))
        fail("expected a number, got '" + shown_text(s, 40) + "'");
      if (t != PlyType::f32 && t != PlyType::f64 && v != std::floor(v))
        fail("expected an integer, got '" + shown_text(s, 40) + "'");
      return v;
    }
    const int n = ply_size(t);
    if (pos + n > d.size()) fail("unexpected end of file in the PLY body");
    unsigned char b[8];
    std::memcpy(b, d.data() + pos, n);
    if (big != (std::endian::native == std::endian::big)) std::reverse(b, b + n);
    pos += n;
    switch (t) {
      case PlyType::i8: {
        std::int8_t v;
        std::memcpy(&v, b, 1);
        return v;
      }
      case PlyType::u8:
        return b[0];
      case PlyType::i16: {
        std::int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::u16: {
        std::uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::i32: {
        std::int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::u32: {
        std::uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::f32: {
        float v;
        std::memcpy(&v, b, 4);
        if (!std::isfinite(v)) {
          pos -= 4;
          fail("non-finite value");
        }
        return v;
      }
      case PlyType::f64: {
        double v;
        std::memcpy(&v, b, 8);
        if (!std::isfinite(v)) {
          pos -= 8;
          fail("non-finite value");
        }
        return v;
      }
    }
    return 0;
  }
};

}  // namespace

SurfaceMesh read_ply(const std::string& path) {
  const std::string d = detail::read_file(path);
  // Header: lines up to end_header.
  size_t pos = 0;
  int line = 0;
  auto next_line = [&](std::string& l) {
    if (pos >= d.size()) return false;
    size_t e = d.find('\n', pos);
    if (e == std::string::npos) e = d.size();
    l = d.substr(pos, e - pos);
    if (!l.empty() && l.back() == '\r') l.pop_back();
    pos = e + 1;
    ++line;
    return true;
  };
  auto fail = [&](const std::string& w) { throw InputError(SourceLocation{path, line}, w); };
  std::string l;
  if (!next_line(l) || l != "ply") fail("expected the 'ply' magic line");
  bool ascii = false, big = false, have_format = false;
  std::vector<PlyElement> elements;
  std::map<int, std::string> names;
  for (;;) {
    if (!next_line(l)) fail("unexpected end of file in the PLY header (no end_header)");
    auto t = detail::split_ws(l);
    if (t.empty()) continue;
    if (t[0] == "end_header") break;
    if (t[0] == "format") {
      if (t.size() != 3 || t[2] != "1.0") fail("expected `format <type> 1.0`");
      if (t[1] == "ascii")
        ascii = true;
      else if (t[1] == "binary_little_endian")
        big = false;
      else if (t[1] == "binary_big_endian")
        big = true;
      else
        fail("unknown PLY format '" + t[1] + "'");
      have_format = true;
    } else if (t[0] == "comment" || t[0] == "obj_info") {
      if (t.size() >= 4 && t[0] == "comment" && t[1] == "region") {
        long id;
        auto r = std::from_chars(t[2].data(), t[2].data() + t[2].size(), id);
        if (r.ec != std::errc() || id < 0 || id > 1000000)
          fail("expected `comment region <id> <name>`");
        std::string name = t[3];
        for (size_t c = 4; c < t.size(); ++c) name += " " + t[c];
        names[static_cast<int>(id)] = name;
      }
    } else if (t[0] == "element") {
      if (t.size() != 3) fail("expected `element <name> <count>`");
      long n;
      auto r = std::from_chars(t[2].data(), t[2].data() + t[2].size(), n);
      if (r.ec != std::errc() || n < 0 || n > 500000000) fail("bad element count '" + t[2] + "'");
      elements.push_back({t[1], n, {}});
    } else if (t[0] == "property") {
      if (elements.empty()) fail("property before any element");
      PlyProperty p;
      if (t.size() == 5 && t[1] == "list") {
        p.list = true;
        if (!ply_type(t[2], p.count_type) || !ply_type(t[3], p.type)) fail("unknown property type");
        p.name = t[4];
      } else if (t.size() == 3) {
        if (!ply_type(t[1], p.type)) fail("unknown property type '" + t[1] + "'");
        p.name = t[2];
      } else {
        fail("expected `property <type> <name>` or `property list <type> <type> <name>`");
      }
      elements.back().props.push_back(p);
    } else {
      fail("unknown PLY header line '" + t[0] + "'");
    }
  }
  if (!have_format) fail("missing `format` line");
  PlyBody body{path, d, pos, ascii, big, line, {}, 0};
  SurfaceBuilder b;
  std::vector<int> idx;
  bool have_vertices = false;
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int ix = -1, iy = -1, iz = -1, iv = -1, ir = -1;
    for (size_t k = 0; k < e.props.size(); ++k) {
      const auto& n = e.props[k].name;
      if (n == "x") ix = static_cast<int>(k);
      if (n == "y") iy = static_cast<int>(k);
      if (n == "z") iz = static_cast<int>(k);
      if ((n == "vertex_indices" || n == "vertex_index") && e.props[k].list)
        iv = static_cast<int>(k);
      if (n == "region" && !e.props[k].list) ir = static_cast<int>(k);
    }
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0))
      throw InputError(SourceLocation{path, line}, "vertex element without x, y, z properties");
    if (is_face && iv < 0)
      throw InputError(SourceLocation{path, line}, "face element without a vertex_indices list");
    if (is_face && !have_vertices)
      throw InputError(SourceLocation{path, line}, "face element before the vertex element");
    if (is_face && ir >= 0) b.any_region = true;
    const long nv = static_cast<long>(b.v.size() / 3);
    for (long i = 0; i < e.count; ++i) {
      body.begin_instance();
      double xyz[3] = {0, 0, 0};
      int region = -1;
      idx.clear();
      for (size_t k = 0; k < e.props.size(); ++k) {
        const PlyProperty& p = e.props[k];
        if (p.list) {
          const double n = body.value(p.count_type);
          if (!(n >= 0 && n <= 1000))  // NaN fails too
            body.fail("implausible list length " + std::to_string(n));
          for (int c = 0; c < static_cast<int>(n); ++c) {
            const double v = body.value(p.type);
            if (static_cast<int>(k) == iv) {
              if (!(v >= 0 && v < nv) || v != std::floor(v))
                body.fail("vertex index " + format_exact(v) + " out of range [0, " +
                          std::to_string(nv) + ")");
              idx.push_back(static_cast<int>(v));
            }
          }
        } else {
          const double v = body.value(p.type);
          if (is_vertex && static_cast<int>(k) == ix) xyz[0] = v;
          if (is_vertex && static_cast<int>(k) == iy) xyz[1] = v;
          if (is_vertex && static_cast<int>(k) == iz) xyz[2] = v;
          if (is_face && static_cast<int>(k) == ir) {
            // Ids index the name table: bounded like the header's `comment region` ids.
            if (!(v >= -1 && v <= 1000000) || v != std::floor(v))
              body.fail("region id " + format_exact(v) + " is not -1 or an id in [0, 1000000]");
            region = static_cast<int>(v);
          }
        }
      }
      body.end_instance();
      if (is_vertex) b.v.insert(b.v.end(), xyz, xyz + 3);
      if (is_face) {
        if (idx.size() < 3) body.fail("face with fewer than 3 vertices");
        if (region >= 0 && !names.count(region)) names[region] = "region_" + std::to_string(region);
        b.polygon(idx, region);
      }
    }
    if (is_vertex) have_vertices = true;
  }
  if (!have_vertices) throw InputError("PLY file has no vertex element", path);
  // Data past the elements the header announces: a count that is wrong (OFF says the same).
  const size_t extra = ascii ? d.find_first_not_of(" \t\r\n", std::min(body.pos, d.size()))
                             : (body.pos < d.size() ? body.pos : std::string::npos);
  if (extra != std::string::npos) {
    if (ascii)
      body.line += 1 + static_cast<int>(std::count(d.begin() + body.pos, d.begin() + extra, '\n'));
    body.fail(std::string("unexpected data after the last element the header announces") +
              (ascii ? "" : " (" + std::to_string(d.size() - body.pos) + " bytes)"));
  }
  if (b.any_region) {
    // Region ids as given; names from the header comments (gaps get generic names).
    int maxid = -1;
    for (auto& [id, n] : names) maxid = std::max(maxid, id);
    b.names.assign(maxid + 1, "");
    for (int i = 0; i <= maxid; ++i)
      b.names[i] = names.count(i) ? names[i] : "region_" + std::to_string(i);
  }
  return b.build(path);
}

void write_ply(const std::string& path, const SurfaceMesh& m, bool binary) {
  auto out = detail::open_out(path, binary);
  const bool regions = !m.regions.empty();
  out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\n"
      << "comment palplab surface, metres\n";
  if (regions)
    for (size_t i = 0; i < m.regions.names.size(); ++i)
      out << "comment region " << i << " " << m.regions.names[i] << "\n";
  out << "element vertex " << m.V.rows() << "\nproperty double x\nproperty double y\n"
      << "property double z\nelement face " << m.F.rows()
      << "\nproperty list uchar int vertex_indices\n";
  if (regions) out << "property int region\n";
  out << "end_header\n";
  auto put = [&](auto v) {
    if constexpr (std::endian::native == std::endian::big) {
      auto* p = reinterpret_cast<unsigned char*>(&v);
      std::reverse(p, p + sizeof v);
    }
    out.write(reinterpret_cast<const char*>(&v), sizeof v);
  };
  for (int i = 0; i < m.V.rows(); ++i) {
    if (binary)
      for (int a = 0; a < 3; ++a) put(m.V(i, a));
    else
      out << format_exact(m.V(i, 0)) << " " << format_exact(m.V(i, 1)) << " "
          << format_exact(m.V(i, 2)) << "\n";
  }
  for (int f = 0; f < m.F.rows(); ++f) {
    if (binary) {
      put(std::uint8_t{3});
      for (int k = 0; k < 3; ++k) put(static_cast<std::int32_t>(m.F(f, k)));
      if (regions) put(static_cast<std::int32_t>(m.regions.id[f]));
    } else {
      out << "3 " << m.F(f, 0) << " " << m.F(f, 1) << " " << m.F(f, 2);
      if (regions) out << " " << m.regions.id[f];
      out << "\n";
    }
  }
  detail::finish_out(out, path);
}

// ---------------------------------------------------------------- dispatch

namespace {

SurfaceMesh read_surface_any(const std::string& path) {
  const std::string e = extension(path);
  if (e == ".obj") return read_obj(path);
  if (e == ".stl") return read_stl(path);
  if (e == ".off") return read_off(path);
  if (e == ".ply") return read_ply(path);
  if (e == ".vtu") {
    AnyMesh a = read_mesh(path);
    if (a.is_tet) throw InputError("expected a surface but the VTU file holds tetrahedra", path);
    return a.surface;
  }
  // The format is told by the extension; a directory or a file without one said as such (a
  // directory /tmp was "unknown surface format ''").
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(
        "is a directory (expected a mesh file: .obj, .stl, .off, .ply, .vtu, or "
        "TetGen .node/.ele)",
        path);
  if (e.empty())
    throw InputError(
        "the file name has no extension, which tells the mesh format (expected "
        ".obj, .stl, .off, .ply, .vtu, or TetGen .node/.ele)",
        path);
  throw InputError("unknown surface format '" + e + "' (expected .obj, .stl, .off, .ply, .vtu)",
                   path);
}

}  // namespace

SurfaceMesh read_surface(const std::string& path) {
  SurfaceMesh m = read_surface_any(path);
  detail::check_region_names(m.regions.names, path);
  // A file without triangles is no surface: every consumer (check, tetrahedralize, a prototype's
  // mesh.file, the simulation) needs at least one.
  if (m.F.rows() == 0)
    throw InputError("no geometry: the file holds " + std::to_string(m.V.rows()) +
                         " vertices and no triangles (expected a triangulated surface)",
                     path);
  return m;
}

void write_surface(const std::string& path, const SurfaceMesh& m, const WriteOptions& o) {
  const std::string e = extension(path);
  if (e == ".obj") return write_obj(path, m);
  if (e == ".stl") return write_stl(path, m, o.binary);
  if (e == ".off") return write_off(path, m);
  if (e == ".ply") return write_ply(path, m, o.binary);
  if (e == ".vtu") return write_vtu(path, m);
  throw InputError("unknown surface format '" + e + "' (expected .obj, .stl, .off, .ply, .vtu)",
                   path);
}

std::string format_exact(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

}  // namespace palplab::mesh
