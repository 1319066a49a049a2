#include "bag/mcap_bag.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>

#include "bag/bytes.h"
#include "bag/decompress.h"
#include "bag/recovered_topics.h"
#include "bag/resync.h"
#include "stillmap/io/error.h"

namespace stillmap {
namespace {

constexpr std::uint8_t kOpFooter = 0x02;
constexpr std::uint8_t kOpSchema = 0x03;
constexpr std::uint8_t kOpChannel = 0x04;
constexpr std::uint8_t kOpMessage = 0x05;
constexpr std::uint8_t kOpChunk = 0x06;
constexpr std::uint8_t kOpChunkIndex = 0x08;
constexpr std::uint8_t kOpDataEnd = 0x0F;
constexpr std::uint8_t kOpFirstPrivate = 0x80;  // 0x80-0xFF: private records, skipped
constexpr std::uint64_t kMaxChunkBytes = 1ULL << 30U;
// A message outside any chunk: BagPosition::block is its record's file offset.
constexpr std::uint32_t kUnchunked = 0xFFFFFFFFU;

// Reads MCAP's little-endian fields from one record's content.
class Fields {
 public:
  Fields(const std::uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool U16(std::uint16_t* value) {
    if (!Has(2)) return false;
    *value = static_cast<std::uint16_t>(data_[at_] | (data_[at_ + 1] << 8U));
    at_ += 2;
    return true;
  }
  bool U32(std::uint32_t* value) {
    if (!Has(4)) return false;
    *value = Le32(data_ + at_);
    at_ += 4;
    return true;
  }
  bool U64(std::uint64_t* value) {
    if (!Has(8)) return false;
    *value = Le64(data_ + at_);
    at_ += 8;
    return true;
  }
  bool String(std::string* value) {
    std::uint32_t length = 0;
    if (!U32(&length) || !Has(length)) return false;
    value->assign(reinterpret_cast<const char*>(data_ + at_), length);
    at_ += length;
    return true;
  }
  bool Skip(size_t n) {
    if (!Has(n)) return false;
    at_ += n;
    return true;
  }
  size_t at() const { return at_; }
  size_t left() const { return size_ - at_; }

 private:
  bool Has(size_t n) const { return n <= size_ - at_; }
  const std::uint8_t* data_;
  size_t size_;
  size_t at_ = 0;
};

// True when `p` (`available` bytes, at file offset `offset` of `file_size`) starts a chunk record
// whose header is self-consistent: a known compression and a records length that fills the
// record exactly.
bool IsChunkHeader(const std::uint8_t* p, size_t available, std::uint64_t offset,
                   std::uint64_t file_size) {
  if (available < 9 || p[0] != kOpChunk) return false;
  const std::uint64_t length = Le64(p + 1);
  if (length > file_size - offset - 9) return false;
  Fields fields(p + 9, std::min<std::uint64_t>(available - 9, length));
  std::uint64_t start = 0, end = 0, uncompressed = 0, records = 0;
  std::uint32_t crc = 0;
  std::string compression;
  if (!fields.U64(&start) || !fields.U64(&end) || !fields.U64(&uncompressed) || !fields.U32(&crc) ||
      !fields.String(&compression)) {
    return false;
  }
  if (!fields.U64(&records)) return false;
  return end >= start && uncompressed <= kMaxChunkBytes &&
         (compression.empty() || compression == "lz4" || compression == "zstd") &&
         records == length - fields.at();
}

// A record op of MCAP's specification (0x01-0x0F) or a private one; anything else is damage.
bool IsKnownOp(std::uint8_t op) {
  return (op >= 0x01 && op <= kOpDataEnd) || op >= kOpFirstPrivate;
}

}  // namespace

McapBag::McapBag(const std::string& path) : BagReader(path), read_file_(path, std::ios::binary) {
  file_size_ = CheckMagic(kMagic, kMagicSize, "an MCAP file (no MCAP magic at its start)");
}

void McapBag::Record(std::uint8_t op, const std::uint8_t* content, size_t size,
                     BagPosition position, const std::function<void(const BagMessage&)>& visit) {
  Fields fields(content, size);
  if (op == kOpSchema) {
    std::uint16_t id = 0;
    std::string name;
    if (fields.U16(&id) && fields.String(&name)) schema_name_[id] = name;
  } else if (op == kOpChannel) {
    std::uint16_t id = 0, schema = 0;
    std::string topic;
    if (!fields.U16(&id) || !fields.U16(&schema) || !fields.String(&topic)) return;
    if (topic_of_channel_.count(id) > 0) return;
    topic_of_channel_[id] = JoinTopic(&topics_, {topic, schema_name_[schema]});
  } else if (op == kOpMessage) {
    std::uint16_t channel = 0;
    std::uint32_t sequence = 0;
    std::uint64_t log_time = 0, publish_time = 0;
    if (!fields.U16(&channel) || !fields.U32(&sequence) || !fields.U64(&log_time) ||
        !fields.U64(&publish_time)) {
      return;
    }
    size_t topic = 0;
    if (!TopicOfChannel(channel, &topic)) return;
    BagMessage message;
    message.topic = topic;
    message.time = 1e-9 * static_cast<double>(log_time);
    message.position = position;
    message.data = content + fields.at();
    message.size = fields.left();
    last_time_ = message.time;
    visit(message);
  }
}

bool McapBag::LoadChunk(std::ifstream& file, std::uint64_t offset, std::uint64_t size,
                        std::vector<std::uint8_t>* out, std::string* error) const {
  std::vector<std::uint8_t> content(size);
  file.clear();
  file.seekg(static_cast<std::streamoff>(offset));
  file.read(reinterpret_cast<char*>(content.data()), static_cast<std::streamsize>(size));
  if (!file) {
    *error = "the chunk could not be read";
    return false;
  }
  Fields fields(content.data(), content.size());
  std::uint64_t start = 0, end = 0, uncompressed = 0, records = 0;
  std::uint32_t crc = 0;
  std::string compression;
  if (!fields.U64(&start) || !fields.U64(&end) || !fields.U64(&uncompressed) || !fields.U32(&crc) ||
      !fields.String(&compression) || !fields.U64(&records) || records > fields.left()) {
    *error = "a chunk header that does not parse";
    return false;
  }
  if (uncompressed > kMaxChunkBytes) {
    *error = "a chunk of " + std::to_string(uncompressed) + " bytes uncompressed";
    return false;
  }
  if (!DecompressBlock(compression, content.data() + fields.at(), records, uncompressed, out,
                       error)) {
    return false;
  }
  if (crc != 0) {
    const uLong computed = crc32(crc32(0L, Z_NULL, 0), out->data(), static_cast<uInt>(out->size()));
    if (computed != crc) {
      *error = "its CRC does not match (damaged data)";
      return false;
    }
  }
  return true;
}

void McapBag::ReadSummary(std::ifstream& file) {
  summary_channels_.clear();
  summary_chunks_.clear();
  // The footer record (op, length 20, summary_start, summary_offset_start, summary_crc), then
  // the closing magic.
  constexpr std::uint64_t kFooterRecord = 9 + 20;
  if (file_size_ < kMagicSize * 2 + kFooterRecord) return;
  const std::uint64_t footer = file_size_ - kMagicSize - kFooterRecord;
  std::uint8_t tail[kFooterRecord + kMagicSize] = {};
  file.clear();
  file.seekg(static_cast<std::streamoff>(footer));
  file.read(reinterpret_cast<char*>(tail), sizeof(tail));
  if (!file || tail[0] != kOpFooter || Le64(tail + 1) != 20 ||
      std::memcmp(tail + kFooterRecord, kMagic, kMagicSize) != 0) {
    return;
  }
  const std::uint64_t summary_start = Le64(tail + 9);
  if (summary_start < kMagicSize || summary_start >= footer) return;
  std::vector<std::uint8_t> summary(footer - summary_start);
  file.seekg(static_cast<std::streamoff>(summary_start));
  file.read(reinterpret_cast<char*>(summary.data()), static_cast<std::streamsize>(summary.size()));
  if (!file) return;
  std::map<std::uint16_t, std::string> schemas;
  for (size_t at = 0; summary.size() - at >= 9;) {
    const std::uint64_t length = Le64(summary.data() + at + 1);
    if (length > summary.size() - at - 9) break;
    Fields fields(summary.data() + at + 9, length);
    std::uint16_t id = 0, schema = 0;
    std::uint64_t start = 0, end = 0, chunk = 0;
    std::string name;
    const std::uint8_t op = summary[at];
    if (op == kOpSchema && fields.U16(&id) && fields.String(&name)) {
      schemas[id] = name;
    } else if (op == kOpChannel && fields.U16(&id) && fields.U16(&schema) && fields.String(&name)) {
      summary_channels_[id] = {name, schemas[schema]};
    } else if (op == kOpChunkIndex && fields.U64(&start) && fields.U64(&end) &&
               fields.U64(&chunk) && chunk >= kMagicSize && chunk < summary_start) {
      summary_chunks_.push_back(chunk);
    }
    at += 9 + length;
  }
  std::sort(summary_chunks_.begin(), summary_chunks_.end());
}

bool McapBag::TopicOfChannel(std::uint16_t id, size_t* topic) {
  return TopicOfId(id, summary_channels_, &topic_of_channel_, &topics_, topic);
}

std::uint64_t McapBag::NextChunkAfter(std::ifstream& file, std::uint64_t from) const {
  constexpr size_t kHeaderBytes = 9 + 8 * 3 + 4 + 4 + 8 + 8;  // a chunk header, compression <= 8
  std::uint8_t head[kHeaderBytes] = {};
  auto is_chunk = [&](std::uint64_t offset) {
    const auto available =
        static_cast<size_t>(std::min<std::uint64_t>(kHeaderBytes, file_size_ - offset));
    file.clear();
    file.seekg(static_cast<std::streamoff>(offset));
    file.read(reinterpret_cast<char*>(head), static_cast<std::streamsize>(available));
    return file && IsChunkHeader(head, available, offset, file_size_);
  };
  const std::uint64_t limit = NextListed(summary_chunks_, from, file_size_, is_chunk);
  const auto starts = [&](const std::uint8_t* bytes, size_t available, std::uint64_t offset) {
    return bytes[0] == kOpChunk && IsChunkHeader(bytes, available, offset, file_size_);
  };
  return ScanForward(file, file_size_, from, limit, kHeaderBytes, starts);
}

void McapBag::Scan(const std::function<void(const BagMessage&)>& visit) {
  warnings_.clear();
  truncated_ = false;
  last_time_ = 0.0;
  std::ifstream file(path_, std::ios::binary);
  if (!file) throw InputError(path_ + ": cannot open the bag");
  ReadSummary(file);
  std::uint64_t offset = kMagicSize;
  std::vector<std::uint8_t> content, chunk;
  while (true) {
    std::uint8_t head[9];
    file.clear();
    file.seekg(static_cast<std::streamoff>(offset));
    file.read(reinterpret_cast<char*>(head), sizeof(head));
    const std::uint64_t length = Le64(head + 1);
    if (!file || length > file_size_ - offset - sizeof(head) || !IsKnownOp(head[0])) {
      // Damage, or the end of a recording cut short: read on from the next chunk, if any.
      const std::uint64_t next = NextChunkAfter(file, offset);
      if (next >= file_size_) {
        WarnTruncated(offset, file_size_, last_time_);
        return;
      }
      warnings_.push_back(path_ + ": " + SkippedBytes(offset, next, ""));
      offset = next;
      continue;
    }
    const std::uint8_t op = head[0];
    const std::uint64_t content_offset = offset + sizeof(head);
    if (op == kOpDataEnd || op == kOpFooter) return;
    if (op == kOpChunk) {
      std::string error;
      if (!LoadChunk(file, content_offset, length, &chunk, &error)) {
        // The chunk's length may be the damage: the next chunk is looked for, not assumed.
        const std::uint64_t next = NextChunkAfter(file, offset);
        warnings_.push_back(path_ + ": " + SkippedChunk(offset, error, next, file_size_));
        if (next >= file_size_) return;
        offset = next;
        continue;
      } else {
        size_t at = 0;
        while (chunk.size() - at >= 9) {
          const std::uint64_t inner = Le64(chunk.data() + at + 1);
          if (inner > chunk.size() - at - 9) {
            warnings_.push_back(path_ + ": the chunk at byte " + std::to_string(offset) +
                                " holds a damaged record; its later messages are skipped");
            break;
          }
          Record(chunk[at], chunk.data() + at + 9, inner, {offset, static_cast<std::uint32_t>(at)},
                 visit);
          at += 9 + inner;
        }
      }
    } else if (op == kOpSchema || op == kOpChannel || op == kOpMessage) {
      content.resize(length);
      file.read(reinterpret_cast<char*>(content.data()), static_cast<std::streamsize>(length));
      if (file) Record(op, content.data(), content.size(), {offset, kUnchunked}, visit);
    }
    offset = content_offset + length;
  }
}

const std::vector<std::uint8_t>& McapBag::CachedChunkAt(std::uint64_t block) const {
  return cache_.Get(block, [this](std::uint64_t at, std::vector<std::uint8_t>* data) {
    std::uint8_t head[9] = {};
    read_file_.clear();
    read_file_.seekg(static_cast<std::streamoff>(at));
    read_file_.read(reinterpret_cast<char*>(head), sizeof(head));
    const std::uint64_t length = Le64(head + 1);
    std::string error = "a record that runs past the file";
    if (!read_file_ || head[0] != kOpChunk || at > file_size_ - sizeof(head) ||
        length > file_size_ - at - sizeof(head) ||
        !LoadChunk(read_file_, at + sizeof(head), length, data, &error)) {
      throw InputError(path_ + ": the chunk at byte " + std::to_string(at) +
                       " cannot be read again (" + error + ")");
    }
  });
}

std::vector<std::uint8_t> McapBag::Read(const BagPosition& position) const {
  const std::lock_guard<std::mutex> lock(read_mutex_);
  std::vector<std::uint8_t> record;
  const std::uint8_t* at = nullptr;
  size_t size = 0;
  if (position.offset == kUnchunked) {
    std::uint8_t head[9] = {};
    read_file_.clear();
    read_file_.seekg(static_cast<std::streamoff>(position.block));
    read_file_.read(reinterpret_cast<char*>(head), sizeof(head));
    const std::uint64_t length = Le64(head + 1);
    if (!read_file_ || length > kMaxChunkBytes) {
      throw InputError(path_ + ": no message at byte " + std::to_string(position.block));
    }
    record.resize(length);
    read_file_.read(reinterpret_cast<char*>(record.data()), static_cast<std::streamsize>(length));
    if (!read_file_)
      throw InputError(path_ + ": no message at byte " + std::to_string(position.block));
    at = record.data();
    size = record.size();
  } else {
    const std::vector<std::uint8_t>& chunk = CachedChunkAt(position.block);
    if (position.offset >= chunk.size() || chunk.size() - position.offset < 9 ||
        Le64(chunk.data() + position.offset + 1) > chunk.size() - position.offset - 9) {
      throw InputError(path_ + ": no message at offset " + std::to_string(position.offset) +
                       " of the chunk at byte " + std::to_string(position.block));
    }
    at = chunk.data() + position.offset + 9;
    size = Le64(chunk.data() + position.offset + 1);
  }
  constexpr size_t kMessageHeader = 2 + 4 + 8 + 8;  // channel, sequence, log and publish time
  if (size < kMessageHeader) throw InputError(path_ + ": a message record too short");
  return {at + kMessageHeader, at + size};
}

}  // namespace stillmap
