#include "bag/image_judge.h"

#include <algorithm>
#include <cstdio>
#include <set>

namespace stillmap {
namespace {

std::string Seconds(double t) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6f s", t);
  return text;
}

// Why messages of a topic were left out, beyond another kind: counts and the first instance.
struct LeftOut {
  size_t negative = 0, back = 0;
  double back_from = 0.0, back_to = 0.0;  // the first jump back [s]
};

// The key most messages have (the first met on a tie); kNoImage when none holds an image.
size_t MostCommonKey(const ImageMessages& messages) {
  std::vector<size_t> votes(messages.keys.size(), 0);
  for (const size_t key : messages.key_of) {
    if (key != ImageMessages::kNoImage) ++votes[key];
  }
  return votes.empty()
             ? ImageMessages::kNoImage
             : static_cast<size_t>(std::max_element(votes.begin(), votes.end()) - votes.begin());
}

void Keep(const ImageMessages& messages, size_t i, BagStream* stream) {
  const double stamp = messages.stamps[i];
  if (stream->count == 0 || stamp < stream->first_stamp) stream->first_stamp = stamp;
  stream->last_stamp = stream->count == 0 ? stamp : std::max(stream->last_stamp, stamp);
  stream->stamps.push_back(stamp);
  stream->positions.push_back(messages.positions[i]);
  ++stream->count;
}

void SetDetail(const std::string& key, BagStream* stream) {
  const size_t space = key.rfind(' ');
  if (stream->kind == BagStreamKind::kImage && space != std::string::npos) {
    stream->detail = key.substr(0, space);
    std::sscanf(key.c_str() + space + 1, "%dx%d", &stream->width, &stream->height);
  } else {
    stream->detail = key;
  }
}

void Warn(const ImageMessages& messages, size_t best, const LeftOut& left_out,
          const std::string& path, const BagStream& stream, std::vector<std::string>* warnings) {
  const std::string of =
      " of " + std::to_string(messages.key_of.size()) + " messages on " + stream.name;
  if (left_out.negative > 0) {
    warnings->push_back(path + ": " + std::to_string(left_out.negative) + of +
                        " have a negative header stamp and are left out");
  }
  if (left_out.back > 0) {
    warnings->push_back(path + ": " + std::to_string(left_out.back) + of +
                        " are stamped back in time and left out (the header stamp goes back from " +
                        Seconds(left_out.back_from) + " to " + Seconds(left_out.back_to) +
                        ": a clock reset?); the map holds the frames before");
  }
  if (stream.repeated > 0) {
    warnings->push_back(path + ": " + std::to_string(stream.repeated) + of +
                        " repeat the header stamp of an earlier one and are left out" +
                        (stream.count == 1
                             ? " (every message has the stamp " + Seconds(stream.first_stamp) + ")"
                             : std::string()));
  }
  const size_t other = stream.skipped - left_out.negative - left_out.back;
  if (other > 0) {
    warnings->push_back(
        path + ": " + std::to_string(other) + of + " are left out: they hold no readable image" +
        (best == ImageMessages::kNoImage
             ? std::string()
             : ", or another encoding or size than the topic's own (" + messages.keys[best] + ")"));
  }
}

}  // namespace

std::string ImageKey(const BagStream& stream, const BagMessage& message,
                     BagSerialization serialization, double* stamp) {
  std::string error;
  if (stream.kind == BagStreamKind::kImage) {
    RosImage image;
    if (!DecodeRosImage(message.data, message.size, serialization, &image, &error) ||
        image.width == 0 || image.height == 0 || image.step == 0 ||
        static_cast<std::uint64_t>(image.step) * image.height > image.size) {
      return {};
    }
    *stamp = image.header.stamp;
    return image.encoding + " " + std::to_string(image.width) + "x" + std::to_string(image.height);
  }
  RosCompressedImage image;
  if (!DecodeRosCompressedImage(message.data, message.size, serialization, &image, &error) ||
      image.size == 0) {
    return {};
  }
  *stamp = image.header.stamp;
  return image.format;
}

void ImageMessages::Add(const std::string& key, double stamp, const BagPosition& position) {
  size_t index = kNoImage;
  if (!key.empty()) {
    index = static_cast<size_t>(std::find(keys.begin(), keys.end(), key) - keys.begin());
    if (index == keys.size()) keys.push_back(key);
  }
  key_of.push_back(index);
  stamps.push_back(stamp);
  positions.push_back(position);
}

void JudgeImages(const ImageMessages& messages, const std::string& path, BagStream* stream,
                 std::vector<std::string>* warnings) {
  const size_t best = MostCommonKey(messages);
  std::set<double> stamps_kept;
  LeftOut left_out;
  double latest = 0.0;  // the latest stamp kept [s]
  for (size_t i = 0; i < messages.key_of.size(); ++i) {
    const double stamp = messages.stamps[i];
    if (messages.key_of[i] != best || best == ImageMessages::kNoImage) {
      ++stream->skipped;
    } else if (stamp < 0.0) {
      ++left_out.negative, ++stream->skipped;
    } else if (stream->count > 0 && stamp < latest - kClockJumpBack) {
      if (left_out.back++ == 0) left_out.back_from = latest, left_out.back_to = stamp;
      ++stream->skipped;
    } else if (!stamps_kept.insert(stamp).second) {  // a message recorded twice, or stamps unset
      ++stream->repeated;
    } else {
      Keep(messages, i, stream);
      latest = std::max(latest, stamp);
    }
  }
  if (best != ImageMessages::kNoImage) SetDetail(messages.keys[best], stream);
  Warn(messages, best, left_out, path, *stream, warnings);
}

}  // namespace stillmap
