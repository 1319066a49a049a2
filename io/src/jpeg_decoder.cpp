#include "jpeg_decoder.h"

// jpeglib.h needs size_t and FILE declared first.
#include <jpeglib.h>

#include <csetjmp>
#include <cstddef>
#include <cstdio>

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

// The libjpeg calls, with no object whose destructor a longjmp could skip: `image` lives in the
// caller. Returns the outcome and leaves libjpeg's message in `error`.
Outcome Decode(const std::vector<unsigned char>& bytes, int max_side, ErrorManager* error,
               cv::Mat* image, long* warnings) {
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
  info.out_color_space = gray ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_start_decompress(&info);
  image->create(static_cast<int>(info.output_height), static_cast<int>(info.output_width),
                gray ? CV_8UC1 : CV_8UC3);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = image->ptr<unsigned char>(static_cast<int>(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  *warnings = info.err->num_warnings;
  jpeg_destroy_decompress(&info);
  return Outcome::kDecoded;
}

}  // namespace

cv::Mat DecodeJpeg(const std::string& path, const std::vector<unsigned char>& bytes, int max_side) {
  ErrorManager error{};
  cv::Mat image;
  long warnings = 0;
  const Outcome outcome = Decode(bytes, max_side, &error, &image, &warnings);
  if (outcome == Outcome::kTooLarge) {
    throw InputError(path + ": the JPEG is larger than " + std::to_string(max_side) +
                     " pixels a side");
  }
  if (outcome == Outcome::kError || warnings > 0) {
    throw InputError(path + ": corrupt JPEG (libjpeg: " + error.message +
                     "); re-extract or re-encode the file");
  }
  return image;
}

}  // namespace stillmap
