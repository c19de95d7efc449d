// Renderer cost on this machine's OpenGL (llvmpipe here): per prototype, the median of
//  - stream: Renderer::update_surface (positions + normals to the GPU) of the current surface,
//  - frame: update_surface + draw + read-back of an 800x600 image (read-back forces the GPU to
//    finish, so this is the full frame time),
//  - still: render_still end to end (EGL context, renderer, draw, read-back).
// `palplab view` needs frame well under 16.7 ms for 60 Hz; a report needs still << 1 s.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/render/headless.hpp"
#include "engine/render/renderer.hpp"
#include "engine/render/still.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using Clock = std::chrono::steady_clock;

namespace {
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

// Usage: bench_render [PROTOTYPES_DIR] (default: ./prototypes, i.e. run from the source tree).
int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : "prototypes";
  std::string why;
  if (!render::headless_available(&why)) {
    std::printf("no EGL device: %s\n", why.c_str());
    return 0;
  }
  std::printf("%-4s %8s %8s %12s %10s %10s\n", "", "verts", "faces", "stream ms", "frame ms",
              "still ms");
  for (const char* id : {"A", "B", "C1"}) {
    const engine::Scene scene = prototypes::build_scene(dir + "/" + id + ".json");
    render::RowMatX3d V;
    render::RowMatX3i F;
    scene.current_surface(V, F);
    const long coarse = scene.stats().coarse_nodes;
    std::vector<double> stream, frame, still;
    {
      render::HeadlessContext ctx(800, 600);
      render::Renderer r(scene.geometry());
      render::Camera cam;
      for (int i = 0; i < 40; ++i) {
        V(0, 0) += 1e-9;  // a change, as every frame has
        auto t0 = Clock::now();
        r.update_surface(V, F, coarse);
        stream.push_back(ms_since(t0));
        t0 = Clock::now();
        r.update_surface(V, F, coarse);
        ctx.bind();
        r.draw(cam, 800, 600, {});
        ctx.read_pixels();
        frame.push_back(ms_since(t0));
      }
    }
    for (int i = 0; i < 5; ++i) {
      const auto t0 = Clock::now();
      render::render_still(scene, render::Camera{}, 800, 600);
      still.push_back(ms_since(t0));
    }
    std::printf("%-4s %8ld %8ld %12.3f %10.2f %10.1f\n", id, static_cast<long>(V.rows()),
                static_cast<long>(F.rows()), engine::median(stream), engine::median(frame),
                engine::median(still));
  }
  return 0;
}
