#include "png_decoder.h"

#include <png.h>

#include <cstring>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

// libpng reports through callbacks: errors jump back to the decoder (png_jmpbuf) with the
// message kept; warnings (an ancillary chunk's bad CRC, a known-incorrect sRGB profile) do not
// change the pixels and are dropped.
struct Reader {
  const std::vector<unsigned char>& bytes;
  size_t at = 0;
  char message[256] = {};
};

void OnError(png_structp png, png_const_charp message) {
  auto* reader = static_cast<Reader*>(png_get_error_ptr(png));
  std::strncpy(reader->message, message, sizeof(reader->message) - 1);
  png_longjmp(png, 1);
}

void OnWarning(png_structp /*png*/, png_const_charp /*message*/) {}

void ReadBytes(png_structp png, png_bytep out, png_size_t length) {
  auto* reader = static_cast<Reader*>(png_get_io_ptr(png));
  if (reader->bytes.size() - reader->at < length) png_error(png, "the file ends early");
  std::memcpy(out, reader->bytes.data() + reader->at, length);
  reader->at += length;
}

bool Says(const char* message, const char* part) { return std::strstr(message, part) != nullptr; }

// libpng's message in the user's words: what is wrong with the file.
std::string PngProblem(const char* message) {
  if (Says(message, "Not a PNG") || Says(message, "ASCII conversion")) {
    return "not a PNG file: its signature is wrong";
  }
  if (Says(message, "CRC")) return "a checksum does not match: the file is damaged";
  if (Says(message, "ends early") || Says(message, "Read Error") ||
      Says(message, "Not enough image data")) {
    return "the file ends early: cut short?";
  }
  if (Says(message, "IHDR") || Says(message, "width") || Says(message, "height") ||
      Says(message, "exceeds")) {
    return "its header is damaged or claims an impossible size";
  }
  return "its pixel data is damaged";
}

// The transforms to 8/16-bit gray, BGR or BGRA in host byte order.
void SetTransforms(png_structp png, png_infop info) {
  const int color_type = png_get_color_type(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS) != 0) png_set_tRNS_to_alpha(png);
  if (color_type == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_strip_alpha(png);
  if (bit_depth == 16) png_set_swap(png);  // PNG is big-endian; cv::Mat holds host order
  png_set_bgr(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
}

// The libpng calls, with no object whose destructor a longjmp could skip: `image` lives in the
// caller. Returns false with the message in `reader`.
bool Decode(Reader* reader, cv::Mat* image) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, reader, OnError, OnWarning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  std::vector<png_bytep> rows;
  if (info == nullptr || setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, reader, ReadBytes);
  png_read_info(png, info);
  SetTransforms(png, info);
  const int depth = png_get_bit_depth(png, info) == 16 ? CV_16U : CV_8U;
  image->create(static_cast<int>(png_get_image_height(png, info)),
                static_cast<int>(png_get_image_width(png, info)),
                CV_MAKETYPE(depth, png_get_channels(png, info)));
  rows.resize(static_cast<size_t>(image->rows));
  for (int r = 0; r < image->rows; ++r) rows[static_cast<size_t>(r)] = image->ptr(r);
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

cv::Mat DecodePng(const std::string& path, const std::vector<unsigned char>& bytes) {
  Reader reader{bytes};
  cv::Mat image;
  if (!Decode(&reader, &image)) {
    throw InputError(path + ": corrupt PNG (" + PngProblem(reader.message) +
                     "); re-extract or re-encode the file");
  }
  return image;
}

}  // namespace stillmap
