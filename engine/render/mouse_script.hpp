#pragma once
// A scripted mouse for the window of `palplab view` and `palplab run --human --device mouse`
// (`--mouse-script FILE`): what a test under Xvfb, or a demonstration, feeds the window in place
// of a person's hand. The script replaces the window's mouse input frame by frame; everything
// after it (picking, the press depth, the mouse device, the haptic loop) is the code path a
// person drives. Format (docs/DEVICES.md):
//
//   {"palplab_mouse_script": 1,
//    "instructions_seconds": 0.5,          // run --human: the instructions stay this long (s)
//    "events": [{"t": 0.0, "x": 320, "y": 240, "left": true},
//               {"t": 0.2, "wheel": 3},
//               {"t": 1.5, "close": true}]}
//
// `t` (s, not decreasing) counts from the start of each session (run --human: the script is
// replayed from its start in every session) or from the window's first frame (view). A state
// (cursor x/y in px, origin top-left; left/right/middle buttons) holds until changed; `wheel`
// notches (+ = press in) and `key` (one capital letter: "N" switches a needle scene's tool, "T"
// transparency, "W" wireframe) are delivered once, in the first frame at or after t; `close` closes
// the window as the window manager's close button would.
#include <string>
#include <vector>

#include "engine/render/window.hpp"

namespace palplab::render {

struct MouseScriptEvent {
  double t = 0.0;  // s
  bool has_xy = false;
  double x = 0.0, y = 0.0;                 // px
  int left = -1, right = -1, middle = -1;  // -1 unchanged, 0 up, 1 down
  double wheel = 0.0;                      // notches
  int key = 0;                             // a letter key pressed once (GLFW code), 0 = none
  bool close = false;
};

class MouseScript {
 public:
  // Throws palplab::InputError (FILE:LINE:COL: $.events[i].key: ...) on a bad file.
  static MouseScript load(const std::string& path);
  static MouseScript parse(const std::string& text, const std::string& file);

  // Back to t = 0 (a new session).
  void restart();
  // The input of the frame at time t (s since restart; t does not decrease between calls).
  // `close` is set once the script's close event is reached.
  WindowInput input_at(double t, bool& close);
  double instructions_seconds() const { return instructions_s_; }
  const std::vector<MouseScriptEvent>& events() const { return events_; }

 private:
  std::vector<MouseScriptEvent> events_;
  double instructions_s_ = 0.5;
  std::size_t next_ = 0;
  WindowInput state_;
  bool closed_ = false;
};

}  // namespace palplab::render
