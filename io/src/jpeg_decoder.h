// JPEG decoding through libjpeg directly, because OpenCV's decoder only prints libjpeg's warnings
// ("Corrupt JPEG data: ...") and returns the half-decoded image as if it were whole.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace stillmap {

// Decodes a JPEG file's bytes to CV_8UC3 (BGR; CMYK and YCCK converted) or CV_8UC1 (grayscale).
// Throws InputError naming `path` and what is wrong, in the user's words, when the data is
// corrupt (including damage libjpeg only warns about and fills in with gray), or when the image
// is larger than `max_side` pixels a side.
cv::Mat DecodeJpeg(const std::string& path, const std::vector<unsigned char>& bytes, int max_side);

}  // namespace stillmap
