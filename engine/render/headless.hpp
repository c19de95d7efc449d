#pragma once
// Off-screen OpenGL 3.3 core rendering without a display: EGL on Mesa's surfaceless platform
// (llvmpipe on machines without a GPU), falling back to the default EGL display with a pbuffer.
// Draws into a 4x multisampled framebuffer object and reads back RGBA.
#include <memory>
#include <stdexcept>
#include <string>

#include "engine/render/image.hpp"

namespace palplab::render {

// No EGL device/driver could give an OpenGL 3.3 core context (message says what failed).
struct NoDisplayError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class HeadlessContext {
 public:
  // Creates the context and makes it current on the calling thread. Throws NoDisplayError.
  HeadlessContext(int width, int height);
  ~HeadlessContext();
  HeadlessContext(const HeadlessContext&) = delete;
  HeadlessContext& operator=(const HeadlessContext&) = delete;

  void resize(int width, int height);
  void bind();          // makes the context current and binds its framebuffer (draw target)
  Image read_pixels();  // resolves multisampling; top row first
  int width() const { return width_; }
  int height() const { return height_; }
  const std::string& renderer_name() const { return gl_renderer_; }

 private:
  struct Egl;
  std::unique_ptr<Egl> egl_;
  int width_ = 0, height_ = 0;
  unsigned fbo_ms_ = 0, color_ms_ = 0, depth_ms_ = 0, fbo_ = 0, color_ = 0;
  std::string gl_renderer_;
  void make_targets();
  void free_targets();
};

// Whether a headless context can be created here; `why` gets the reason when not.
bool headless_available(std::string* why = nullptr);

}  // namespace palplab::render
