#include "jpeg_decoder.h"

// jpeglib.h needs size_t and FILE declared first.
#include <jpeglib.h>

#include <csetjmp>
#include <cstddef>
#include <cstdio>
#include <cstring>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

// libjpeg reports through callbacks: errors jump back to the decoder with the message kept,
// warnings are counted by libjpeg itself (num_warnings) and the first one's message is kept.
struct ErrorManager {
  jpeg_error_mgr manager;  // first member: libjpeg's pointer to it is a pointer to this
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

[[noreturn]] void OnError(j_common_ptr info) {
  auto* error = reinterpret_cast<ErrorManager*>(info->err);
  (*info->err->format_message)(info, error->message);
  std::longjmp(error->jump, 1);
}

void OnMessage(j_common_ptr info) {
  auto* error = reinterpret_cast<ErrorManager*>(info->err);
  if (error->message[0] == '\0') (*info->err->format_message)(info, error->message);
}

enum class Outcome { kDecoded, kError, kTooLarge };

bool Says(const char* message, const char* part) { return std::strstr(message, part) != nullptr; }

// libjpeg's message in the user's words: what is wrong with the file.
std::string JpegProblem(const char* message) {
  if (Says(message, "Premature end")) return "the file ends early: cut short?";
  if (Says(message, "Not a JPEG")) return "not a JPEG file: it does not start with a JPEG marker";
  if (Says(message, "Unsupported JPEG process") ||
      Says(message, "Unsupported JPEG data precision")) {
    return "a JPEG kind that is not read (lossless, arithmetic-coded or 12-bit)";
  }
  if (Says(message, "Empty JPEG") || Says(message, "dimension") || Says(message, "too large")) {
    return "its header claims an impossible size";
  }
  return "its compressed data is damaged";
}

// The libjpeg calls, with no object whose destructor a longjmp could skip: `image` lives in the
// caller. Returns the outcome and leaves libjpeg's message in `error`.
Outcome Decode(const std::vector<unsigned char>& bytes, int max_side, ErrorManager* error,
               cv::Mat* image, long* warnings, bool* inverted_cmyk) {
  jpeg_decompress_struct info{};
  info.err = jpeg_std_error(&error->manager);
  error->manager.error_exit = OnError;
  error->manager.output_message = OnMessage;
  error->message[0] = '\0';
  if (setjmp(error->jump) != 0) {
    jpeg_destroy_decompress(&info);
    return Outcome::kError;
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, bytes.data(), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&info, TRUE);
  if (info.image_width > static_cast<JDIMENSION>(max_side) ||
      info.image_height > static_cast<JDIMENSION>(max_side)) {
    jpeg_destroy_decompress(&info);
    return Outcome::kTooLarge;
  }
  const bool gray = info.num_components == 1;
  const bool cmyk = info.jpeg_color_space == JCS_CMYK || info.jpeg_color_space == JCS_YCCK;
  info.out_color_space = gray ? JCS_GRAYSCALE : cmyk ? JCS_CMYK : JCS_EXT_BGR;
  jpeg_start_decompress(&info);
  image->create(static_cast<int>(info.output_height), static_cast<int>(info.output_width),
                gray   ? CV_8UC1
                : cmyk ? CV_8UC4
                       : CV_8UC3);
  *inverted_cmyk = cmyk && info.saw_Adobe_marker;
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = image->ptr<unsigned char>(static_cast<int>(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  *warnings = info.err->num_warnings;
  jpeg_destroy_decompress(&info);
  return Outcome::kDecoded;
}

// CMYK (4 channels) to BGR, ink removed from white: R = (1 - C)(1 - K). Adobe's writers (the
// usual source of CMYK JPEGs, marked by their APP14 segment) store the channels inverted.
cv::Mat CmykToBgr(const cv::Mat& cmyk, bool inverted) {
  cv::Mat bgr(cmyk.size(), CV_8UC3);
  for (int r = 0; r < cmyk.rows; ++r) {
    const unsigned char* in = cmyk.ptr<unsigned char>(r);
    unsigned char* out = bgr.ptr<unsigned char>(r);
    for (int c = 0; c < cmyk.cols; ++c, in += 4, out += 3) {
      const int k = inverted ? in[3] : 255 - in[3];
      for (int channel = 0; channel < 3; ++channel) {
        const int ink_free = inverted ? in[channel] : 255 - in[channel];  // 1 - C, 1 - M, 1 - Y
        out[2 - channel] = static_cast<unsigned char>((ink_free * k + 127) / 255);
      }
    }
  }
  return bgr;
}

}  // namespace

cv::Mat DecodeJpeg(const std::string& path, const std::vector<unsigned char>& bytes, int max_side) {
  ErrorManager error{};
  cv::Mat image;
  long warnings = 0;
  bool inverted_cmyk = false;
  const Outcome outcome = Decode(bytes, max_side, &error, &image, &warnings, &inverted_cmyk);
  if (outcome == Outcome::kTooLarge) {
    throw InputError(path + ": the JPEG is larger than " + std::to_string(max_side) +
                     " pixels a side");
  }
  if (outcome == Outcome::kError || warnings > 0) {
    throw InputError(path + ": corrupt JPEG (" + JpegProblem(error.message) +
                     "); re-extract or re-encode the file");
  }
  return image.channels() == 4 ? CmykToBgr(image, inverted_cmyk) : image;
}

}  // namespace stillmap
