#include "bag/ros1_bag.h"

#include <algorithm>
#include <cstring>

#include "bag/bytes.h"
#include "bag/decompress.h"
#include "bag/recovered_topics.h"
#include "bag/resync.h"
#include "stillmap/io/error.h"

namespace stillmap {
namespace {

constexpr std::uint8_t kOpMessage = 0x02;
constexpr std::uint8_t kOpBagHeader = 0x03;
constexpr std::uint8_t kOpIndexData = 0x04;
constexpr std::uint8_t kOpChunk = 0x05;
constexpr std::uint8_t kOpChunkInfo = 0x06;
constexpr std::uint8_t kOpConnection = 0x07;
// A resynchronisation's candidate record headers are this short (rosbag's are under 200 bytes).
constexpr std::uint32_t kMaxOuterHeaderBytes = 4096;
// Larger record headers or chunks than these are damage, not data (rosbag's own chunks are
// 768 KiB by default; a header holds a few short fields).
constexpr std::uint32_t kMaxHeaderBytes = 1U << 20U;
constexpr std::uint64_t kMaxChunkBytes = 1ULL << 30U;

using Fields = std::map<std::string, std::string>;

// The "name=value" fields of a record header, each preceded by its length.
bool ParseFields(const std::uint8_t* p, size_t n, Fields* fields) {
  while (n > 0) {
    if (n < 4) return false;
    const std::uint32_t length = Le32(p);
    p += 4;
    n -= 4;
    if (length > n) return false;
    const char* text = reinterpret_cast<const char*>(p);
    const char* equals = static_cast<const char*>(std::memchr(text, '=', length));
    if (equals == nullptr) return false;
    (*fields)[std::string(text, equals)] = std::string(equals + 1, text + length);
    p += length;
    n -= length;
  }
  return true;
}

bool FieldU8(const Fields& fields, const char* name, std::uint8_t* value) {
  const auto it = fields.find(name);
  if (it == fields.end() || it->second.size() != 1) return false;
  *value = static_cast<std::uint8_t>(it->second[0]);
  return true;
}

bool FieldU32(const Fields& fields, const char* name, std::uint32_t* value) {
  const auto it = fields.find(name);
  if (it == fields.end() || it->second.size() != 4) return false;
  *value = Le32(reinterpret_cast<const std::uint8_t*>(it->second.data()));
  return true;
}

bool FieldU64(const Fields& fields, const char* name, std::uint64_t* value) {
  const auto it = fields.find(name);
  if (it == fields.end() || it->second.size() != 8) return false;
  *value = Le64(reinterpret_cast<const std::uint8_t*>(it->second.data()));
  return true;
}

// A record that may stand in the data or index section (messages stand only inside chunks).
bool IsOuterOp(std::uint8_t op) {
  return op == kOpChunk || op == kOpIndexData || op == kOpChunkInfo || op == kOpConnection;
}

// The warning for bytes [from, to) skipped after damage.
// A ROS 1 time field: seconds and nanoseconds, 32 bits each.
bool FieldTime(const Fields& fields, const char* name, double* seconds) {
  const auto it = fields.find(name);
  if (it == fields.end() || it->second.size() != 8) return false;
  const auto* p = reinterpret_cast<const std::uint8_t*>(it->second.data());
  *seconds = static_cast<double>(Le32(p)) + 1e-9 * static_cast<double>(Le32(p + 4));
  return true;
}

// A record inside a decompressed chunk: its fields and data span; false when it runs past the
// chunk or its header is damaged.
bool ChunkRecord(const std::vector<std::uint8_t>& chunk, size_t offset, Fields* fields,
                 size_t* data_offset, size_t* data_size) {
  if (chunk.size() - offset < 4) return false;
  const std::uint32_t header_size = Le32(chunk.data() + offset);
  if (header_size > chunk.size() - offset - 4 || chunk.size() - offset - 4 - header_size < 4) {
    return false;
  }
  if (!ParseFields(chunk.data() + offset + 4, header_size, fields)) return false;
  *data_offset = offset + 4 + header_size + 4;
  *data_size = Le32(chunk.data() + offset + 4 + header_size);
  return *data_size <= chunk.size() - *data_offset;
}

}  // namespace

Ros1Bag::Ros1Bag(const std::string& path) : BagReader(path), read_file_(path, std::ios::binary) {
  char magic[kMagicSize] = {};
  std::ifstream(path, std::ios::binary).read(magic, kMagicSize);
  if (std::memcmp(magic, "#ROSBAG V", 9) == 0 && std::memcmp(magic, kMagic, kMagicSize) != 0) {
    throw InputError(path + ": a ROS 1 bag of format " + Quoted(std::string(magic + 9, 3)) +
                     "; stillmap reads format 2.0 (convert it with `rosbag fix` on a ROS 1 "
                     "machine)");
  }
  file_size_ = CheckMagic(kMagic, kMagicSize, "a ROS 1 bag (no \"#ROSBAG V2.0\" at its start)");
  std::ifstream file(path, std::ios::binary);
  Record header;
  std::string damage;
  std::uint8_t op = 0;
  if (!ReadRecord(file, kMagicSize, &header, &damage) || !FieldU8(header.fields, "op", &op) ||
      op != kOpBagHeader) {
    throw InputError(path + ": the bag header record is damaged" +
                     (damage.empty() ? std::string() : " (" + damage + ")"));
  }
  data_start_ = header.end;
  if (!FieldU64(header.fields, "index_pos", &index_pos_) || index_pos_ < data_start_ ||
      index_pos_ >= file_size_) {
    index_pos_ = 0;  // not indexed (a recording cut short), or a damaged header field
  }
}

bool Ros1Bag::ReadRecord(std::ifstream& file, std::uint64_t offset, Record* record,
                         std::string* damage) const {
  *record = Record();
  if (file_size_ - offset < 4) return false;
  std::uint8_t size_bytes[4];
  file.clear();
  file.seekg(static_cast<std::streamoff>(offset));
  file.read(reinterpret_cast<char*>(size_bytes), 4);
  const std::uint32_t header_size = Le32(size_bytes);
  if (!file || header_size > kMaxHeaderBytes) {
    *damage = "a record header of " + std::to_string(header_size) + " bytes";
    return false;
  }
  if (file_size_ - offset - 4 < static_cast<std::uint64_t>(header_size) + 4) return false;
  std::vector<std::uint8_t> header(header_size + 4);
  file.read(reinterpret_cast<char*>(header.data()), static_cast<std::streamsize>(header.size()));
  if (!file || !ParseFields(header.data(), header_size, &record->fields)) {
    *damage = "a record header that does not parse";
    return false;
  }
  record->data_offset = offset + 4 + header_size + 4;
  record->data_size = Le32(header.data() + header_size);
  record->end = record->data_offset + record->data_size;
  return record->end <= file_size_;
}

bool Ros1Bag::LoadChunk(std::ifstream& file, const Record& record, std::vector<std::uint8_t>* out,
                        std::string* error) const {
  std::uint32_t size = 0;
  const auto compression = record.fields.find("compression");
  if (compression == record.fields.end() || !FieldU32(record.fields, "size", &size)) {
    *error = "a chunk header without compression or size";
    return false;
  }
  if (size > kMaxChunkBytes) {
    *error = "a chunk of " + std::to_string(size) + " bytes uncompressed";
    return false;
  }
  std::vector<std::uint8_t> data(record.data_size);
  file.clear();
  file.seekg(static_cast<std::streamoff>(record.data_offset));
  file.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
  if (!file) {
    *error = "the chunk could not be read";
    return false;
  }
  return DecompressBlock(compression->second, data.data(), data.size(), size, out, error);
}

void Ros1Bag::AddConnection(const Fields& fields, const std::uint8_t* data, size_t size) {
  std::uint32_t id = 0;
  Fields connection;
  if (!FieldU32(fields, "conn", &id) || !ParseFields(data, size, &connection)) return;
  if (topic_of_connection_.count(id) > 0) return;
  const auto topic = fields.find("topic");
  if (topic == fields.end()) return;
  const size_t index = JoinTopic(&topics_, {topic->second, connection["type"]});
  topic_of_connection_[id] = index;
}

bool Ros1Bag::ScanChunk(std::uint64_t chunk_offset, const std::vector<std::uint8_t>& chunk,
                        const std::function<void(const BagMessage&)>& visit, double* last_time) {
  size_t offset = 0;
  while (offset < chunk.size()) {
    Fields fields;
    size_t data_offset = 0, data_size = 0;
    std::uint8_t op = 0;
    if (!ChunkRecord(chunk, offset, &fields, &data_offset, &data_size) ||
        !FieldU8(fields, "op", &op)) {
      return false;
    }
    if (op == kOpConnection) AddConnection(fields, chunk.data() + data_offset, data_size);
    std::uint32_t connection = 0;
    if (op == kOpMessage && FieldU32(fields, "conn", &connection)) {
      size_t topic = 0;
      BagMessage message;
      if (TopicOfConnection(connection, &topic) && FieldTime(fields, "time", &message.time)) {
        message.topic = topic;
        message.position = {chunk_offset, static_cast<std::uint32_t>(offset)};
        message.data = chunk.data() + data_offset;
        message.size = data_size;
        *last_time = message.time;
        visit(message);
      }
    }
    offset = data_offset + data_size;
  }
  return true;
}

void Ros1Bag::ReadIndex(std::ifstream& file) {
  index_connections_.clear();
  index_chunks_.clear();
  if (index_pos_ == 0) return;
  for (std::uint64_t offset = index_pos_; offset < file_size_;) {
    Record record;
    std::string damage;
    std::uint8_t op = 0;
    if (!ReadRecord(file, offset, &record, &damage) || !FieldU8(record.fields, "op", &op)) break;
    std::uint32_t id = 0;
    std::uint64_t chunk = 0;
    const auto topic = record.fields.find("topic");
    if (op == kOpConnection && FieldU32(record.fields, "conn", &id) &&
        topic != record.fields.end() && record.data_size <= kMaxOuterHeaderBytes * 16) {
      std::vector<std::uint8_t> data(record.data_size);
      file.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
      Fields connection;
      if (file && ParseFields(data.data(), data.size(), &connection)) {
        index_connections_[id] = {topic->second, connection["type"]};
      }
    } else if (op == kOpChunkInfo && FieldU64(record.fields, "chunk_pos", &chunk) &&
               chunk >= data_start_ && chunk < index_pos_) {
      index_chunks_.push_back(chunk);
    }
    offset = record.end;
  }
  std::sort(index_chunks_.begin(), index_chunks_.end());
}

bool Ros1Bag::TopicOfConnection(std::uint32_t id, size_t* topic) {
  return TopicOfId(id, index_connections_, &topic_of_connection_, &topics_, topic);
}

bool Ros1Bag::IsRecordStart(std::ifstream& file, std::uint64_t offset) const {
  Record record;
  std::string damage;
  std::uint8_t op = 0;
  if (!ReadRecord(file, offset, &record, &damage) || !FieldU8(record.fields, "op", &op) ||
      !IsOuterOp(op)) {
    return false;
  }
  std::uint32_t size = 0;
  if (op == kOpChunk &&
      (record.fields.count("compression") == 0 || !FieldU32(record.fields, "size", &size))) {
    return false;
  }
  if (record.end == file_size_) return true;
  Record next;
  return ReadRecord(file, record.end, &next, &damage) && FieldU8(next.fields, "op", &op) &&
         IsOuterOp(op);
}

std::uint64_t Ros1Bag::NextRecordAfter(std::ifstream& file, std::uint64_t from) const {
  const auto whole = [&](std::uint64_t offset) { return IsRecordStart(file, offset); };
  const std::uint64_t limit = NextListed(index_chunks_, from, file_size_, whole);
  // A plausible header length and first field length, then the records themselves.
  const auto starts = [&](const std::uint8_t* bytes, size_t available, std::uint64_t offset) {
    if (available < 8) return false;
    const std::uint32_t header_size = Le32(bytes), first_field = Le32(bytes + 4);
    return header_size >= 8 && header_size <= kMaxOuterHeaderBytes && first_field >= 4 &&
           first_field <= header_size - 4 && whole(offset);
  };
  return ScanForward(file, file_size_, from, limit, 8, starts);
}

void Ros1Bag::Scan(const std::function<void(const BagMessage&)>& visit) {
  warnings_.clear();
  truncated_ = false;
  std::ifstream file(path_, std::ios::binary);
  if (!file) throw InputError(path_ + ": cannot open the bag");
  ReadIndex(file);
  std::uint64_t offset = data_start_;
  double last_time = 0.0;
  std::vector<std::uint8_t> chunk;
  while (offset < file_size_) {
    Record record;
    std::string damage;
    std::uint8_t op = 0;
    if (!ReadRecord(file, offset, &record, &damage) || !FieldU8(record.fields, "op", &op)) {
      // Damage, or the end of a bag cut short: read on from the next record, if there is one.
      const std::uint64_t next = NextRecordAfter(file, offset);
      if (next >= file_size_) {
        WarnTruncated(offset, file_size_, last_time, damage);
        return;
      }
      warnings_.push_back(path_ + ": " + SkippedBytes(offset, next, damage));
      offset = next;
      continue;
    }
    if (op == kOpChunk) {
      std::string error;
      if (!LoadChunk(file, record, &chunk, &error)) {
        // The chunk's length may be the damage: the next chunk is looked for, not assumed.
        const std::uint64_t next = NextRecordAfter(file, offset);
        warnings_.push_back(path_ + ": " + SkippedChunk(offset, error, next, file_size_));
        if (next >= file_size_) return;
        offset = next;
        continue;
      }
      if (!ScanChunk(offset, chunk, visit, &last_time)) {
        warnings_.push_back(path_ + ": the chunk at byte " + std::to_string(offset) +
                            " holds a damaged record; its later messages are skipped");
      }
    } else if (op == kOpConnection) {
      std::vector<std::uint8_t> data(record.data_size);
      file.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
      if (file) AddConnection(record.fields, data.data(), data.size());
    }
    offset = record.end;
  }
}

const std::vector<std::uint8_t>& Ros1Bag::CachedChunkAt(std::uint64_t block) const {
  return cache_.Get(block, [this](std::uint64_t at, std::vector<std::uint8_t>* data) {
    Record record;
    std::string error;
    if (!ReadRecord(read_file_, at, &record, &error) ||
        !LoadChunk(read_file_, record, data, &error)) {
      throw InputError(path_ + ": the chunk at byte " + std::to_string(at) +
                       " cannot be read again (" + error + ")");
    }
  });
}

std::vector<std::uint8_t> Ros1Bag::Read(const BagPosition& position) const {
  const std::lock_guard<std::mutex> lock(read_mutex_);
  const std::vector<std::uint8_t>& chunk = CachedChunkAt(position.block);
  Fields fields;
  size_t data_offset = 0, data_size = 0;
  if (position.offset >= chunk.size() ||
      !ChunkRecord(chunk, position.offset, &fields, &data_offset, &data_size)) {
    throw InputError(path_ + ": no message at offset " + std::to_string(position.offset) +
                     " of the chunk at byte " + std::to_string(position.block));
  }
  return {chunk.begin() + static_cast<std::ptrdiff_t>(data_offset),
          chunk.begin() + static_cast<std::ptrdiff_t>(data_offset + data_size)};
}

}  // namespace stillmap
