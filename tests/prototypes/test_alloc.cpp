// "No allocation in the step": every heap allocation of the process is counted (malloc, calloc,
// realloc and operator new all end in these glibc entry points), and steady-state lock-step
// steps must make none. Refinement/simplify events are allowed to allocate (once per contact).
#include <gtest/gtest.h>

#include <cstdlib>

#include "prototypes/factory.hpp"
#include "tests/prototypes/press_run.hpp"
#include "tests/prototypes/prototype_text.hpp"

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
using palplab::engine::testing::proto;

// Counts the allocations inside each Scene::step of the device it wraps (between the read
// that hands the position over and the write that gets the rendered force back).
class CountingDevice : public Device {
 public:
  CountingDevice(Device& inner, std::vector<long>& per_step) : inner_(inner), out_(per_step) {}
  DeviceInput read(double t) override {
    const DeviceInput in = inner_.read(t);
    g_allocations = 0;
    g_counting = true;
    return in;
  }
  void write(const Rendered& r) override {
    g_counting = false;
    out_.push_back(g_allocations);
    inner_.write(r);
  }
  bool finished() const override { return inner_.finished(); }

 private:
  Device& inner_;
  std::vector<long>& out_;
};

// Press `region` 8 mm deep and hold for 1000 steps from the last reset; the allocations of each
// step.
std::vector<long> press_allocations(Scene& s, const std::string& region) {
  std::vector<long> per_step;
  per_step.reserve(1000);
  PressDevice press(engine::testing::depth_press(s, region, 0.008, 1e3));
  CountingDevice counting(press, per_step);
  run_lockstep(s, counting, {.duration = 1000 * s.dt(), .frame_period = 0.0});
  return per_step;
}

// Allocations in steps [from, to).
long sum(const std::vector<long>& v, int from, int to) {
  long n = 0;
  for (int k = from; k < to && k < static_cast<int>(v.size()); ++k) n += v[k];
  return n;
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
    press_allocations(s, "ovary_left");  // warm-up: buffers reach their size
    s.reset();
    const auto n = press_allocations(s, "ovary_left");
    ASSERT_EQ(n.size(), 1000u);
    EXPECT_EQ(sum(n, 0, 1000), 0) << id;  // approach, press, hold
  }
  // C: after the press has refined (an allocating event), holding the press must not allocate.
  for (const char* region : {"ovary_left", "body"}) {
    Scene s = prototypes::build_scene(proto("C"));
    press_allocations(s, region);
    s.reset();
    const auto n = press_allocations(s, region);
    // The press refines (an event that allocates: proves the counter sees inside step()) ...
    EXPECT_GT(sum(n, 0, 600), 0) << region;
    // ... and holding it afterwards does not allocate.
    EXPECT_EQ(sum(n, 600, 1000), 0) << region;
    // The same without refinement, from the first contact on.
    engine::SceneConfig cfg = prototypes::load_prototype(proto("C"));
    cfg.refinement.enabled = false;
    Scene q = engine::make_scene(cfg);
    press_allocations(q, region);
    q.reset();
    EXPECT_EQ(sum(press_allocations(q, region), 0, 1000), 0) << region << " (no refinement)";
  }
}
