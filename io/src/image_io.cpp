#include "stillmap/io/image_io.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "jpeg_decoder.h"
#include "png_decoder.h"
#include "stillmap/io/camera.h"
#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/output_files.h"

namespace stillmap {
namespace {

std::vector<unsigned char> ReadBytes(const std::string& path) {
  CheckInputFile(path, "image listed in the sequence");
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(path + ": image listed but missing or unreadable");
  const std::streamsize size = in.tellg();
  if (size <= 0) throw InputError(path + ": image file is empty");
  std::vector<unsigned char> bytes(static_cast<size_t>(size));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) {
    throw InputError(path + ": could not read the image file");
  }
  return bytes;
}

bool IsPng(const std::vector<unsigned char>& bytes) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  return bytes.size() >= 8 && std::memcmp(bytes.data(), kSignature, 8) == 0;
}

bool IsJpeg(const std::vector<unsigned char>& bytes) {
  return bytes.size() >= 3 && bytes[0] == 0xff && bytes[1] == 0xd8 && bytes[2] == 0xff;
}

// A complete PNG ends with the IEND chunk (length 0, type, CRC); a complete JPEG with FF D9
// (some writers pad after it, so the last few bytes are searched).
void CheckComplete(const std::string& path, const std::vector<unsigned char>& bytes) {
  if (IsPng(bytes)) {
    static const unsigned char kIend[8] = {0, 0, 0, 0, 'I', 'E', 'N', 'D'};
    if (bytes.size() < 20 || std::memcmp(bytes.data() + bytes.size() - 12, kIend, 8) != 0) {
      throw InputError(path + ": truncated PNG (no IEND chunk at the end); re-extract the file");
    }
  } else if (IsJpeg(bytes)) {
    const size_t first = bytes.size() > 64 ? bytes.size() - 64 : 0;
    for (size_t i = bytes.size() - 1; i > first; --i) {
      if (bytes[i - 1] == 0xff && bytes[i] == 0xd9) return;
    }
    throw InputError(path + ": truncated JPEG (no end-of-image marker); re-extract the file");
  } else {
    throw InputError(path + ": not a PNG or JPEG image");
  }
}

// A PNG's size from its header (IHDR: width and height, big-endian, at bytes 16 and 20), checked
// before decoding so that a damaged header cannot ask for gigabytes.
void CheckSize(const std::string& path, const std::vector<unsigned char>& bytes) {
  if (!IsPng(bytes) || bytes.size() < 24) return;
  auto big_endian = [&bytes](size_t at) {
    return (std::uint32_t{bytes[at]} << 24) | (std::uint32_t{bytes[at + 1]} << 16) |
           (std::uint32_t{bytes[at + 2]} << 8) | std::uint32_t{bytes[at + 3]};
  };
  const auto limit = static_cast<std::uint32_t>(Camera::kMaxImageSide);
  if (big_endian(16) > limit || big_endian(20) > limit) {
    throw InputError(path + ": the PNG header claims " + std::to_string(big_endian(16)) + "x" +
                     std::to_string(big_endian(20)) + " pixels, more than " +
                     std::to_string(limit) + " a side (a damaged header?)");
  }
}

// ".PNG" -> ".png": the extension that picks the format.
std::string LowerExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

}  // namespace

cv::Mat ReadImageAsStored(const std::string& path) {
  const std::vector<unsigned char> bytes = ReadBytes(path);
  CheckComplete(path, bytes);
  CheckSize(path, bytes);
  return IsJpeg(bytes) ? DecodeJpeg(path, bytes, Camera::kMaxImageSide) : DecodePng(path, bytes);
}

cv::Mat ReadColorImage(const std::string& path) {
  cv::Mat image = ReadImageAsStored(path);
  if (image.empty()) throw InputError(path + ": the image could not be decoded (corrupt file?)");
  if (image.depth() != CV_8U) {
    throw InputError(path + ": color image must have 8 bits per channel");
  }
  if (image.channels() == 1) {
    cv::cvtColor(image, image, cv::COLOR_GRAY2BGR);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
  }
  return image;
}

cv::Mat ReadDepthImage(const std::string& path, double depth_factor) {
  const std::vector<unsigned char> bytes = ReadBytes(path);
  CheckComplete(path, bytes);
  if (!IsPng(bytes)) {
    throw InputError(path + ": depth must be a 16-bit PNG (JPEG cannot hold depth)");
  }
  CheckSize(path, bytes);
  const cv::Mat raw = DecodePng(path, bytes);
  if (raw.empty()) throw InputError(path + ": the depth PNG could not be decoded (corrupt file?)");
  if (raw.channels() != 1 || raw.depth() != CV_16U) {
    throw InputError(path + ": depth must be a 1-channel 16-bit PNG, got " +
                     std::to_string(raw.channels()) + " channel(s) of " +
                     (raw.depth() == CV_8U ? "8" : "non-16") +
                     " bits (an 8-bit image cannot hold millimetre depth)");
  }
  cv::Mat depth_m;
  raw.convertTo(depth_m, CV_32F, 1.0 / depth_factor);
  return depth_m;
}

void WriteImage(const std::string& path, const cv::Mat& image, const std::string& extension) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(extension, image, bytes)) {
    throw std::runtime_error(path + ": could not encode the image");
  }
  std::ofstream out(path, std::ios::binary);
  if (!out.write(reinterpret_cast<const char*>(bytes.data()),
                 static_cast<std::streamsize>(bytes.size())) ||
      !out.flush()) {
    const std::string failure = WriteFailure(path, "the image");
    out.close();
    std::remove(path.c_str());
    throw std::runtime_error(failure);
  }
}

void CheckImageOutputPath(const std::string& path, bool png_only) {
  const std::filesystem::path target(path);
  const std::string extension = LowerExtension(path);
  std::error_code error;
  if (std::filesystem::is_directory(target, error)) {
    throw InputError(path + ": is a folder; give the image's file name (e.g. " +
                     (target / "plot.png").string() + ")");
  }
  const bool png = extension == ".png";
  if (!png && (png_only || (extension != ".jpg" && extension != ".jpeg"))) {
    throw InputError(path + ": an image file name must end in " +
                     (png_only ? ".png" : ".png or .jpg"));
  }
  const std::filesystem::path folder =
      target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(folder, error)) {
    throw InputError(path + ": the folder " + folder.string() +
                     " does not exist; create it first or name another");
  }
  if (std::filesystem::exists(target, error)) {
    std::vector<unsigned char> head(8, 0);
    std::ifstream in(path, std::ios::binary);
    in.read(reinterpret_cast<char*>(head.data()), 8);
    if (!std::filesystem::is_regular_file(target, error) || !(png ? IsPng(head) : IsJpeg(head))) {
      throw InputError(path + ": exists and is not a " + (png ? "PNG" : "JPEG") +
                       " image; stillmap does not overwrite it (name another file)");
    }
  }
}

void WriteImageAtomically(const std::string& path, const cv::Mat& image) {
  CheckImageOutputPath(path, false);
  const std::string extension = LowerExtension(path);
  const std::string temp = TemporaryPathFor(path);
  std::remove(temp.c_str());  // never write through what is left at that name
  WriteImage(temp, image, extension);
  CommitTemporary(temp, path);
}

}  // namespace stillmap
