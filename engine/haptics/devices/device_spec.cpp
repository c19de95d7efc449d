#include "engine/haptics/devices/device_spec.hpp"

#include <algorithm>

#include "common/input_error.hpp"

namespace palplab::engine {

DeviceSpec parse_device_spec(const std::string& text) {
  DeviceSpec s;
  s.text = text;
  const std::string expected = "expected mouse, udp:PORT (1..65535) or trace:FILE";
  if (text == "mouse") {
    s.kind = "mouse";
  } else if (text.rfind("udp:", 0) == 0) {
    const std::string p = text.substr(4);
    const bool digits = !p.empty() && p.size() <= 5 && std::all_of(p.begin(), p.end(), [](char c) {
      return c >= '0' && c <= '9';
    });
    s.port = digits ? std::stoi(p) : 0;
    if (s.port < 1 || s.port > 65535) throw InputError("--device: \"" + text + "\": " + expected);
    s.kind = "udp";
  } else if (text.rfind("trace:", 0) == 0 && text.size() > 6) {
    s.kind = "trace";
    s.file = text.substr(6);
  } else {
    throw InputError("--device: \"" + text + "\": " + expected);
  }
  return s;
}

}  // namespace palplab::engine
