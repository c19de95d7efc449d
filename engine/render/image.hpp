#pragma once
// An 8-bit RGBA image (row 0 = top row, as in PNG) and its PNG encoding (libpng).
#include <cstdint>
#include <string>
#include <vector>

namespace palplab::render {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  // width * height * 4 bytes, top row first

  const std::uint8_t* pixel(int x, int y) const {
    return rgba.data() + (static_cast<size_t>(y) * width + x) * 4;
  }
};

// Writes `img` as an 8-bit RGBA PNG. Throws palplab::InputError when the file cannot be written
// (the path is user input).
void write_png(const std::string& path, const Image& img);
// Reads an 8-bit RGB/RGBA (or grey) PNG into RGBA. Throws palplab::InputError on a bad file.
Image read_png(const std::string& path);

}  // namespace palplab::render
