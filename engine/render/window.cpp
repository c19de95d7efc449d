#include "engine/render/window.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstring>
#include <vector>

#include "engine/render/gl.hpp"

namespace palplab::render {

namespace {
struct Pending {
  double scroll = 0.0;
  int keys[16] = {};
  int n_keys = 0;
};
std::string g_last_error;
void on_error(int, const char* what) {
  g_last_error = what ? what : "?";
}
}  // namespace

Window::Window(int width, int height, const std::string& title, bool visible) {
  glfwSetErrorCallback(on_error);
  if (!glfwInit())
    throw NoWindowError("cannot open a window (GLFW: " + g_last_error +
                        "); is DISPLAY set? For tests use xvfb-run");
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SAMPLES, 4);
  glfwWindowHint(GLFW_VISIBLE, visible ? GLFW_TRUE : GLFW_FALSE);
  win_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (!win_) {
    glfwTerminate();
    throw NoWindowError("cannot create an OpenGL 3.3 core window (GLFW: " + g_last_error + ")");
  }
  glfwMakeContextCurrent(win_);
  glfwSwapInterval(1);
  auto* pending = new Pending;
  glfwSetWindowUserPointer(win_, pending);
  glfwSetScrollCallback(win_, [](GLFWwindow* w, double, double dy) {
    static_cast<Pending*>(glfwGetWindowUserPointer(w))->scroll += dy;
  });
  glfwSetKeyCallback(win_, [](GLFWwindow* w, int key, int, int action, int) {
    auto* p = static_cast<Pending*>(glfwGetWindowUserPointer(w));
    if (action == GLFW_PRESS && p->n_keys < 16) p->keys[p->n_keys++] = key;
  });
}

Window::~Window() {
  delete static_cast<Pending*>(glfwGetWindowUserPointer(win_));
  glfwDestroyWindow(win_);
  glfwTerminate();
}

bool Window::should_close() const {
  return glfwWindowShouldClose(win_);
}
void Window::request_close() {
  glfwSetWindowShouldClose(win_, GLFW_TRUE);
}

WindowInput Window::poll() {
  glfwPollEvents();
  WindowInput in;
  glfwGetCursorPos(win_, &in.mouse_x, &in.mouse_y);
  // Cursor positions are in screen coordinates; scale to framebuffer pixels (HiDPI).
  int ww = 1, wh = 1, fw = 1, fh = 1;
  glfwGetWindowSize(win_, &ww, &wh);
  glfwGetFramebufferSize(win_, &fw, &fh);
  if (ww > 0 && wh > 0) {
    in.mouse_x *= static_cast<double>(fw) / ww;
    in.mouse_y *= static_cast<double>(fh) / wh;
  }
  in.left = glfwGetMouseButton(win_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  in.right = glfwGetMouseButton(win_, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  in.middle = glfwGetMouseButton(win_, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  auto* p = static_cast<Pending*>(glfwGetWindowUserPointer(win_));
  in.scroll = p->scroll;
  std::memcpy(in.keys_pressed, p->keys, sizeof p->keys);
  in.n_keys = p->n_keys;
  *p = Pending{};
  return in;
}

void Window::swap() {
  glfwSwapBuffers(win_);
}

int Window::width() const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(win_, &w, &h);
  return w;
}
int Window::height() const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(win_, &w, &h);
  return h;
}

Image Window::read_back_buffer() {
  Image img;
  img.width = width();
  img.height = height();
  std::vector<std::uint8_t> raw(static_cast<size_t>(img.width) * img.height * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, img.width, img.height, GL_RGBA, GL_UNSIGNED_BYTE, raw.data());
  img.rgba.resize(raw.size());
  const size_t row = static_cast<size_t>(img.width) * 4;
  for (int y = 0; y < img.height; ++y)
    std::memcpy(img.rgba.data() + y * row, raw.data() + (img.height - 1 - y) * row, row);
  for (size_t i = 3; i < img.rgba.size(); i += 4) img.rgba[i] = 255;  // opaque PNG
  return img;
}

}  // namespace palplab::render
