// The .psim simulation file (scene_file.hpp): a bounds-checked binary writer/reader of the
// prepared SceneMesh and the model's stored precomputation, with the header checks in the
// order a user needs them (what the file is, which version, whether it is intact, whether its
// sources changed).
#include "engine/haptics/scene_file.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <type_traits>

#include "common/input_error.hpp"
#include "common/write_file.hpp"
#include "engine/haptics/contact.hpp"
#include "engine/mesh/io.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/models/model.hpp"
#include "engine/spatial/octree.hpp"
#include "palplab/version.hpp"
#include "results/sha256.hpp"

namespace palplab::engine {

namespace fs = std::filesystem;
using Digest = std::array<std::uint8_t, 32>;

namespace {

constexpr char kMagic[8] = {'P', 'A', 'L', 'P', 'S', 'I', 'M', '\0'};
constexpr std::size_t kHeaderCheckAt = 120;

std::string hex(const std::uint8_t* p, std::size_t n) {
  static const char* d = "0123456789abcdef";
  std::string s;
  for (std::size_t i = 0; i < n; ++i) {
    s += d[p[i] >> 4];
    s += d[p[i] & 15];
  }
  return s;
}

Digest sha256(const void* p, std::size_t n) {
  results::Sha256 h;
  h.update(p, n);
  return h.digest();
}

// A whole file, read-only, mapped into memory (MAP_POPULATE: the page cache's pages are mapped in
// one call). Reading into a buffer instead cost a zero-filled allocation (a page fault per 4 KiB
// on first touch, and glibc unmapping or trimming it again when freed: in a loop this made the
// load time bimodal, docs/FORMATS.md) plus a copy out of the page cache; a mapping costs neither.
// A file that cannot be mapped (a pipe, /proc) is read into a buffer. palplab never truncates a
// .psim in place (scene build writes a new file and renames it), so a mapped file does not
// shrink under the reader.
class FileBytes {
 public:
  // `missing`: the message when the file cannot be opened; `regular`: anything but a regular
  // file (a directory, a device) is that error too.
  FileBytes(const std::string& path, const char* missing, bool regular = false) {
    // Opened without blocking (a FIFO with no writer blocked here for ever: review 2026-12-06,
    // fifth), then read blocking as usual.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) throw InputError(missing, path);
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    struct stat st {};
    if (regular && (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))) {
      ::close(fd);
      throw InputError("is not a regular file (a directory, a FIFO or a device)", path);
    }
    // A small file (a prototype) is cheaper to read than to map and unmap.
    if ((regular || ::fstat(fd, &st) == 0) && S_ISREG(st.st_mode) && st.st_size > kMapFrom) {
      n_ = static_cast<std::size_t>(st.st_size);
      void* m = ::mmap(nullptr, n_, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
      if (m != MAP_FAILED) {
        map_ = m;
        p_ = static_cast<const char*>(m);
        ::close(fd);
        return;
      }
    }
    // Small, not mappable or empty: read to the end.
    if (st.st_size > 0) buf_.reserve(static_cast<std::size_t>(st.st_size));
    char chunk[65536];
    for (;;) {
      const ssize_t k = ::read(fd, chunk, sizeof chunk);
      if (k < 0) {
        ::close(fd);
        throw InputError(missing, path);
      }
      if (k == 0) break;
      buf_.append(chunk, static_cast<std::size_t>(k));
    }
    ::close(fd);
    p_ = buf_.data();
    n_ = buf_.size();
  }
  FileBytes(const FileBytes&) = delete;
  FileBytes& operator=(const FileBytes&) = delete;
  ~FileBytes() {
    if (map_) ::munmap(map_, n_);
  }
  const char* data() const { return p_; }
  std::size_t size() const { return n_; }

 private:
  static constexpr off_t kMapFrom = 64 * 1024;  // bytes
  void* map_ = nullptr;
  std::string buf_;
  const char* p_ = nullptr;
  std::size_t n_ = 0;
};

// The payload checksum (format 5): 256 bits from eight 64-bit lanes over 64-byte stripes, the
// accumulation of XXH3 (Collet; not its exact output): per 8-byte word w of lane i, with k = w
// xor a per-position secret word, acc[i ^ 1] += w and acc[i] += lo32(k) * hi32(k); every 16
// stripes (1 KiB) each lane is scrambled (xorshift, xor secret, times an odd constant: a
// bijection). A change confined to one word always changes its neighbour lane (+= w, and every
// later step adds the same to both files or is a bijection), and the finish below keeps a
// difference in one lane; the secret word depends on the stripe's place in its 1 KiB block, so
// stripes swapped within a block change the sums too. Truncation is caught by the stored size
// first. It guards against damage, not against an adversary (the sources fingerprint is
// SHA-256). With SSE2 (every x86-64) two lanes per instruction: twice the speed of format 4's
// four multiply-rotate lanes (18.9 vs 9.8 GB/s on 2.4 MB in cache), which were a sixth of
// loading prototypes A and B (perf). A file is read only by the palplab build that wrote it
// (the header's version check), so the SSE2 and the portable path need only agree with each
// other, which they do (the portable one does the file's last, partial stripe).
struct ChecksumSecret {
  std::uint64_t k[8 + 15 + 8];  // stripe keys at offsets 0..15, then the scramble keys
};
constexpr ChecksumSecret make_checksum_secret() {  // splitmix64 from the digits of pi
  ChecksumSecret s{};
  std::uint64_t x = 0x243F6A8885A308D3ULL;
  for (auto& v : s.k) {
    x += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = x;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    v = z ^ (z >> 31);
  }
  return s;
}
constexpr ChecksumSecret kChecksumSecret = make_checksum_secret();

inline void checksum_stripe(std::uint64_t* acc, const char* p, const std::uint64_t* key) {
  for (int i = 0; i < 8; ++i) {
    std::uint64_t w;
    std::memcpy(&w, p + 8 * i, 8);
    const std::uint64_t k = w ^ key[i];
    acc[i ^ 1] += w;
    acc[i] += (k & 0xFFFFFFFFu) * (k >> 32);
  }
}

#if defined(__SSE2__)
inline void checksum_stripe_sse2(__m128i* acc, const char* p, const std::uint64_t* key) {
  for (int i = 0; i < 4; ++i) {
    const __m128i w = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p) + i);
    const __m128i k = _mm_xor_si128(w, _mm_loadu_si128(reinterpret_cast<const __m128i*>(key) + i));
    const __m128i prod = _mm_mul_epu32(k, _mm_shuffle_epi32(k, _MM_SHUFFLE(0, 3, 0, 1)));
    const __m128i swapped = _mm_shuffle_epi32(w, _MM_SHUFFLE(1, 0, 3, 2));  // to lane i ^ 1
    acc[i] = _mm_add_epi64(acc[i], _mm_add_epi64(prod, swapped));
  }
}
#endif

#if defined(__x86_64__) && defined(__GNUC__)
#define PALPLAB_PSIM_AVX2 1
// The same stripes four lanes per instruction (AVX2, chosen at run time: the build targets the
// x86-64 baseline): the lane pairs i, i ^ 1 stay within each 128-bit half, so the SSE2 shuffles
// carry over unchanged; the scramble's multiply by the 32-bit prime is lo * P + (hi * P << 32),
// exactly the 64-bit product. Its result is the SSE2 path's (tests/scene_file: every path on
// every tail length), at about 1.6 times its speed (measured in docs/FORMATS.md).
[[gnu::target("avx2")]] void checksum_stripes_avx2(std::uint64_t* acc, const char* p,
                                                   std::size_t stripes, const std::uint64_t* secret,
                                                   std::uint64_t prime32) {
  __m256i a[2] = {_mm256_loadu_si256(reinterpret_cast<const __m256i*>(acc)),
                  _mm256_loadu_si256(reinterpret_cast<const __m256i*>(acc) + 1)};
  const __m256i prime = _mm256_set1_epi64x(static_cast<long long>(prime32));
  int s = 0;
  for (std::size_t t = 0; t < stripes; ++t, p += 64) {
    for (int h = 0; h < 2; ++h) {
      const __m256i w = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p) + h);
      const __m256i k =
          _mm256_xor_si256(w, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(secret + s) + h));
      const __m256i prod = _mm256_mul_epu32(k, _mm256_shuffle_epi32(k, _MM_SHUFFLE(0, 3, 0, 1)));
      const __m256i swapped = _mm256_shuffle_epi32(w, _MM_SHUFFLE(1, 0, 3, 2));
      a[h] = _mm256_add_epi64(a[h], _mm256_add_epi64(prod, swapped));
    }
    if (++s == 16) {
      s = 0;
      for (int h = 0; h < 2; ++h) {
        __m256i x = _mm256_xor_si256(a[h], _mm256_srli_epi64(a[h], 47));
        x = _mm256_xor_si256(x,
                             _mm256_loadu_si256(reinterpret_cast<const __m256i*>(secret + 23) + h));
        const __m256i lo = _mm256_mul_epu32(x, prime);
        const __m256i hi = _mm256_mul_epu32(_mm256_srli_epi64(x, 32), prime);
        a[h] = _mm256_add_epi64(lo, _mm256_slli_epi64(hi, 32));
      }
    }
  }
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(acc), a[0]);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(acc) + 1, a[1]);
}
bool cpu_has_avx2() {
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
}
#endif

}  // namespace

Digest psim_payload_checksum(const void* data, std::size_t n, ChecksumPath path) {
  const char* p = static_cast<const char*>(data);
  constexpr std::uint64_t P1 = 0x9E3779B185EBCA87ULL, P2 = 0xC2B2AE3D27D4EB4FULL,
                          P3 = 0x165667B19E3779F9ULL, P5 = 0x27D4EB2F165667C5ULL, P32 = 0x9E3779B1u;
  const std::uint64_t* secret = kChecksumSecret.k;
  alignas(16) std::uint64_t acc[8] = {P32, P1, P2, P3, P5, P1 ^ P2, P2 ^ P3, P3 ^ P5};
  auto scramble = [&] {
    for (int l = 0; l < 8; ++l) {
      std::uint64_t a = acc[l];
      a ^= a >> 47;
      a ^= secret[23 + l];
      acc[l] = a * P32;
    }
  };
  std::size_t i = 0;
  int s = 0;  // the stripe's place in its 1 KiB block
#if defined(PALPLAB_PSIM_AVX2)
  if (path == ChecksumPath::best && cpu_has_avx2()) path = ChecksumPath::avx2;
  if (path == ChecksumPath::avx2) {
    if (!cpu_has_avx2()) throw std::logic_error("psim checksum: this CPU has no AVX2");
    const std::size_t stripes = n / 64;
    checksum_stripes_avx2(acc, p, stripes, secret, P32);
    i = 64 * stripes;
    s = static_cast<int>(stripes % 16);
  }
#else
  if (path == ChecksumPath::avx2) throw std::logic_error("psim checksum: built without AVX2");
#endif
#if defined(__SSE2__)
  if (path == ChecksumPath::best) path = ChecksumPath::sse2;
  if (path == ChecksumPath::sse2) {
    auto* a = reinterpret_cast<__m128i*>(acc);
    for (; i + 64 <= n; i += 64) {
      checksum_stripe_sse2(a, p + i, secret + s);
      if (++s == 16) {
        s = 0;
        scramble();
      }
    }
  }
#else
  if (path == ChecksumPath::sse2) throw std::logic_error("psim checksum: built without SSE2");
#endif
  // The portable path (and the last, partial stripe of every path).
  for (; i + 64 <= n; i += 64) {
    checksum_stripe(acc, p + i, secret + s);
    if (++s == 16) {
      s = 0;
      scramble();
    }
  }
  char tail[64] = {};
  std::memcpy(tail, p + i, n - i);
  checksum_stripe(acc, tail, secret + s);
  auto rotl = [](std::uint64_t x, int r) { return (x << r) | (x >> (64 - r)); };
  auto avalanche = [](std::uint64_t h) {
    h ^= h >> 33;
    h *= P2;
    h ^= h >> 29;
    h *= P3;
    h ^= h >> 32;
    return h;
  };
  // Output word k: a bijection of lane k for a fixed lane k + 4 and the other way round.
  Digest d;
  for (int k = 0; k < 4; ++k) {
    const std::uint64_t h =
        avalanche(acc[k] + rotl(acc[k + 4], 17) + static_cast<std::uint64_t>(n) * P5 + k);
    std::memcpy(d.data() + 8 * k, &h, 8);
  }
  return d;
}

bool psim_checksum_has_avx2() {
#if defined(PALPLAB_PSIM_AVX2)
  return cpu_has_avx2();
#else
  return false;
#endif
}

namespace {

Digest payload_checksum(const char* p, std::size_t n) {
  return psim_payload_checksum(p, n, ChecksumPath::best);
}

// ---- writer / reader --------------------------------------------------------------------

class Writer {
 public:
  template <class T>
  void put(T v) {
    static_assert(std::is_trivially_copyable_v<T>);
    raw(&v, sizeof v);
  }
  void raw(const void* p, std::size_t n) {
    const auto* c = static_cast<const char*>(p);
    buf_.append(c, n);
  }
  void str(const std::string& s) {
    put<std::uint64_t>(s.size());
    raw(s.data(), s.size());
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    put<std::uint64_t>(v.size());
    raw(v.data(), v.size() * sizeof(T));
  }
  template <class M>
  void mat(const M& m) {
    put<std::int64_t>(m.rows());
    put<std::int64_t>(m.cols());
    raw(m.data(), static_cast<std::size_t>(m.size()) * sizeof(typename M::Scalar));
  }
  std::string& bytes() { return buf_; }

 private:
  std::string buf_;
};

// Every read is bounds-checked: a payload that passed its checksum but does not parse (a bug, or
// a file written by hand) is a located InputError, never a read past the end.
class Reader {
 public:
  Reader(const std::string& file, const char* p, std::size_t n) : file_(file), p_(p), n_(n) {}
  void need(std::size_t k, const char* what) {
    if (k > n_ - at_) past_end(what);
  }
  // k bytes at the current offset (bounds-checked once), advanced past.
  const char* bytes(std::size_t k, const char* what) {
    need(k, what);
    const char* b = p_ + at_;
    at_ += k;
    return b;
  }
  template <class T>
  T get(const char* what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, p_ + at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  std::size_t count(std::size_t elem, const char* what) {
    const auto n = get<std::uint64_t>(what);
    if (elem && n > (n_ - at_) / elem) need(n_ + 1, what);  // throws
    return static_cast<std::size_t>(n);
  }
  std::string str(const char* what) {
    const std::size_t n = count(1, what);
    std::string s(p_ + at_, n);
    at_ += n;
    return s;
  }
  template <class T>
  std::vector<T> vec(const char* what) {
    const std::size_t n = count(sizeof(T), what);
    std::vector<T> v;
    const char* src = p_ + at_;
    if (reinterpret_cast<std::uintptr_t>(src) % alignof(T) == 0) {
      // Aligned in the mapped file: one copy, no zero fill first.
      const T* t = reinterpret_cast<const T*>(src);
      v.assign(t, t + n);
    } else {
      v.resize(n);
      if (n) std::memcpy(v.data(), src, n * sizeof(T));
    }
    at_ += n * sizeof(T);
    return v;
  }
  template <class M>
  void mat(M& m, const char* what) {
    const auto r = get<std::int64_t>(what), c = get<std::int64_t>(what);
    const bool fixed_cols = M::ColsAtCompileTime != Eigen::Dynamic;
    if (r < 0 || c < 0 || (fixed_cols && c != M::ColsAtCompileTime) ||
        (M::ColsAtCompileTime == 1 && c != 1))
      throw InputError(std::string("corrupted scene file: bad shape of ") + what, file_);
    const std::size_t bytes = sizeof(typename M::Scalar);
    if (c && static_cast<std::uint64_t>(r) > (n_ - at_) / bytes / static_cast<std::uint64_t>(c))
      need(n_ + 1, what);
    m.resize(r, c);
    if (r > 0 && c > 0) std::memcpy(m.data(), p_ + at_, static_cast<std::size_t>(r * c) * bytes);
    at_ += static_cast<std::size_t>(r * c) * bytes;
  }
  std::size_t at() const { return at_; }
  std::size_t size() const { return n_; }
  void skip(std::size_t k) {
    need(k, "section");
    at_ += k;
  }
  const std::string& file() const { return file_; }

 private:
  // Out of line and cold, so that need() inlines into every read.
  [[noreturn, gnu::cold, gnu::noinline]] void past_end(const char* what) const {
    throw InputError(std::string("corrupted scene file: ") + what + " at payload offset " +
                         std::to_string(at_) + " runs past the end (" + std::to_string(n_) +
                         " bytes)",
                     file_);
  }
  std::string file_;
  const char* p_;
  std::size_t n_, at_ = 0;
};

// ---- the prepared mesh ------------------------------------------------------------------

// Whole-array checks without an early exit, so that the compiler vectorises them (the
// short-circuiting loops they replace were a third of B's mesh parsing, perf): a damaged file is
// rare, a loaded one is not.
bool any_outside(const std::vector<int>& v, long lo, long hi) {  // some v[i] not in [lo, hi)
  const auto width = static_cast<std::uint32_t>(hi - lo);
  const auto base = static_cast<std::uint32_t>(lo);
  std::uint32_t bad = 0;
  for (int x : v) bad |= static_cast<std::uint32_t>(x) - base >= width;
  return bad != 0;
}
bool any_outside(const std::vector<int>& v, long n) {
  return any_outside(v, 0, n);
}
bool any_decrease(const std::vector<int>& v) {
  std::uint32_t bad = 0;
  for (std::size_t i = 1; i < v.size(); ++i) bad |= v[i] < v[i - 1];
  return bad != 0;
}

void put_csr(Writer& w, const mesh::Csr& c) {
  w.vec(c.offset);
  w.vec(c.index);
}
mesh::Csr get_csr(Reader& r, int rows, const char* what) {
  mesh::Csr c;
  c.offset = r.vec<int>(what);
  c.index = r.vec<int>(what);
  const bool ok = static_cast<int>(c.offset.size()) == rows + 1 && c.offset.front() == 0 &&
                  c.offset.back() == static_cast<int>(c.index.size()) && !any_decrease(c.offset) &&
                  !any_outside(c.index, rows);
  if (!ok) throw InputError(std::string("corrupted scene file: inconsistent ") + what, r.file());
  return c;
}

void put_mesh(Writer& w, const SceneMesh& m) {
  w.mat(m.V);
  w.mat(m.N);
  w.mat(m.F);
  w.mat(m.E);
  w.vec(m.vertex_region);
  w.put<std::uint64_t>(m.region_names.size());
  for (const auto& s : m.region_names) w.str(s);
  w.mat(m.vertex_area);
  w.put(m.mean_edge);
  const spatial::Octree& o = *m.octree;
  w.put<std::int32_t>(o.max_depth);
  w.put<std::int32_t>(o.max_points_per_leaf);
  w.put<std::uint64_t>(o.nodes.size());
  for (const auto& n : o.nodes) {
    w.raw(n.cell.min().data(), 3 * sizeof(double));
    w.raw(n.cell.max().data(), 3 * sizeof(double));
    w.raw(n.box.min().data(), 3 * sizeof(double));
    w.raw(n.box.max().data(), 3 * sizeof(double));
    w.raw(n.child, sizeof n.child);
    w.put<std::int32_t>(n.begin);
    w.put<std::int32_t>(n.end);
    w.put<std::int32_t>(n.depth);
    w.put<std::uint8_t>(n.leaf);
  }
  w.vec(o.order);
  w.vec(o.leaf_of);
  put_csr(w, m.rings->first);
  put_csr(w, m.rings->second);
  w.put<std::uint8_t>(m.tet);
  // A surface mesh's model mesh is the surface again (scene_mesh.cpp prepare): not stored.
  if (!m.tet) return;
  w.mat(m.model_V);
  w.mat(m.model_E);
  w.mat(m.model_T);
  w.mat(m.tet_attribute);
  w.mat(m.model_F);
  w.mat(m.boundary_tet);
  w.vec(m.surface_to_model);
}

template <class M>
void check_indices(const Reader& r, const M& m, long n, const char* what) {
  // One pass without an early exit over the raw entries (Eigen's minCoeff and maxCoeff were two
  // passes, most of checking a mesh's faces and edges, perf).
  const int* x = m.data();
  const auto width = static_cast<std::uint32_t>(n);
  std::uint32_t bad = 0;
  for (Eigen::Index i = 0; i < m.size(); ++i) bad |= static_cast<std::uint32_t>(x[i]) >= width;
  if (bad)
    throw InputError(std::string("corrupted scene file: ") + what + " index out of range",
                     r.file());
}

// `keep` (the file's mapping) lives as long as the mesh: it is unmapped when the mesh is dropped,
// not while a scene is made ready from it (unmapping was 8 % of loading prototype A, perf).
// Nothing reads it after the load: every array is copied out.
std::shared_ptr<const SceneMesh> get_mesh(Reader& r, std::shared_ptr<const void> keep) {
  const std::shared_ptr<SceneMesh> m(new SceneMesh,
                                     [keep = std::move(keep)](SceneMesh* p) { delete p; });
  r.mat(m->V, "surface positions");
  r.mat(m->N, "normals");
  r.mat(m->F, "faces");
  r.mat(m->E, "edges");
  m->vertex_region = r.vec<int>("vertex regions");
  const std::size_t nr = r.count(8, "region names");
  for (std::size_t i = 0; i < nr; ++i) m->region_names.push_back(r.str("region name"));
  r.mat(m->vertex_area, "vertex areas");
  m->mean_edge = r.get<double>("mean edge");
  const long nv = m->V.rows();
  check_indices(r, m->F, nv, "face");
  check_indices(r, m->E, nv, "edge");
  if (m->N.rows() != nv || m->vertex_area.size() != nv ||
      static_cast<long>(m->vertex_region.size()) != nv)
    throw InputError("corrupted scene file: per-vertex arrays disagree in size", r.file());
  if (any_outside(m->vertex_region, -1, static_cast<long>(nr)))
    throw InputError("corrupted scene file: vertex region out of range", r.file());

  auto o = std::make_shared<spatial::Octree>();
  o->max_depth = r.get<std::int32_t>("octree depth");
  o->max_points_per_leaf = r.get<std::int32_t>("octree leaf size");
  // The nodes as put_mesh writes them, field by field from one bounds-checked run (reading each
  // field through get() was most of parsing the octree, perf).
  constexpr std::size_t kNodeBytes = 4 * 3 * 8 + 8 * 4 + 3 * 4 + 1;
  const std::size_t nn = r.count(kNodeBytes, "octree nodes");
  const char* at = r.bytes(nn * kNodeBytes, "octree nodes");
  o->nodes.resize(nn);
  std::uint32_t bad_child = 0;
  for (auto& n : o->nodes) {
    double box[12];
    std::memcpy(box, at, sizeof box);
    n.cell = Eigen::AlignedBox3d(Eigen::Vector3d(box[0], box[1], box[2]),
                                 Eigen::Vector3d(box[3], box[4], box[5]));
    n.box = Eigen::AlignedBox3d(Eigen::Vector3d(box[6], box[7], box[8]),
                                Eigen::Vector3d(box[9], box[10], box[11]));
    static_assert(sizeof n.child == 8 * sizeof(std::int32_t));
    std::memcpy(n.child, at + 96, sizeof n.child);
    std::int32_t run[3];
    std::memcpy(run, at + 128, sizeof run);
    n.begin = run[0];
    n.end = run[1];
    n.depth = run[2];
    n.leaf = at[140] != 0;
    at += kNodeBytes;
    // -1 (none) or a node: ch + 1 in [0, nn] (unsigned, so no early exit).
    for (int ch : n.child)
      bad_child |= static_cast<std::uint32_t>(ch) + 1u > static_cast<std::uint32_t>(nn);
  }
  if (bad_child) throw InputError("corrupted scene file: octree child out of range", r.file());
  o->order = r.vec<int>("octree order");
  o->leaf_of = r.vec<int>("octree leaves");
  if (nn == 0 || static_cast<long>(o->order.size()) != nv ||
      static_cast<long>(o->leaf_of.size()) != nv)
    throw InputError("corrupted scene file: octree does not match the surface", r.file());
  for (const auto& n : o->nodes)
    if (n.begin < 0 || n.end < n.begin || n.end > nv)
      throw InputError("corrupted scene file: octree run out of range", r.file());
  if (any_outside(o->order, nv) || any_outside(o->leaf_of, static_cast<long>(nn)))
    throw InputError("corrupted scene file: octree index out of range", r.file());
  m->octree = o;
  auto rings = std::make_shared<mesh::RingTable>();
  rings->first = get_csr(r, static_cast<int>(nv), "first rings");
  rings->second = get_csr(r, static_cast<int>(nv), "second rings");
  m->rings = rings;
  m->tet = r.get<std::uint8_t>("mesh kind") != 0;
  if (!m->tet) {  // as scene_mesh.cpp prepares a surface mesh
    m->model_V = m->V;
    m->model_E = m->E;
    m->model_F = m->F;
    m->surface_to_model.resize(nv);
    for (long i = 0; i < nv; ++i) m->surface_to_model[i] = static_cast<int>(i);
    return m;
  }
  r.mat(m->model_V, "model positions");
  r.mat(m->model_E, "model edges");
  r.mat(m->model_T, "tets");
  r.mat(m->tet_attribute, "tet attributes");
  r.mat(m->model_F, "boundary faces");
  r.mat(m->boundary_tet, "boundary tets");
  m->surface_to_model = r.vec<int>("surface-to-model map");
  const long nm = m->model_V.rows();
  check_indices(r, m->model_E, nm, "model edge");
  check_indices(r, m->model_T, nm, "tet");
  check_indices(r, m->model_F, nm, "boundary face");
  check_indices(r, m->boundary_tet, std::max<long>(m->model_T.rows(), 1), "boundary tet");
  if (static_cast<long>(m->surface_to_model.size()) != nv ||
      m->tet_attribute.size() != m->model_T.rows())
    throw InputError("corrupted scene file: model arrays disagree in size", r.file());
  if (any_outside(m->surface_to_model, nm))
    throw InputError("corrupted scene file: bad surface map", r.file());
  return m;
}

// ---- the contact tracker's face index (FIDX, format 4) -------------------------------------

// The hierarchy as two flat arrays (read in bulk): per node 6 doubles (box min, max) and 4 ints
// (left, right, begin, end). The face boxes are not stored: recomputed from the surface
// (face_boxes, the builder's own code, so bit-identical) at less cost than reading them.
void put_face_index(Writer& w, const FaceIndex& ix) {
  w.vec(ix.vf_offset);
  w.vec(ix.vf);
  w.vec(ix.edge_face);
  w.put(ix.mean_edge);
  std::vector<double> boxes;
  std::vector<std::int32_t> links;
  boxes.reserve(6 * ix.bvh.size());
  links.reserve(4 * ix.bvh.size());
  for (const auto& n : ix.bvh) {
    boxes.insert(boxes.end(), n.box.min().data(), n.box.min().data() + 3);
    boxes.insert(boxes.end(), n.box.max().data(), n.box.max().data() + 3);
    links.insert(links.end(), {n.left, n.right, n.begin, n.end});
  }
  w.vec(boxes);
  w.vec(links);
  w.vec(ix.order);
  w.put<std::uint8_t>(ix.closed);  // format 6
}

// Read and checked against the surface it indexes (check_face_index): a hand-made file that
// passed the checksum still cannot send the tracker out of range.
std::shared_ptr<const FaceIndex> get_face_index(Reader& r, const SceneMesh& m) {
  auto ix = std::make_shared<FaceIndex>();
  ix->vf_offset = r.vec<int>("vertex-face offsets");
  ix->vf = r.vec<int>("vertex-face table");
  ix->edge_face = r.vec<int>("edge-face table");
  ix->mean_edge = r.get<double>("mean face edge");
  const auto boxes = r.vec<double>("face hierarchy boxes");
  const auto links = r.vec<std::int32_t>("face hierarchy links");
  const std::size_t nb = links.size() / 4;
  if (links.size() != 4 * nb || boxes.size() != 6 * nb)
    throw InputError("corrupted scene file: face hierarchy arrays disagree in size", r.file());
  ix->bvh.resize(nb);
  for (std::size_t i = 0; i < nb; ++i) {
    FaceIndex::Node& n = ix->bvh[i];
    n.box =
        Eigen::AlignedBox3d(Eigen::Vector3d(boxes[6 * i], boxes[6 * i + 1], boxes[6 * i + 2]),
                            Eigen::Vector3d(boxes[6 * i + 3], boxes[6 * i + 4], boxes[6 * i + 5]));
    n.left = links[4 * i];
    n.right = links[4 * i + 1];
    n.begin = links[4 * i + 2];
    n.end = links[4 * i + 3];
  }
  ix->order = r.vec<int>("face order");
  // The builder's verdict (surface_closed), guarded by the payload checksum: a hand-made file
  // that claims a surface with a hole is closed gets a winding number of 0 outside the surface's
  // box (the sum would give a fraction there), never a read out of range.
  ix->closed = r.get<std::uint8_t>("surface closed") != 0;
  ix->face_box = face_boxes(m.V, m.F);
  const std::string bad = check_face_index(*ix, m.V.rows(), m.F.rows());
  if (!bad.empty()) throw InputError("corrupted scene file: face index: " + bad, r.file());
  return ix;
}

// ---- sections ---------------------------------------------------------------------------

constexpr std::uint32_t tag(const char (&s)[5]) {
  return static_cast<std::uint32_t>(s[0]) | static_cast<std::uint32_t>(s[1]) << 8 |
         static_cast<std::uint32_t>(s[2]) << 16 | static_cast<std::uint32_t>(s[3]) << 24;
}

void section(Writer& out, std::uint32_t t, const std::string& body) {
  out.put(t);
  out.str(body);
}

std::string sources_bytes(const std::vector<SceneSource>& s) {
  Writer w;
  w.put<std::uint64_t>(s.size());
  for (const auto& x : s) {
    w.str(x.role);
    w.str(x.path);
    w.raw(x.sha256.data(), 32);
  }
  return std::move(w.bytes());
}

std::vector<SceneSource> get_sources(Reader& r) {
  std::vector<SceneSource> s(r.count(8 + 8 + 32, "sources"));
  for (auto& x : s) {
    x.role = r.str("source role");
    x.path = r.str("source path");
    for (auto& b : x.sha256) b = r.get<std::uint8_t>("source digest");
  }
  return s;
}

}  // namespace

std::string scene_file_tool_version() {
  return std::string(kVersion) + "+" + kGitCommit;
}

namespace {
// fs::absolute(p).lexically_normal(), without building the path's components when p is already
// both (a loaded file's prototype path is: 3 % of loading prototype A).
std::string normal_absolute(const std::string& p) {
  const bool normal = !p.empty() && p[0] == '/' && p.find("//") == std::string::npos &&
                      p.find("/./") == std::string::npos && p.find("/../") == std::string::npos &&
                      p.back() != '/' && !p.ends_with("/.") && !p.ends_with("/..");
  return normal ? p : fs::absolute(p).lexically_normal().string();
}
}  // namespace

std::vector<SceneSource> scene_sources(const SceneConfig& cfg) {
  if (cfg.source.empty())
    throw InputError("a scene file is built from a prototype file (the config names none)");
  std::vector<SceneSource> out;
  auto add = [&](const char* role, const std::string& path) {
    const FileBytes bytes(path, "cannot read a source of the scene");
    out.push_back({role, path, sha256(bytes.data(), bytes.size())});
  };
  add("prototype", normal_absolute(cfg.source));
  if (!cfg.mesh.file.empty()) {
    if (mesh::is_tetgen_path(cfg.mesh.file)) {
      // read_tetgen reads .node, .ele and, when present, .names.
      const std::string base = mesh::tetgen_base(cfg.mesh.file);
      add("mesh", base + ".node");
      add("mesh", base + ".ele");
      std::error_code ec;
      if (fs::is_regular_file(base + ".names", ec)) add("mesh", base + ".names");
    } else {
      add("mesh", cfg.mesh.file);
    }
  }
  // The built-in table is part of this binary, so its digest is a constant of the build: taken
  // once per process (hashing its 4 KB was 4 % of loading prototype A from a .psim file).
  static const Digest materials = [] {
    const std::string& mat = mesh::default_materials_json();
    return sha256(mat.data(), mat.size());
  }();
  out.push_back({"materials", "<built-in materials table>", materials});
  return out;
}

SceneFileInfo write_scene_file(const std::string& out, const SceneConfig& cfg) {
  const ModelKind* kind = find_model_kind(cfg.model);
  if (!kind) throw InputError("unknown model kind \"" + cfg.model + "\"", cfg.source);
  SceneFileInfo info;
  info.format_version = kSceneFileVersion;
  info.tool_version = scene_file_tool_version();
  info.sources = scene_sources(cfg);
  info.prototype = info.sources.front().path;
  info.model_kind = cfg.model;
  const std::shared_ptr<const SceneMesh> mesh = scene_mesh(cfg.mesh);
  std::string blob;
  if (kind->save) blob = kind->save(cfg, *mesh);
  info.model_blob = !blob.empty();

  Writer payload;
  const std::string src = sources_bytes(info.sources);
  {
    Writer s;
    s.str(info.prototype);
    s.raw(src.data(), src.size());
    section(payload, tag("SRCS"), s.bytes());
  }
  {
    Writer s;
    s.str(cfg.mesh.key());
    section(payload, tag("MKEY"), s.bytes());
  }
  {
    Writer s;
    put_mesh(s, *mesh);
    section(payload, tag("MESH"), s.bytes());
  }
  {
    Writer s;
    put_face_index(s, *mesh->face_index);
    section(payload, tag("FIDX"), s.bytes());
  }
  {
    Writer s;
    s.str(cfg.model);
    s.str(blob);
    section(payload, tag("MODL"), s.bytes());
  }
  const std::string& p = payload.bytes();

  std::array<char, kSceneFileHeaderBytes> h{};
  std::memcpy(h.data(), kMagic, 8);
  const std::uint32_t version = kSceneFileVersion, hsize = kSceneFileHeaderBytes;
  const std::uint64_t psize = p.size();
  std::memcpy(h.data() + 8, &version, 4);
  std::memcpy(h.data() + 12, &hsize, 4);
  std::memcpy(h.data() + 16, &psize, 8);
  const Digest pd = payload_checksum(p.data(), p.size()), sd = sha256(src.data(), src.size());
  std::memcpy(h.data() + 24, pd.data(), 32);
  std::memcpy(h.data() + 56, sd.data(), 32);
  if (info.tool_version.size() > 31)
    throw std::logic_error("palplab version string too long for the .psim header");
  std::memcpy(h.data() + 88, info.tool_version.data(), info.tool_version.size());
  const Digest hd = sha256(h.data(), kHeaderCheckAt);
  std::memcpy(h.data() + kHeaderCheckAt, hd.data(), 8);

  // Whole or not at all (written beside the target and renamed; a device or a FIFO directly).
  write_file(out, {std::string_view(h.data(), h.size()), std::string_view(p.data(), p.size())},
             "the scene file");
  info.bytes = h.size() + p.size();
  return info;
}

SceneFileData read_scene_file(const std::string& path) {
  // Kept alive by the loaded mesh (get_mesh), so that it is not unmapped while a scene is made
  // ready.
  const auto mapping = std::make_shared<const FileBytes>(path, "no such scene file", true);
  const FileBytes& bytes = *mapping;
  const std::string rebuild = " (rebuild it with `palplab scene build`)";
  if (bytes.size() == 0)
    throw InputError("is empty (0 bytes), not a palplab scene file (.psim)" + rebuild, path);
  // A file shorter than the magic that is its start: cut off (an interrupted copy).
  if (bytes.size() < 8 && std::memcmp(bytes.data(), kMagic, bytes.size()) == 0)
    throw InputError("truncated scene file: " + std::to_string(bytes.size()) +
                         " bytes, shorter than the " + std::to_string(kSceneFileHeaderBytes) +
                         "-byte header" + rebuild,
                     path);
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    throw InputError("not a palplab scene file (.psim): it does not start with PALPSIM", path);
  if (bytes.size() < kSceneFileHeaderBytes)
    throw InputError("truncated scene file: " + std::to_string(bytes.size()) +
                         " bytes, shorter than the " + std::to_string(kSceneFileHeaderBytes) +
                         "-byte header" + rebuild,
                     path);
  const char* h = bytes.data();
  std::uint32_t version, hsize;
  std::uint64_t psize;
  std::memcpy(&version, h + 8, 4);
  std::memcpy(&hsize, h + 12, 4);
  std::memcpy(&psize, h + 16, 8);
  if (version != kSceneFileVersion)
    throw InputError("scene file format version " + std::to_string(version) +
                         ", this palplab reads version " + std::to_string(kSceneFileVersion) +
                         rebuild,
                     path);
  const Digest hd = sha256(h, kHeaderCheckAt);
  if (std::memcmp(hd.data(), h + kHeaderCheckAt, 8) != 0 || hsize != kSceneFileHeaderBytes)
    throw InputError("corrupted scene file: the header checksum does not match" + rebuild, path);
  SceneFileData d;
  d.info.format_version = version;
  d.info.tool_version = std::string(h + 88, strnlen(h + 88, 32));
  d.info.bytes = bytes.size();
  if (d.info.tool_version != scene_file_tool_version())
    throw InputError("scene file built by palplab " + d.info.tool_version + ", this is palplab " +
                         scene_file_tool_version() + ": precomputation may differ between builds" +
                         rebuild,
                     path);
  const std::uint64_t have = bytes.size() - kSceneFileHeaderBytes;
  if (have < psize)
    throw InputError("truncated scene file: " + std::to_string(have) + " of " +
                         std::to_string(psize) + " payload bytes" + rebuild,
                     path);
  if (have > psize)
    throw InputError("corrupted scene file: " + std::to_string(have - psize) +
                         " bytes after the payload" + rebuild,
                     path);
  const char* p = h + kSceneFileHeaderBytes;
  const Digest pd = payload_checksum(p, psize);
  if (std::memcmp(pd.data(), h + 24, 32) != 0)
    throw InputError("corrupted scene file: payload checksum " + hex(pd.data(), 8) +
                         "... does not match the header's " +
                         hex(reinterpret_cast<const std::uint8_t*>(h + 24), 8) + "..." + rebuild,
                     path);

  Reader r(path, p, psize);
  bool have_src = false, have_mesh = false, have_model = false, have_key = false;
  bool have_index = false;
  std::size_t blob_at = 0, blob_size = 0;  // the model blob in `bytes`
  while (r.at() < r.size()) {
    const auto t = r.get<std::uint32_t>("section tag");
    const std::size_t len = r.count(1, "section");
    Reader s(path, p + r.at(), len);  // a view: the payload is not copied
    r.skip(len);
    if (t == tag("SRCS")) {
      d.info.prototype = s.str("prototype path");
      const std::size_t start = s.at();
      d.info.sources = get_sources(s);
      const Digest sd = sha256(p + (r.at() - len) + start, s.at() - start);
      if (std::memcmp(sd.data(), h + 56, 32) != 0)
        throw InputError("corrupted scene file: the sources fingerprint does not match", path);
      have_src = true;
    } else if (t == tag("MKEY")) {
      d.mesh_key = s.str("mesh key");
      have_key = true;
    } else if (t == tag("MESH")) {
      d.mesh = get_mesh(s, mapping);
      have_mesh = true;
    } else if (t == tag("FIDX")) {
      if (!have_mesh)
        throw InputError("corrupted scene file: the face index comes before the mesh", path);
      std::const_pointer_cast<SceneMesh>(d.mesh)->face_index = get_face_index(s, *d.mesh);
      have_index = true;
    } else if (t == tag("MODL")) {
      d.info.model_kind = s.str("model kind");
      blob_size = s.count(1, "model data");
      blob_at = kSceneFileHeaderBytes + (r.at() - len) + s.at();
      s.skip(blob_size);
      d.info.model_blob = blob_size > 0;
      have_model = true;
    } else {
      continue;  // an unknown section is skipped (a later minor addition)
    }
    if (s.at() != s.size())
      throw InputError("corrupted scene file: section has trailing bytes", path);
  }
  if (!have_src || !have_key || !have_mesh || !have_index || !have_model)
    throw InputError(
        "corrupted scene file: a section (sources, mesh key, mesh, face index or model) is "
        "missing",
        path);
  // One copy out of the mapping (no zero fill, no copy of the rest of the file).
  d.model_blob.assign(bytes.data() + blob_at, blob_size);
  return d;
}

namespace {

// load_scene_file's checks of the sources (stale) and the model kind; the configuration.
SceneConfig checked_config(const std::string& path, const SceneFileData& d,
                           const std::function<SceneConfig(const std::string&)>& load_config) {
  SceneConfig cfg;
  try {
    cfg = load_config(d.info.prototype);
  } catch (const InputError&) {
    // Asked only when reading failed (a stat before every load was 4 % of loading prototype A).
    std::error_code ec;
    if (!fs::is_regular_file(d.info.prototype, ec))
      throw InputError("the prototype this scene file was built from is gone: " + d.info.prototype +
                           " (rebuild it with `palplab scene build`)",
                       path);
    throw;
  }
  const std::vector<SceneSource> now = scene_sources(cfg);

  auto same = [](const SceneSource& a, const SceneSource& b) {
    return a.role == b.role && a.path == b.path;
  };
  for (const auto& s : d.info.sources) {
    const SceneSource* cur = nullptr;
    for (const auto& n : now)
      if (same(n, s)) cur = &n;
    if (!cur)
      throw InputError("stale scene file: " + s.role + " " + s.path +
                           " is no longer a source of the prototype (rebuild it with `palplab "
                           "scene build`)",
                       path);
    if (cur->sha256 != s.sha256)
      throw InputError("stale scene file: " + s.role + " " + s.path +
                           " changed since the file was built (rebuild it with `palplab scene "
                           "build`)",
                       path);
  }
  for (const auto& n : now) {
    bool found = false;
    for (const auto& s : d.info.sources) found = found || same(n, s);
    if (!found)
      throw InputError("stale scene file: the prototype now uses " + n.role + " " + n.path +
                           " (rebuild it with `palplab scene build`)",
                       path);
  }
  if (d.info.model_kind != cfg.model)
    throw InputError("corrupted scene file: stored model \"" + d.info.model_kind +
                         "\" but the prototype's is \"" + cfg.model + "\"",
                     path);
  return cfg;
}

}  // namespace

SceneConfig load_scene_file(const std::string& path,
                            const std::function<SceneConfig(const std::string&)>& load_config) {
  SceneFileData d = read_scene_file(path);
  // The stored mesh goes into the cache before the prototype is read: reading it validates the
  // prototype's region names against its mesh, and a generated tet mesh (the shoulder) would
  // otherwise be regenerated (TetGen) just for its names -- the whole cost the file saves. It
  // comes out again unless every check below passes.
  auto mesh = std::const_pointer_cast<SceneMesh>(d.mesh);
  mesh->model_blob = std::move(d.model_blob);
  mesh->model_blob_kind = d.info.model_kind;
  const std::shared_ptr<const SceneMesh> before = cached_scene_mesh(d.mesh_key);
  install_scene_mesh_key(d.mesh_key, mesh);
  try {
    const SceneConfig cfg = checked_config(path, d, load_config);
    if (cfg.mesh.key() != d.mesh_key)
      throw InputError("stale scene file: built for mesh " + d.mesh_key +
                           ", the prototype now uses " + cfg.mesh.key() +
                           " (rebuild it with `palplab scene build`)",
                       path);
    return cfg;
  } catch (...) {
    install_scene_mesh_key(d.mesh_key, before);
    throw;
  }
}

}  // namespace palplab::engine
