#include "bag/decompress.h"

#include <bzlib.h>
#include <lz4frame.h>
#include <zstd.h>

#include <cstring>

namespace stillmap {
namespace {

bool Bz2(const std::uint8_t* data, size_t size, std::vector<std::uint8_t>* out,
         std::string* error) {
  auto length = static_cast<unsigned int>(out->size());
  // The libbz2 interface takes non-const pointers; it does not write the source.
  const int status =
      BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out->data()), &length,
                                 const_cast<char*>(reinterpret_cast<const char*>(data)),
                                 static_cast<unsigned int>(size), 0, 0);
  if (status != BZ_OK) {
    *error = "bz2 data damaged (libbz2 status " + std::to_string(status) + ")";
    return false;
  }
  if (length != out->size()) {
    *error = "bz2 data gave " + std::to_string(length) + " bytes, the header says " +
             std::to_string(out->size());
    return false;
  }
  return true;
}

bool Lz4Frame(const std::uint8_t* data, size_t size, std::vector<std::uint8_t>* out,
              std::string* error) {
  LZ4F_dctx* context = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&context, LZ4F_VERSION))) {
    *error = "lz4: no decompression context";
    return false;
  }
  size_t written = 0, read = 0;
  bool ok = true;
  while (read < size) {
    size_t out_left = out->size() - written, in_left = size - read;
    const size_t hint =
        LZ4F_decompress(context, out->data() + written, &out_left, data + read, &in_left, nullptr);
    if (LZ4F_isError(hint)) {
      *error = std::string("lz4 data damaged (") + LZ4F_getErrorName(hint) + ")";
      ok = false;
      break;
    }
    written += out_left;
    read += in_left;
    if (hint == 0) break;  // the frame ended
    if (out_left == 0 && in_left == 0) {
      *error = "lz4 data longer than the header says";
      ok = false;
      break;
    }
  }
  LZ4F_freeDecompressionContext(context);
  if (ok && written != out->size()) {
    *error = "lz4 data gave " + std::to_string(written) + " bytes, the header says " +
             std::to_string(out->size());
    ok = false;
  }
  return ok;
}

bool Zstd(const std::uint8_t* data, size_t size, std::vector<std::uint8_t>* out,
          std::string* error) {
  const size_t written = ZSTD_decompress(out->data(), out->size(), data, size);
  if (ZSTD_isError(written) != 0U) {
    *error = std::string("zstd data damaged (") + ZSTD_getErrorName(written) + ")";
    return false;
  }
  if (written != out->size()) {
    *error = "zstd data gave " + std::to_string(written) + " bytes, the header says " +
             std::to_string(out->size());
    return false;
  }
  return true;
}

}  // namespace

bool DecompressBlock(const std::string& compression, const std::uint8_t* data, size_t size,
                     size_t uncompressed_size, std::vector<std::uint8_t>* out, std::string* error) {
  out->assign(uncompressed_size, 0);
  if (compression == "none" || compression.empty()) {
    if (size != uncompressed_size) {
      *error = "an uncompressed block of " + std::to_string(size) + " bytes, the header says " +
               std::to_string(uncompressed_size);
      return false;
    }
    if (size > 0) std::memcpy(out->data(), data, size);
    return true;
  }
  if (compression == "bz2") return Bz2(data, size, out, error);
  if (compression == "lz4") return Lz4Frame(data, size, out, error);
  if (compression == "zstd") return Zstd(data, size, out, error);
  *error = "unknown compression \"" + compression + "\"";
  return false;
}

}  // namespace stillmap
