#pragma once
// Derived seeds (lab.js / PsychoPy style): every random component gets its own stream,
// seed = hash(parent_seed, label...), so adding a draw in one component never shifts the
// sequence of another. The hash is SplitMix64's finaliser chained over the parts; it is
// fixed forever because stored results name the study seed only.
#include <cstdint>
#include <string_view>

namespace palplab {

constexpr std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

constexpr std::uint64_t derive_seed(std::uint64_t parent, std::uint64_t part) {
  return splitmix64(parent ^ splitmix64(part));
}

// FNV-1a of a label, so components can be named ("participant-model", "exploration").
constexpr std::uint64_t label_hash(std::string_view s) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (char c : s) h = (h ^ static_cast<unsigned char>(c)) * 0x100000001b3ULL;
  return h;
}

constexpr std::uint64_t derive_seed(std::uint64_t parent, std::string_view label) {
  return derive_seed(parent, label_hash(label));
}

template <typename... Parts>
constexpr std::uint64_t derive_seed(std::uint64_t parent, std::uint64_t first, Parts... rest) {
  if constexpr (sizeof...(rest) == 0) {
    return derive_seed(parent, first);
  } else {
    return derive_seed(derive_seed(parent, first), rest...);
  }
}

}  // namespace palplab
