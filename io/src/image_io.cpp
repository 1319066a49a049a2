#include "stillmap/io/image_io.h"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "stillmap/io/error.h"
#include "stillmap/io/output_files.h"

namespace stillmap {
namespace {

std::vector<unsigned char> ReadBytes(const std::string& path) {
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

}  // namespace

cv::Mat ReadColorImage(const std::string& path) {
  const std::vector<unsigned char> bytes = ReadBytes(path);
  CheckComplete(path, bytes);
  cv::Mat image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
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
  const cv::Mat raw = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
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
    out.close();
    std::remove(path.c_str());
    throw std::runtime_error(path + ": could not write the image (is the folder writable?)");
  }
}

void WriteImageAtomically(const std::string& path, const cv::Mat& image) {
  const std::string temp = TemporaryPathFor(path);
  WriteImage(temp, image, path.substr(path.find_last_of('.')));
  CommitTemporary(temp, path);
}

}  // namespace stillmap
