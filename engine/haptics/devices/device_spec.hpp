#pragma once
// The --device option of the commands that take a person's device: "mouse", "udp:PORT" or
// "trace:FILE".
#include <string>

namespace palplab::engine {

struct DeviceSpec {
  std::string kind;  // "mouse" | "udp" | "trace"
  int port = 0;      // udp
  std::string file;  // trace
  std::string text;  // as given, for messages ("udp:5005")
};

// Throws palplab::InputError ("--device: ...: expected mouse, udp:PORT or trace:FILE").
DeviceSpec parse_device_spec(const std::string& text);

}  // namespace palplab::engine
