// Decoding of color and depth images with the checks real recordings need (truncated files,
// wrong bit depth, wrong size).
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace stillmap {

// Reads a PNG (8 or 16 bits, gray, BGR or BGRA) or JPEG (8-bit gray or BGR; CMYK converted) as
// stored. Throws InputError naming the file for a missing, unreadable, truncated, corrupt or
// implausibly large image; no library prints anything.
cv::Mat ReadImageAsStored(const std::string& path);

// Reads a PNG or JPEG color image as 8-bit BGR (gray images are expanded). Throws InputError for
// a missing, unreadable or truncated file (a PNG without its IEND chunk, a JPEG without its end
// marker: decoders would otherwise return a half-gray image without complaint).
cv::Mat ReadColorImage(const std::string& path);

// Reads a 16-bit depth PNG and converts it to metres (CV_32FC1, value / depth_factor, 0 = no
// reading). Throws InputError for a missing or truncated file and for an 8-bit or color image.
cv::Mat ReadDepthImage(const std::string& path, double depth_factor);

// Encodes an image in the format of `extension` (".png") and writes it to `path` as named (an
// output set's temporary name, say); throws std::runtime_error on failure, leaving no file.
void WriteImage(const std::string& path, const cv::Mat& image, const std::string& extension);

// Checks a new image file's name before anything is drawn: it ends in .png (or .jpg/.jpeg unless
// `png_only`), its folder exists, and it is not a folder or an existing file that is not an image
// of that format (a user's text file is never overwritten). Throws InputError naming `path`.
void CheckImageOutputPath(const std::string& path, bool png_only);

// Writes an image under a temporary name and renames it. Throws InputError when
// CheckImageOutputPath refuses `path`, std::runtime_error when it cannot be written.
void WriteImageAtomically(const std::string& path, const cv::Mat& image);

}  // namespace stillmap
