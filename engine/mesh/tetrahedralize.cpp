#include "engine/mesh/tetrahedralize.hpp"

#include <tetgen.h>

#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <new>
#include <set>
#include <sstream>

#include "common/format.hpp"
#include "common/input_error.hpp"
#include "engine/mesh/check.hpp"
#include "engine/mesh/io.hpp"
#include "engine/mesh/text_reader.hpp"
#include "engine/mesh/union_find.hpp"
#include "engine/spatial/octree.hpp"

namespace palplab::mesh {

namespace {

std::string tetgen_error(int code) {
  switch (code) {
    case 1:
      return "TetGen ran out of memory (it may use half of this machine's memory): a larger "
             "--max-volume or region volume bound asks for fewer tetrahedra";
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
  // SPEC §4: first line the count, then one line per region `index x y z region_id attribute`.
  // Every token is parsed whole (no "12abc" read as 12, no NaN), each error names FILE:LINE and
  // the field.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError("is a directory (expected a .regions file)", path);
  detail::TextReader r(path, read_file_bounded(path, std::size_t{1} << 26, ".regions file"), '#');
  std::vector<std::string> tok;
  if (!r.tokens(tok))
    throw InputError("empty region file (expected the number of regions on the first line)", path);
  if (tok.size() != 1)
    r.fail("expected only the number of regions on the first line, got " +
           std::to_string(tok.size()) + " fields");
  const long n = r.integer(tok[0], "the number of regions");
  if (n < 0 || n > 1000000)
    r.fail("expected the number of regions (an integer in 0 ... 1000000), got " + tok[0]);
  const int count_line = r.line;
  static const char* kFields[] = {"index", "x", "y", "z", "region_id", "attribute"};
  std::vector<RegionSeed> seeds;
  std::map<int, int> line_of_index;
  while (r.tokens(tok)) {
    if (tok.size() != 6) {
      std::string got = tok.size() < 6 ? "the " + std::string(kFields[tok.size()]) + " is missing"
                                       : "unexpected text '" + tok[6] + "' after the attribute";
      r.fail("expected `index x y z region_id attribute` (6 fields), got " +
             std::to_string(tok.size()) + ": " + got);
    }
    if (static_cast<long>(seeds.size()) == n)
      r.fail("more regions than the " + std::to_string(n) + " announced on line " +
             std::to_string(count_line));
    RegionSeed s;
    s.line = r.line;
    s.index = r.int32(tok[0], "the index (field 1)");
    if (const auto [it, fresh] = line_of_index.emplace(s.index, s.line); !fresh)
      r.fail("index " + tok[0] + " is given twice (also on line " + std::to_string(it->second) +
             "; expected one line per region)");
    s.point.x() = r.number(tok[1], "x (field 2)");
    s.point.y() = r.number(tok[2], "y (field 3)");
    s.point.z() = r.number(tok[3], "z (field 4)");
    s.region_id = r.int32(tok[4], "the region_id (field 5, an integer tissue attribute)");
    // The attribute is the region's maximum tet volume (m^3; <= 0 = no constraint).
    s.max_volume =
        r.number(tok[5], "the attribute (field 6, the maximum tet volume in m^3; <= 0 = none)");
    seeds.push_back(s);
  }
  if (static_cast<long>(seeds.size()) != n)
    throw InputError(SourceLocation{path, r.line}, "the first line announces " + std::to_string(n) +
                                                       " regions but " +
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

namespace {

// ---- the TetGen run, in a child process
//
// TetGen 1.5 aborts (exit(), assert) or crashes on some inputs that pass every check we can
// afford, and it can loop for a very long time on others. It therefore runs in a forked child
// that sends its result through a pipe: a crash, abort or timeout of the child becomes an
// InputError in palplab, never the end of palplab.

struct RawTets {
  std::vector<double> points;  // 3 per point
  std::vector<int> tets;       // 4 per tet
  std::vector<double> attr;    // first tet attribute, when regions were seeded
};

void write_all(int fd, const void* data, std::size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) ::_exit(120);  // parent gone: nothing to report to
    p += w;
    n -= static_cast<std::size_t>(w);
  }
}

template <class T>
void put(int fd, const T& x) {
  write_all(fd, &x, sizeof x);
}

// Child side: run TetGen, then write status (0 = ok, else TetGen's error code) and the result.
// The child's address space is held to half of the machine's memory: a volume bound the checks
// before TetGen let through (a region's own volume is not known before it runs) ends as "out of
// memory" instead of growing until --timeout on a shared machine (review 2026-12-06, second:
// 55 MB/s). Not under AddressSanitizer, whose shadow memory is address space.
// The child's address-space limit (bytes): half of the machine's memory, or the process's own
// lower limit (`fem reference --mem-limit-gb`); 0 when none applies.
rlim_t child_memory_limit() {
#if !defined(__SANITIZE_ADDRESS__)
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return 0;
  const rlim_t half = static_cast<rlim_t>(pages) / 2 * static_cast<rlim_t>(page);
  struct rlimit lim {};
  if (::getrlimit(RLIMIT_AS, &lim) != 0) return 0;
  return lim.rlim_cur == RLIM_INFINITY ? half : std::min(lim.rlim_cur, half);
#else
  return 0;
#endif
}

void limit_child_memory() {
  const rlim_t want = child_memory_limit();
  struct rlimit lim {};
  if (want == 0 || ::getrlimit(RLIMIT_AS, &lim) != 0) return;
  if (lim.rlim_cur == RLIM_INFINITY || lim.rlim_cur > want) {
    lim.rlim_cur = want;
    ::setrlimit(RLIMIT_AS, &lim);
  }
}

[[noreturn]] void child_run(int fd, const SurfaceMesh& s, const TetOptions& opt) {
  limit_child_memory();
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
  int status = 0;
  try {
    ::tetrahedralize(swbuf.data(), &in, &out);
  } catch (int code) {
    status = code == 0 ? 2 : code;
  } catch (const std::bad_alloc&) {
    status = 1;  // out of memory, as TetGen's own code 1
  } catch (...) {
    status = 2;
  }
  put(fd, status);
  if (status == 0) {
    const std::int64_t np = out.numberofpoints, nt = out.numberoftetrahedra;
    const bool attr = !opt.seeds.empty() && out.numberoftetrahedronattributes > 0;
    put(fd, np);
    put(fd, nt);
    put(fd, static_cast<std::int32_t>(attr));
    write_all(fd, out.pointlist, sizeof(double) * 3 * np);
    std::vector<int> t(4 * nt);
    for (std::int64_t i = 0; i < nt; ++i)
      for (int k = 0; k < 4; ++k) t[4 * i + k] = out.tetrahedronlist[out.numberofcorners * i + k];
    write_all(fd, t.data(), sizeof(int) * t.size());
    if (attr) {
      std::vector<double> a(nt);
      for (std::int64_t i = 0; i < nt; ++i)
        a[i] = out.tetrahedronattributelist[out.numberoftetrahedronattributes * i];
      write_all(fd, a.data(), sizeof(double) * a.size());
    }
  }
  ::close(fd);
  ::_exit(0);  // no atexit handlers, no flush of the parent's stdio buffers
}

// Parent side: reads everything the child sends (until EOF or the deadline).
bool read_all(int fd, std::string& buf, std::chrono::steady_clock::time_point deadline) {
  char chunk[1 << 16];
  while (true) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pollfd pfd{fd, POLLIN, 0};
    const int pr = ::poll(&pfd, 1, static_cast<int>(std::min<long long>(left.count(), 1 << 30)));
    if (pr < 0 && errno == EINTR) continue;
    if (pr <= 0) return pr == 0 ? false : true;
    const ssize_t r = ::read(fd, chunk, sizeof chunk);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return true;  // EOF (or error): the child is done
    buf.append(chunk, static_cast<std::size_t>(r));
  }
}

RawTets run_tetgen_isolated(const SurfaceMesh& s, const TetOptions& opt) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error("tetrahedralize: pipe() failed");
  std::fflush(nullptr);  // nothing buffered may be written twice
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error("tetrahedralize: fork() failed");
  }
  if (pid == 0) {
    ::close(fds[0]);
    child_run(fds[1], s, opt);
  }
  ::close(fds[1]);
  const double limit = opt.timeout_seconds > 0 ? opt.timeout_seconds : 1e9;
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<long long>(limit * 1000));
  std::string buf;
  const bool finished = read_all(fds[0], buf, deadline);
  ::close(fds[0]);
  if (!finished) ::kill(pid, SIGKILL);
  int st = 0;
  while (::waitpid(pid, &st, 0) < 0 && errno == EINTR) {
  }
  if (!finished)
    throw InputError("TetGen did not finish within " + format_exact(limit) +
                     " s (--timeout); the surface may be nearly degenerate: run `palplab mesh "
                     "check` and `palplab mesh repair`, or relax --quality/--max-volume");
  // TetGen does not check every allocation: out of memory can end in a crash. Under a
  // command's own memory limit (`fem reference --mem-limit-gb`, below half of the memory) the
  // crash is taken for that (a 0.05 GB limit was reported as a bad surface, exit 2); else it may
  // still be the half of the machine's memory the child is held to.
  char mem[160] = "";
  if (const rlim_t cap = child_memory_limit(); cap > 0 && WIFSIGNALED(st)) {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    const rlim_t half =
        pages > 0 && page > 0 ? static_cast<rlim_t>(pages) / 2 * static_cast<rlim_t>(page) : 0;
    if (cap < half) throw std::bad_alloc();
    std::snprintf(mem, sizeof mem,
                  " (or it ran out of memory: it may use %.3g GB, half of this machine's memory)",
                  static_cast<double>(cap) / 1073741824.0);
  }
  if (WIFSIGNALED(st))
    throw InputError(std::string("TetGen crashed on this surface (signal ") +
                     std::to_string(WTERMSIG(st)) + ", " + strsignal(WTERMSIG(st)) + ")" + mem +
                     "; run `palplab mesh check` and `palplab mesh repair` on it" +
                     (opt.seeds.empty() ? std::string()
                                        : std::string(", and check that every region seed lies "
                                                      "inside the region it seeds")));
  std::size_t pos = 0;
  auto get = [&](void* dst, std::size_t n) {
    if (buf.size() - pos < n)
      throw InputError("TetGen stopped without a result (exit status " +
                       std::to_string(WIFEXITED(st) ? WEXITSTATUS(st) : -1) +
                       "); run `palplab mesh check` on the surface");
    std::memcpy(dst, buf.data() + pos, n);
    pos += n;
  };
  std::int32_t status = 0;
  get(&status, sizeof status);
  if (status != 0) throw InputError(tetgen_error(status));
  std::int64_t np = 0, nt = 0;
  std::int32_t has_attr = 0;
  get(&np, sizeof np);
  get(&nt, sizeof nt);
  get(&has_attr, sizeof has_attr);
  if (np < 0 || nt < 0 || np > (1LL << 31) || nt > (1LL << 31))
    throw InputError("TetGen returned a malformed result");
  RawTets r;
  r.points.resize(3 * np);
  r.tets.resize(4 * nt);
  get(r.points.data(), sizeof(double) * r.points.size());
  get(r.tets.data(), sizeof(int) * r.tets.size());
  if (has_attr) {
    r.attr.resize(nt);
    get(r.attr.data(), sizeof(double) * r.attr.size());
  }
  return r;
}

}  // namespace

void check_tetgen_input(const SurfaceMesh& s) {
  if (s.V.rows() < 4 || s.F.rows() < 4)
    throw InputError("cannot tetrahedralize: the surface has " + std::to_string(s.V.rows()) +
                     " vertices and " + std::to_string(s.F.rows()) +
                     " triangles (a closed surface needs at least 4 of each)");
  for (int i = 0; i < s.V.rows(); ++i)
    if (!s.V.row(i).allFinite())
      throw InputError("cannot tetrahedralize: vertex " + std::to_string(i) +
                       " has a coordinate that is not a finite number (NaN or inf)");
  const double extent = (s.V.colwise().maxCoeff() - s.V.colwise().minCoeff()).maxCoeff();
  if (!(extent > 0) || !std::isfinite(extent) || extent > 1e6)
    throw InputError("cannot tetrahedralize: the surface's extent is " + format_exact(extent) +
                     " m (expected a positive size below 1e6 m)");
  CheckOptions co;
  co.max_per_kind = 1;
  const CheckReport rep = check_surface(s, co);
  // Every kind TetGen cannot take (orientation alone is harmless to it).
  std::string list, first;
  for (const auto& [kind, n] : rep.counts) {
    if (kind == "inconsistent_orientation" || kind == "inside_out") continue;
    list += (list.empty() ? "" : ", ") + std::to_string(n) + " " + kind;
    if (first.empty())
      for (const Defect& d : rep.defects)
        if (d.kind == kind) {
          first = kind + " at";
          if (!d.faces.empty()) {
            first += " face";
            for (int f : d.faces) first += " " + std::to_string(f);
          } else {
            first += " vertex";
            for (int v : d.vertices) first += " " + std::to_string(v);
          }
          break;
        }
  }
  if (!list.empty())
    throw InputError("cannot tetrahedralize: the surface has " + list + " (first: " + first +
                     "); run `palplab mesh check` for all of them and `palplab mesh repair` to "
                     "fix what can be fixed");
}

void check_region_seeds_inside(const SurfaceMesh& s, const std::vector<RegionSeed>& seeds,
                               const std::string& source) {
  if (seeds.empty() || s.F.rows() == 0) return;
  // Connected components of faces (through shared vertices): the generalized winding number of
  // each closed component is +-1 inside it and 0 outside, whatever its orientation, so a seed
  // between nested surfaces (fat between skin and muscle) is inside too.
  const long nv = s.V.rows(), nf = s.F.rows();
  std::vector<long> parent(nv);
  for (long i = 0; i < nv; ++i) parent[i] = i;
  auto root = [&](long a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (long f = 0; f < nf; ++f)
    for (int k = 1; k < 3; ++k) {
      const long a = root(s.F(f, 0)), b = root(s.F(f, k));
      if (a != b) parent[a] = b;
    }
  std::map<long, int> comp_of_root;
  std::vector<int> face_comp(nf);
  for (long f = 0; f < nf; ++f) {
    const long r0 = root(s.F(f, 0));
    auto it = comp_of_root.emplace(r0, static_cast<int>(comp_of_root.size())).first;
    face_comp[f] = it->second;
  }
  std::vector<double> w(comp_of_root.size());
  for (const RegionSeed& g : seeds) {
    std::fill(w.begin(), w.end(), 0.0);
    for (long f = 0; f < nf; ++f) {
      // Solid angle of the triangle seen from the seed (van Oosterom & Strackee 1983).
      const Vec3 a = s.V.row(s.F(f, 0)).transpose() - g.point;
      const Vec3 b = s.V.row(s.F(f, 1)).transpose() - g.point;
      const Vec3 c = s.V.row(s.F(f, 2)).transpose() - g.point;
      const double la = a.norm(), lb = b.norm(), lc = c.norm();
      const double num = a.dot(b.cross(c));
      const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
      w[face_comp[f]] += 2 * std::atan2(num, den);
    }
    bool inside = false;
    for (double x : w) inside = inside || std::abs(x) / (4 * M_PI) > 0.5;
    if (!inside) {
      const std::string what =
          "region seed " + std::to_string(g.index) + " at (" + format_exact(g.point.x()) + ", " +
          format_exact(g.point.y()) + ", " + format_exact(g.point.z()) +
          ") is not inside the closed surface (expected a point inside the region it seeds)";
      if (!source.empty()) throw InputError(SourceLocation{source, g.line}, what);
      throw InputError(what);
    }
  }
}

namespace {
// Two seeds of different tissues in one closed region: TetGen floods the region from one seed
// and the other's tissue vanished (1774 tets of 101, 1 of 102, exit 0; review 2026-12-07).
// Closed regions are the tets connected across faces that are not the input surface's; two
// seeds with different region_ids in one are refused, naming both.
void check_one_seed_per_region(const TetOptions& opt, const SurfaceMesh& s, const Positions& V,
                               const Tets& T) {
  if (opt.seeds.size() < 2) return;
  using Tri = std::array<int, 3>;
  auto sorted = [](int a, int b, int c) {
    Tri t{a, b, c};
    std::sort(t.begin(), t.end());
    return t;
  };
  std::set<Tri> surface;
  for (int f = 0; f < s.F.rows(); ++f) surface.insert(sorted(s.F(f, 0), s.F(f, 1), s.F(f, 2)));
  std::vector<int> parent(static_cast<std::size_t>(T.rows()));
  for (int t = 0; t < T.rows(); ++t) parent[static_cast<std::size_t>(t)] = t;
  std::map<Tri, int> first;
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  for (int t = 0; t < T.rows(); ++t)
    for (const auto& f : kFace) {
      const Tri key = sorted(T(t, f[0]), T(t, f[1]), T(t, f[2]));
      if (surface.count(key)) continue;
      const auto [it, fresh] = first.emplace(key, t);
      if (!fresh)
        parent[static_cast<std::size_t>(detail::find_root(parent, t))] =
            detail::find_root(parent, it->second);
    }
  // The component of each seed: of a tet containing its point.
  auto component_of = [&](const Vec3& x) {
    for (int t = 0; t < T.rows(); ++t) {
      const Vec3 a = row3(V, T(t, 0)), b = row3(V, T(t, 1)), c = row3(V, T(t, 2)),
                 d = row3(V, T(t, 3));
      const double v = signed_volume(a, b, c, d);
      if (!(std::abs(v) > 0)) continue;
      const double sgn = v > 0 ? 1.0 : -1.0, tol = -1e-12 * std::abs(v);
      if (sgn * signed_volume(x, b, c, d) < tol || sgn * signed_volume(a, x, c, d) < tol ||
          sgn * signed_volume(a, b, x, d) < tol || sgn * signed_volume(a, b, c, x) < tol)
        continue;
      return detail::find_root(parent, t);
    }
    return -1;
  };
  auto where = [&](const RegionSeed& g) {
    std::string w = g.line > 0 ? "line " : "seed ";
    w += std::to_string(g.line > 0 ? g.line : g.index);
    return w;
  };
  std::map<int, const RegionSeed*> seed_of;  // component -> its first seed
  for (const RegionSeed& g : opt.seeds) {
    const int c = component_of(g.point);
    if (c < 0) continue;
    const auto [it, fresh] = seed_of.emplace(c, &g);
    if (fresh || it->second->region_id == g.region_id) continue;
    const std::string why =
        "the region seeds of " + where(*it->second) + " (region_id " +
        std::to_string(it->second->region_id) + ") and " + where(g) + " (region_id " +
        std::to_string(g.region_id) +
        ") lie in one closed region (a part of the interior bounded by the surface's faces): "
        "two seeds in one closed region, and TetGen gives all of it one tissue; give each closed "
        "region one seed";
    if (g.line > 0) throw InputError(SourceLocation{opt.regions_file, g.line}, why);
    throw InputError(why);
  }
}
}  // namespace

TetMesh tetrahedralize(const SurfaceMesh& s, const TetOptions& opt) {
  if (opt.quality < 0 || (opt.quality > 0 && opt.quality < 1.0) || !std::isfinite(opt.quality))
    throw InputError("--quality must be 0 (off) or a radius-edge ratio >= 1.0, got " +
                     format_exact(opt.quality));
  if (opt.max_volume < 0 || !std::isfinite(opt.max_volume))
    throw InputError("--max-volume must be > 0, got " + format_exact(opt.max_volume));
  for (const RegionSeed& g : opt.seeds)
    if (!g.point.allFinite() || !std::isfinite(g.max_volume))
      throw InputError("region seed " + std::to_string(g.index) + " is not finite");
  check_tetgen_input(s);
  check_region_seeds_inside(s, opt.seeds, opt.regions_file);
  // A volume bound that asks for more tetrahedra than memory holds: TetGen grew by ~55 MB/s
  // until --timeout (1e-30 m³ in a 5 cm sphere). Each tetrahedron is at most the bound, so the
  // surface's volume over the bound is a lower limit of their number; a region seed's bound is
  // held to the same limit (its region may fill the surface: its own volume is not known before
  // TetGen runs). The child's memory limit (limit_child_memory) backs this up.
  constexpr double kMaxTets = 2e7;
  const double volume = std::abs(enclosed_volume(s.V, s.F));
  auto refuse_tiny = [&](double bound, const std::string& what, const char* asks,
                         const std::string& source, int line) {
    if (!(bound > 0) || volume / bound <= kMaxTets) return;
    const std::string why = what + " " + format_g(bound) + " m^3 asks for " +
                            (std::isfinite(volume / bound) ? asks + (" " + format_g(volume / bound))
                                                           : std::string("more than 1e308")) +
                            " tetrahedra (the surface encloses " + format_g(volume) +
                            " m^3); palplab meshes at most 2e7: expected a bound of at least " +
                            format_g(volume / kMaxTets) + " m^3";
    if (!source.empty()) throw InputError(SourceLocation{source, line}, why);
    throw InputError(why);
  };
  refuse_tiny(opt.max_volume, "--max-volume", "at least", "", 0);
  for (const RegionSeed& g : opt.seeds)
    refuse_tiny(g.max_volume, "region seed " + std::to_string(g.index) + "'s volume bound", "up to",
                g.line > 0 ? opt.regions_file : std::string(), g.line);
  const RawTets out = run_tetgen_isolated(s, opt);
  const int np = static_cast<int>(out.points.size() / 3),
            nt = static_cast<int>(out.tets.size() / 4);
  if (nt <= 0) throw InputError("TetGen produced no tetrahedra");
  Positions V(np, 3);
  for (int i = 0; i < np; ++i)
    V.row(i) << out.points[3 * i], out.points[3 * i + 1], out.points[3 * i + 2];
  Tets T(nt, 4);
  Eigen::VectorXi A = Eigen::VectorXi::Constant(nt, opt.default_attribute);
  // TetGen -A numbers the tets of a closed region without a seed itself (0, or max seed
  // attribute + 1, + 2, ...: a bone region left unseeded next to seed 300 came out as 301,
  // muscle): only a seed's region_id is kept, every other tet gets the default attribute.
  std::set<int> seeded;
  for (const RegionSeed& g : opt.seeds)
    if (g.region_id != 0) seeded.insert(g.region_id);
  for (int t = 0; t < nt; ++t) {
    for (int k = 0; k < 4; ++k) T(t, k) = out.tets[4 * t + k];
    if (!out.attr.empty()) {
      const long a = std::lround(out.attr[t]);
      if (a == static_cast<int>(a) && seeded.count(static_cast<int>(a))) A[t] = static_cast<int>(a);
    }
  }
  check_one_seed_per_region(opt, s, V, T);
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
