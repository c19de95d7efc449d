#include "engine/render/headless.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <sstream>

#include "engine/render/gl.hpp"

namespace palplab::render {

struct HeadlessContext::Egl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
};

namespace {

std::string egl_error(const char* what) {
  std::ostringstream s;
  s << what << " failed (EGL error 0x" << std::hex << eglGetError() << ")";
  return s.str();
}

// Tries one display: initialise, choose a pbuffer-capable GL config, create a 3.3 core context.
bool try_display(EGLDisplay d, bool surfaceless, EGLContext& ctx, EGLSurface& surf,
                 std::string& why) {
  if (d == EGL_NO_DISPLAY) {
    why += "no display; ";
    return false;
  }
  EGLint major = 0, minor = 0;
  if (!eglInitialize(d, &major, &minor)) {
    why += egl_error("eglInitialize") + "; ";
    return false;
  }
  if (!eglBindAPI(EGL_OPENGL_API)) {
    why += egl_error("eglBindAPI(OpenGL)") + "; ";
    return false;
  }
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint n = 0;
  if (!eglChooseConfig(d, config_attribs, &config, 1, &n) || n < 1) {
    why += "no OpenGL-capable EGL config; ";
    return false;
  }
  const EGLint ctx_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                3,
                                EGL_CONTEXT_MINOR_VERSION,
                                3,
                                EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                EGL_NONE};
  ctx = eglCreateContext(d, config, EGL_NO_CONTEXT, ctx_attribs);
  if (ctx == EGL_NO_CONTEXT) {
    why += egl_error("eglCreateContext(OpenGL 3.3 core)") + "; ";
    return false;
  }
  surf = EGL_NO_SURFACE;
  if (!surfaceless) {
    const EGLint pb[] = {EGL_WIDTH, 16, EGL_HEIGHT, 16, EGL_NONE};
    surf = eglCreatePbufferSurface(d, config, pb);
    if (surf == EGL_NO_SURFACE) {
      why += egl_error("eglCreatePbufferSurface") + "; ";
      eglDestroyContext(d, ctx);
      return false;
    }
  }
  if (!eglMakeCurrent(d, surf, surf, ctx)) {
    why += egl_error("eglMakeCurrent") + "; ";
    if (surf != EGL_NO_SURFACE) eglDestroySurface(d, surf);
    eglDestroyContext(d, ctx);
    return false;
  }
  return true;
}

}  // namespace

HeadlessContext::HeadlessContext(int width, int height) : egl_(std::make_unique<Egl>()) {
  std::string why;
  bool ok = false;
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client && std::strstr(client, "EGL_MESA_platform_surfaceless")) {
    auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_display) {
      egl_->display = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
      ok = try_display(egl_->display, true, egl_->context, egl_->surface, why);
    }
  } else {
    why += "EGL_MESA_platform_surfaceless not offered; ";
  }
  if (!ok) {
    egl_->display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
    ok = try_display(egl_->display, false, egl_->context, egl_->surface, why);
  }
  if (!ok)
    throw NoDisplayError("no headless OpenGL 3.3 core context (EGL): " + why +
                         "install Mesa's EGL and DRI drivers (libegl-mesa0, libgl1-mesa-dri)");
  const auto* r = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  gl_renderer_ = r ? r : "?";
  width_ = width;
  height_ = height;
  make_targets();
}

HeadlessContext::~HeadlessContext() {
  if (egl_->context != EGL_NO_CONTEXT) {
    eglMakeCurrent(egl_->display, egl_->surface, egl_->surface, egl_->context);
    free_targets();
    eglMakeCurrent(egl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (egl_->surface != EGL_NO_SURFACE) eglDestroySurface(egl_->display, egl_->surface);
    eglDestroyContext(egl_->display, egl_->context);
  }
  // The display stays initialised: EGL displays are process-wide and other contexts may use it.
}

void HeadlessContext::make_targets() {
  glGenFramebuffers(1, &fbo_ms_);
  glGenRenderbuffers(1, &color_ms_);
  glGenRenderbuffers(1, &depth_ms_);
  glBindRenderbuffer(GL_RENDERBUFFER, color_ms_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, 4, GL_RGBA8, width_, height_);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_ms_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, 4, GL_DEPTH_COMPONENT24, width_, height_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_ms_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_ms_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_ms_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw NoDisplayError("headless framebuffer incomplete");
  glGenFramebuffers(1, &fbo_);
  glGenRenderbuffers(1, &color_);
  glBindRenderbuffer(GL_RENDERBUFFER, color_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width_, height_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_ms_);
}

void HeadlessContext::free_targets() {
  glDeleteFramebuffers(1, &fbo_ms_);
  glDeleteFramebuffers(1, &fbo_);
  glDeleteRenderbuffers(1, &color_ms_);
  glDeleteRenderbuffers(1, &depth_ms_);
  glDeleteRenderbuffers(1, &color_);
  fbo_ms_ = fbo_ = color_ms_ = depth_ms_ = color_ = 0;
}

void HeadlessContext::resize(int width, int height) {
  bind();
  if (width == width_ && height == height_) return;
  free_targets();
  width_ = width;
  height_ = height;
  make_targets();
}

void HeadlessContext::bind() {
  eglMakeCurrent(egl_->display, egl_->surface, egl_->surface, egl_->context);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_ms_);
  glViewport(0, 0, width_, height_);
}

Image HeadlessContext::read_pixels() {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_ms_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo_);
  glBlitFramebuffer(0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  Image img;
  img.width = width_;
  img.height = height_;
  img.rgba.resize(static_cast<size_t>(width_) * height_ * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  std::vector<std::uint8_t> flipped(img.rgba.size());
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, flipped.data());
  const size_t row = static_cast<size_t>(width_) * 4;
  for (int y = 0; y < height_; ++y)  // OpenGL's row 0 is the bottom one
    std::memcpy(img.rgba.data() + y * row, flipped.data() + (height_ - 1 - y) * row, row);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_ms_);
  return img;
}

bool headless_available(std::string* why) {
  try {
    HeadlessContext c(4, 4);
    return true;
  } catch (const NoDisplayError& e) {
    if (why) *why = e.what();
    return false;
  }
}

}  // namespace palplab::render
