// "No allocation in the step": every heap allocation of the process is counted (malloc, calloc,
// realloc and operator new all end in these glibc entry points), and steady-state lock-step
// steps must make none. Refinement/simplify events are allowed to allocate (once per contact).
#include <gtest/gtest.h>

#include <cstdlib>

#include "prototypes/factory.hpp"

// Sanitizers bring their own allocator: no counting there (the test skips).
#if defined(__has_feature)
#if __has_feature(thread_sanitizer) || __has_feature(address_sanitizer)
#define PALPLAB_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__) || defined(PALPLAB_SANITIZED)
#define PALPLAB_COUNT_ALLOCATIONS 0
#else
#define PALPLAB_COUNT_ALLOCATIONS 1
#endif

namespace {
bool g_counting = false;
long g_allocations = 0;
}  // namespace

#if PALPLAB_COUNT_ALLOCATIONS
extern "C" void* __libc_malloc(size_t);
extern "C" void* __libc_calloc(size_t, size_t);
extern "C" void* __libc_realloc(void*, size_t);

extern "C" void* malloc(size_t n) {
  if (g_counting) ++g_allocations;
  return __libc_malloc(n);
}
extern "C" void* calloc(size_t a, size_t b) {
  if (g_counting) ++g_allocations;
  return __libc_calloc(a, b);
}
extern "C" void* realloc(void* p, size_t n) {
  if (g_counting) ++g_allocations;
  return __libc_realloc(p, n);
}
#endif

using namespace palplab;
using namespace palplab::engine;

namespace {
std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}

// Press `region` 8 mm deep and hold; counts allocations in steps [count_from, count_to).
// Steps are numbered from the last reset (continuing calls resume where the last one stopped).
long press_allocations(Scene& s, const std::string& region, int count_from, int count_to) {
  const auto& g = s.geometry();
  const int node = g.region_node(region);
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  long counted = 0;
  for (int k = static_cast<int>(std::lround(s.time() / s.dt())); k < count_to; ++k) {
    const double depth = std::min(-0.002 + 0.02 * k * s.dt(), 0.008);
    g_allocations = 0;
    g_counting = k >= count_from;
    s.step(p - depth * n);
    g_counting = false;
    counted += g_allocations;
  }
  return counted;
}
}  // namespace

TEST(Allocation, CounterSeesAllocations) {
  if (!PALPLAB_COUNT_ALLOCATIONS) GTEST_SKIP() << "sanitizer build";
  g_allocations = 0;
  g_counting = true;
  std::vector<double>* v = new std::vector<double>(100);
  Eigen::VectorXd e(100);
  g_counting = false;
  EXPECT_GE(g_allocations, 3);
  delete v;
}

TEST(Allocation, SteadyStateStepsDoNotAllocate) {
  if (!PALPLAB_COUNT_ALLOCATIONS) GTEST_SKIP() << "sanitizer build";
  for (const char* id : {"A", "B"}) {
    Scene s = prototypes::build_scene(proto(id));
    press_allocations(s, "ovary_left", 0, 1000);  // warm-up: buffers reach their size
    s.reset();
    EXPECT_EQ(press_allocations(s, "ovary_left", 0, 1000), 0) << id;  // approach, press, hold
  }
  // C: after the press has refined (an allocating event), holding the press must not allocate.
  for (const char* region : {"ovary_left", "body"}) {
    Scene s = prototypes::build_scene(proto("C"));
    press_allocations(s, region, 0, 1000);
    s.reset();
    // The press refines (an event that allocates: proves the counter sees inside step()) ...
    EXPECT_GT(press_allocations(s, region, 0, 600), 0) << region;
    // ... and holding it afterwards does not allocate.
    EXPECT_EQ(press_allocations(s, region, 600, 1000), 0) << region;
    // The same without refinement, from the first contact on.
    engine::SceneConfig cfg = prototypes::load_prototype(proto("C"));
    cfg.refinement.enabled = false;
    Scene q = engine::make_scene(cfg);
    press_allocations(q, region, 0, 1000);
    q.reset();
    EXPECT_EQ(press_allocations(q, region, 0, 1000), 0) << region << " (no refinement)";
  }
}
