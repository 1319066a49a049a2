#include "bag/decompress.h"

#include <bzlib.h>
#include <lz4frame.h>
#include <xxhash.h>
#include <zstd.h>

#include <cstdint>
#include <cstring>

#include "bag/bytes.h"

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

// LZ4's end-of-block rules (the last match starts 12 bytes or more before the block's end), which
// liblz4's decoder enforces, are broken by some writers: @mcap/core's JavaScript lz4 wrote chunks
// with a match 10 bytes before a block's end, intact by their CRC, which liblz4 refuses. This
// decoder of the block format (https://github.com/lz4/lz4/blob/dev/doc/lz4_Block_format.md)
// checks only what keeps it inside its buffers; it runs after liblz4 refused, and the caller
// still checks the size (and MCAP the CRC). Linked blocks read back into the frame's earlier
// output, which this decoder keeps whole.
bool Lz4Sequences(const std::uint8_t* in, size_t size, size_t history_start,
                  std::vector<std::uint8_t>* out, size_t* written) {
  auto length = [&](size_t* at, size_t value) {
    if (value != 15) return value;
    while (*at < size) {
      const std::uint8_t more = in[(*at)++];
      value += more;
      if (more != 255) return value;
    }
    return SIZE_MAX;
  };
  size_t at = 0;
  std::uint8_t* const begin = out->data();
  const size_t capacity = out->size();
  while (at < size) {
    const std::uint8_t token = in[at++];
    const size_t literals = length(&at, token >> 4U);
    if (literals > size - at || literals > capacity - *written) return false;
    std::memcpy(begin + *written, in + at, literals);
    at += literals;
    *written += literals;
    if (at == size) return true;  // the last sequence has no match
    if (size - at < 2) return false;
    const size_t offset = in[at] | (static_cast<size_t>(in[at + 1]) << 8U);
    at += 2;
    const size_t match = length(&at, token & 0xFU);
    if (match == SIZE_MAX || match + 4 > capacity - *written) return false;
    if (offset == 0 || offset > *written - history_start) return false;
    for (size_t i = 0; i < match + 4; ++i, ++*written) begin[*written] = begin[*written - offset];
  }
  return false;
}

// The frame's checksums (xxHash32, seed 0) are checked as liblz4 checks them: a block's over its
// stored bytes, the content's over the frame's whole output. Without them, data that liblz4
// refused as damaged would pass here.
bool Lz4FrameByHand(const std::uint8_t* data, size_t size, std::vector<std::uint8_t>* out,
                    std::string* error) {
  size_t at = 0, written = 0;
  while (at <= size && size - at >= 7 && Le32(data + at) == 0x184D2204U) {
    const std::uint8_t flags = data[at + 4];
    at += 7 + ((flags & 0x08U) != 0 ? 8 : 0) + ((flags & 0x01U) != 0 ? 4 : 0);
    const bool block_checksum = (flags & 0x10U) != 0, independent = (flags & 0x20U) != 0;
    const size_t frame_start = written;
    while (true) {
      if (size < 4 || at > size - 4) return false;
      const std::uint32_t word = Le32(data + at);
      at += 4;
      if (word == 0) break;
      const size_t block = word & 0x7FFFFFFFU;
      if (block > size - at || (block_checksum && size - at - block < 4)) return false;
      if (block_checksum && XXH32(data + at, block, 0) != Le32(data + at + block)) {
        *error = "lz4 data damaged (a block's checksum does not match)";
        return false;
      }
      if ((word & 0x80000000U) != 0) {
        if (block > out->size() - written) return false;
        std::memcpy(out->data() + written, data + at, block);
        written += block;
      } else if (!Lz4Sequences(data + at, block, independent ? written : frame_start, out,
                               &written)) {
        return false;
      }
      at += block + (block_checksum ? 4 : 0);
    }
    if ((flags & 0x04U) != 0) {
      if (size - at < 4) return false;
      if (XXH32(out->data() + frame_start, written - frame_start, 0) != Le32(data + at)) {
        *error = "lz4 data damaged (the content checksum does not match)";
        return false;
      }
      at += 4;
    }
  }
  return at == size && written == out->size();
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
  if (!ok && Lz4FrameByHand(data, size, out, error)) return true;
  if (ok && read != size) {  // a frame that ends before its block: the block's length is damaged
    *error = "lz4 data: the frame ends " + std::to_string(size - read) + " bytes before the block";
    ok = false;
  } else if (ok && written != out->size()) {
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
