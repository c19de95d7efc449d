#include "engine/render/image.hpp"

#include <png.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "common/input_error.hpp"
#include "common/write_file.hpp"

namespace palplab::render {

namespace {
struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;
}  // namespace

namespace {
// libpng's errors are kept for our message instead of being printed ("libpng error: ..." on
// stderr, then the exception).
struct PngWriteState {
  std::string bytes;  // the encoded PNG
  std::string message;
};
[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* st = static_cast<PngWriteState*>(png_get_error_ptr(png));
  st->message = message ? message : "";
  png_longjmp(png, 1);
}
void on_png_warning(png_structp, png_const_charp) {}
void on_png_write(png_structp png, png_bytep data, png_size_t n) {
  static_cast<PngWriteState*>(png_get_io_ptr(png))->bytes.append(reinterpret_cast<char*>(data), n);
}
void on_png_flush(png_structp) {}
}  // namespace

void write_png(const std::string& path, const Image& img) {
  if (img.width <= 0 || img.height <= 0 ||
      img.rgba.size() != static_cast<size_t>(img.width) * img.height * 4)
    throw std::invalid_argument("write_png: image size does not match its pixels");
  // Encoded in memory, then written whole or not at all (common/write_file: a full disk or an
  // interruption leaves no cut-off PNG, a device given as the output is never removed). On the
  // heap: an automatic object changed between setjmp and longjmp would be indeterminate.
  const auto state = std::make_unique<PngWriteState>();
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, state.get(), on_png_error, on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("write_png: out of memory");
  }
  // libpng reports errors by longjmp; nothing with a destructor lives between here and the end.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("write_png: libpng: " + state->message);
  }
  png_set_write_fn(png, state.get(), on_png_write, on_png_flush);
  png_set_IHDR(png, info, img.width, img.height, 8, PNG_COLOR_TYPE_RGBA, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < img.height; ++y) png_write_row(png, const_cast<png_bytep>(img.pixel(0, y)));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  write_file(path, state->bytes, "the PNG");
}

Image read_png(const std::string& path) {
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f) throw InputError(path + ": cannot open: " + std::strerror(errno));
  unsigned char sig[8] = {};
  if (std::fread(sig, 1, 8, f.get()) != 8 || png_sig_cmp(sig, 0, 8) != 0)
    throw InputError(path + ": not a PNG file (bad signature)");
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw std::runtime_error("read_png: out of memory");
  }
  Image img;
  std::vector<png_bytep> rows;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw InputError(path + ": corrupt PNG");
  }
  png_init_io(png, f.get());
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  png_set_expand(png);
  png_set_strip_16(png);
  png_set_gray_to_rgb(png);
  png_set_add_alpha(png, 0xff, PNG_FILLER_AFTER);
  png_read_update_info(png, info);
  img.width = static_cast<int>(png_get_image_width(png, info));
  img.height = static_cast<int>(png_get_image_height(png, info));
  img.rgba.resize(static_cast<size_t>(img.width) * img.height * 4);
  rows.resize(img.height);
  for (int y = 0; y < img.height; ++y)
    rows[y] = img.rgba.data() + static_cast<size_t>(y) * img.width * 4;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return img;
}

}  // namespace palplab::render
