// PNG decoding through libpng directly, because OpenCV's decoder lets libpng print its own
// messages ("libpng error: IDAT: CRC error") to the terminal before the caller can say anything.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace stillmap {

// Decodes a PNG file's bytes as stored: 8 or 16 bits per channel, 1 (gray), 3 (BGR) or 4 (BGRA)
// channels; palettes and gray below 8 bits are expanded to 8. Throws InputError naming `path` and
// what is wrong, in the user's words, when the data is corrupt (a bad CRC, a damaged stream, a
// cut-short file).
// Callers check the header's size first: the decoder allocates what it claims.
cv::Mat DecodePng(const std::string& path, const std::vector<unsigned char>& bytes);

}  // namespace stillmap
