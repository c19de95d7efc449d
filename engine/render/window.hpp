#pragma once
// A GLFW window with an OpenGL 3.3 core context, for `palplab view` and human sessions. The
// Renderer draws into it exactly as into the headless framebuffer. Input is collected by GLFW
// callbacks into a plain struct the caller reads once per frame. Main thread only (GLFW).
#include <stdexcept>
#include <string>

#include "engine/render/image.hpp"

struct GLFWwindow;

namespace palplab::render {

struct NoWindowError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct WindowInput {
  double mouse_x = 0.0, mouse_y = 0.0;  // px, origin top-left
  bool left = false, right = false, middle = false;
  double scroll = 0.0;        // wheel notches since the last frame (+ = away from the user)
  int keys_pressed[16] = {};  // GLFW key codes pressed since the last frame
  int n_keys = 0;
};

class Window {
 public:
  // Opens a window (throws NoWindowError without a display or GL 3.3 core). vsync on.
  Window(int width, int height, const std::string& title, bool visible = true);
  ~Window();
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;

  bool should_close() const;
  void request_close();
  // Polls events; returns the input gathered since the previous call.
  WindowInput poll();
  void swap();
  int width() const;  // framebuffer size (px)
  int height() const;
  Image read_back_buffer();  // what was drawn this frame, before swap()
  GLFWwindow* handle() { return win_; }

 private:
  GLFWwindow* win_ = nullptr;
};

}  // namespace palplab::render
