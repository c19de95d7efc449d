#pragma once
// SHA-256 (FIPS 180-4), for the study hash stored with every result. Tested on the FIPS 180
// example vectors (tests/results).
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace palplab::results {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t n);
  void update(std::string_view s) { update(s.data(), s.size()); }
  std::array<std::uint8_t, 32> digest();  // finalises; the object must not be updated after

 private:
  void block(const std::uint8_t* p);
  std::uint32_t h_[8];
  std::uint8_t buf_[64];
  std::size_t buf_len_ = 0;
  std::uint64_t total_ = 0;  // bytes
};

// Lower-case hex digest of `data`.
std::string sha256_hex(std::string_view data);

}  // namespace palplab::results
