#include "engine/render/mouse_script.hpp"

#include "common/json_check.hpp"

namespace palplab::render {

MouseScript MouseScript::load(const std::string& path) {
  std::string text;
  std::vector<Problem> repeated;  // parse() reports them with the script's other problems
  json::parse_json_file(path, &text, &repeated);
  return parse(text, path);
}

MouseScript MouseScript::parse(const std::string& text, const std::string& file) {
  std::vector<Problem> repeated;  // reported with the file's other problems
  const nlohmann::json root = json::parse_located(text, file, &repeated);
  json::Checker c(file, text);
  c.add(repeated);
  MouseScript s;
  if (c.expect_object(root, "$")) {
    c.keys(root, "$", {"palplab_mouse_script", "instructions_seconds", "events"});
    if (auto v = c.integer(root, "$", "palplab_mouse_script", true, 1, 1,
                           "the mouse-script format version"))
      (void)v;
    if (auto v = c.number(root, "$", "instructions_seconds", false, 0.0, 3600.0,
                          "the time the instructions stay (s)"))
      s.instructions_s_ = *v;
    const nlohmann::json* ev = c.member(root, "$", "events", true, "an array of events");
    if (ev && !ev->is_array()) {
      c.err("$.events", std::string("expected an array of events, got ") + json::kind_name(*ev));
    } else if (ev) {
      double last_t = 0.0;
      for (std::size_t i = 0; i < ev->size(); ++i) {
        const std::string P = "$.events[" + std::to_string(i) + "]";
        const nlohmann::json& e = (*ev)[i];
        if (!c.expect_object(e, P)) continue;
        c.keys(e, P, {"t", "x", "y", "left", "right", "middle", "wheel", "key", "close"});
        MouseScriptEvent me;
        if (auto t = c.number(e, P, "t", true, 0.0, 86400.0, "the event time (s)")) {
          if (*t < last_t)
            c.err(P + ".t", "expected times that do not decrease (the previous event is at " +
                                json::Checker::fmt(last_t) + " s), got " + json::Checker::fmt(*t));
          me.t = last_t = std::max(*t, last_t);
        }
        if (e.contains("x") != e.contains("y"))
          c.err(P, "expected both \"x\" and \"y\" or neither");
        auto x = c.number(e, P, "x", false, -1e5, 1e5, "the cursor x (px)");
        auto y = c.number(e, P, "y", false, -1e5, 1e5, "the cursor y (px)");
        if (x && y) {
          me.has_xy = true;
          me.x = *x;
          me.y = *y;
        }
        if (auto b = c.boolean(e, P, "left")) me.left = *b;
        if (auto b = c.boolean(e, P, "right")) me.right = *b;
        if (auto b = c.boolean(e, P, "middle")) me.middle = *b;
        if (auto w = c.number(e, P, "wheel", false, -1000.0, 1000.0, "the wheel notches"))
          me.wheel = *w;
        if (auto k = c.text(e, P, "key", false)) {
          // A letter key (GLFW's key codes of A-Z are their ASCII codes): W, T, N, R.
          if (k->size() == 1 && (*k)[0] >= 'A' && (*k)[0] <= 'Z')
            me.key = (*k)[0];
          else
            c.err(P + ".key", "expected one capital letter A-Z, got \"" + *k + "\"");
        }
        if (auto b = c.boolean(e, P, "close")) me.close = *b;
        s.events_.push_back(me);
      }
    }
  }
  c.throw_if_any();
  return s;
}

void MouseScript::restart() {
  next_ = 0;
  state_ = WindowInput{};
  closed_ = false;
}

WindowInput MouseScript::input_at(double t, bool& close) {
  state_.scroll = 0.0;
  state_.n_keys = 0;
  for (; next_ < events_.size() && events_[next_].t <= t; ++next_) {
    const MouseScriptEvent& e = events_[next_];
    if (e.has_xy) {
      state_.mouse_x = e.x;
      state_.mouse_y = e.y;
    }
    if (e.left >= 0) state_.left = e.left;
    if (e.right >= 0) state_.right = e.right;
    if (e.middle >= 0) state_.middle = e.middle;
    state_.scroll += e.wheel;
    if (e.key && state_.n_keys < 16) state_.keys_pressed[state_.n_keys++] = e.key;
    if (e.close) closed_ = true;
  }
  close = closed_;
  return state_;
}

}  // namespace palplab::render
