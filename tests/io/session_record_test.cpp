#include "stillmap/io/session_record.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "stillmap/io/error.h"
#include "stillmap/io/session_keyframes.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::TempDir;

Camera TestCamera() {
  Camera camera;
  camera.width = 64;
  camera.height = 48;
  camera.fx = camera.fy = 50.0;
  camera.cx = 31.5;
  camera.cy = 23.5;
  camera.distortion = {0.1, -0.05, 0.001, 0.002, 0.01};
  camera.depth_factor = 1000.0;
  Eigen::Isometry3d body_from_camera = Eigen::Isometry3d::Identity();
  body_from_camera.translation() = Eigen::Vector3d(0.01, -0.02, 0.03);
  camera.groundtruth_body_from_camera = body_from_camera;
  return camera;
}

// A keyframe with random features and images of the test camera's size.
SessionKeyframeBlocks RandomKeyframe(int id, std::mt19937* random, cv::Mat* depth_m,
                                     cv::Mat* color) {
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  SessionKeyframeBlocks blocks;
  SessionKeyframe& keyframe = blocks.keyframe;
  keyframe.id = id;
  keyframe.time = 100.0 + id * 0.5;
  keyframe.map_from_camera.linear() =
      Eigen::AngleAxisd(0.3 * id, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  keyframe.map_from_camera.translation() = Eigen::Vector3d(0.1 * id, -0.2, 1.5);
  keyframe.features.resize(10 + static_cast<size_t>(id));
  for (SessionFeature& f : keyframe.features) {
    f.u = 64 * uniform(*random);
    f.v = 48 * uniform(*random);
    f.x = uniform(*random) - 0.5f;
    f.y = uniform(*random) - 0.5f;
    f.depth_m = 4 * uniform(*random);
    f.octave = static_cast<std::uint8_t>(8 * uniform(*random));
    for (auto& byte : f.descriptor) byte = static_cast<std::uint8_t>(256 * uniform(*random));
  }
  const double unit = 0.001;
  cv::Mat depth(48, 64, CV_16UC1);
  cv::randu(depth, 0, 5000);
  depth.convertTo(*depth_m, CV_32F, unit);
  *color = cv::Mat(48, 64, CV_8UC3, cv::Scalar(10 * id, 100, 200));
  cv::imencode(".png", depth, blocks.depth_png);
  cv::imencode(".jpg", *color, blocks.color_jpeg, {cv::IMWRITE_JPEG_QUALITY, 100});
  return blocks;
}

SessionRecord TestRecord() {
  SessionRecord record;
  record.camera = TestCamera();
  record.depth_unit_m = 0.001;
  record.sequence = "/data/room";
  record.stillmap_version = "1.2.3";
  record.poses = "tf:odom, the tracker's prior";
  record.map_frame.name = "floor";
  record.map_frame.description = "floor frame";
  record.map_frame.floor_up = Eigen::Vector3d(0.0, 0.6, 0.8);
  record.map_frame.floor_offset = 1.25;
  record.map_frame.floor_found = true;
  record.map_frame.floor_source = "fitted";
  record.map_frame.map_from_floor.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);
  return record;
}

std::vector<unsigned char> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void WriteBytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

std::string ErrorOf(const std::string& path) {
  try {
    SessionRecordReader reader(path);
    for (size_t i = 0; i < reader.record().keyframes.size(); ++i) reader.ReadImages(i);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

class SessionRecordTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 random(7);
    for (int id = 0; id < 3; ++id) {
      cv::Mat depth_m, color;
      blocks_.push_back(RandomKeyframe(id * 4, &random, &depth_m, &color));
      depths_.push_back(depth_m);
      colors_.push_back(color);
    }
    WriteSessionRecord(path_, TestRecord(), blocks_);
  }

  TempDir dir_;
  std::string path_ = dir_.path() + "/session.bin";
  std::vector<SessionKeyframeBlocks> blocks_;
  std::vector<cv::Mat> depths_, colors_;
};

TEST_F(SessionRecordTest, WhatIsWrittenReadsBack) {
  SessionRecordReader reader(path_);
  const SessionRecord& record = reader.record();
  const SessionRecord expected = TestRecord();
  EXPECT_EQ(record.camera.width, 64);
  EXPECT_EQ(record.camera.fx, 50.0);
  EXPECT_EQ(record.camera.distortion, expected.camera.distortion);
  ASSERT_TRUE(record.camera.groundtruth_body_from_camera.has_value());
  EXPECT_TRUE(record.camera.groundtruth_body_from_camera->isApprox(
      *expected.camera.groundtruth_body_from_camera));
  EXPECT_EQ(record.sequence, "/data/room");
  EXPECT_EQ(record.stillmap_version, "1.2.3");
  EXPECT_EQ(record.poses, "tf:odom, the tracker's prior");
  EXPECT_EQ(record.depth_unit_m, 0.001);
  EXPECT_EQ(record.map_frame.name, "floor");
  EXPECT_TRUE(record.map_frame.floor_up.isApprox(expected.map_frame.floor_up));
  EXPECT_EQ(record.map_frame.floor_offset, 1.25);
  EXPECT_TRUE(record.map_frame.map_from_floor.isApprox(expected.map_frame.map_from_floor));
  ASSERT_EQ(record.keyframes.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    const SessionKeyframe& got = record.keyframes[k];
    const SessionKeyframe& want = blocks_[k].keyframe;
    EXPECT_EQ(got.id, want.id);
    EXPECT_EQ(got.time, want.time);
    EXPECT_TRUE(got.map_from_camera.isApprox(want.map_from_camera, 1e-12));
    ASSERT_EQ(got.features.size(), want.features.size());
    for (size_t i = 0; i < got.features.size(); ++i) {
      EXPECT_EQ(got.features[i].u, want.features[i].u);
      EXPECT_EQ(got.features[i].y, want.features[i].y);
      EXPECT_EQ(got.features[i].depth_m, want.features[i].depth_m);
      EXPECT_EQ(got.features[i].octave, want.features[i].octave);
      EXPECT_EQ(got.features[i].descriptor, want.features[i].descriptor);
    }
    const SessionImages images = reader.ReadImages(k);
    EXPECT_EQ(cv::norm(images.depth_m, depths_[k], cv::NORM_INF), 0.0);
    EXPECT_LE(cv::norm(images.color, colors_[k], cv::NORM_INF), 2.0);  // JPEG at quality 100
  }
}

// The keyframes parked in a temporary file and written one at a time give the same file, byte
// for byte, and read back whole.
TEST_F(SessionRecordTest, ParkedKeyframesWriteTheSameFile) {
  SessionKeyframeList list;
  for (const SessionKeyframeBlocks& blocks : blocks_) list.Add(blocks);
  ASSERT_EQ(list.size(), 3u);
  EXPECT_TRUE(list.keyframe(1).features.empty());  // in the file, not in memory
  const std::string parked = dir_.path() + "/parked.bin";
  list.Write(parked, TestRecord());
  EXPECT_EQ(ReadBytes(parked), ReadBytes(path_));
  const SessionKeyframeBlocks loaded = list.Load(2);
  EXPECT_EQ(loaded.depth_png, blocks_[2].depth_png);
  EXPECT_EQ(loaded.color_jpeg, blocks_[2].color_jpeg);
  ASSERT_EQ(loaded.keyframe.features.size(), blocks_[2].keyframe.features.size());
  EXPECT_EQ(loaded.keyframe.features.back().descriptor,
            blocks_[2].keyframe.features.back().descriptor);
  EXPECT_EQ(loaded.keyframe.features.back().depth_m, blocks_[2].keyframe.features.back().depth_m);
}

TEST_F(SessionRecordTest, AnotherVersionIsRefusedByName) {
  std::vector<unsigned char> bytes = ReadBytes(path_);
  bytes[16] = 2;  // the version's low byte
  WriteBytes(path_, bytes);
  EXPECT_NE(ErrorOf(path_).find("format version 2, but this stillmap reads version 1"),
            std::string::npos)
      << ErrorOf(path_);
}

TEST_F(SessionRecordTest, ForeignFileIsNotASessionRecord) {
  WriteBytes(path_, {'P', 'K', 3, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                     0,   0,   0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_NE(ErrorOf(path_).find("not a stillmap session record"), std::string::npos);
  EXPECT_NE(
      ErrorOf(dir_.path() + "/missing.bin").find("cannot open the session record: no such file"),
      std::string::npos);
}

// Every cut of the file and many damaged copies: an InputError naming the file, never a crash or
// a record that reads as complete.
TEST_F(SessionRecordTest, DamagedCopiesAreErrorsNamingTheFile) {
  const std::vector<unsigned char> bytes = ReadBytes(path_);
  const std::string damaged = dir_.path() + "/damaged.bin";
  for (size_t cut = 0; cut < bytes.size(); cut += 97) {
    WriteBytes(damaged, std::vector<unsigned char>(bytes.begin(), bytes.begin() + cut));
    EXPECT_NE(ErrorOf(damaged).find(damaged), std::string::npos) << "cut at " << cut;
  }
  std::mt19937 random(11);
  for (int copy = 0; copy < 300; ++copy) {
    std::vector<unsigned char> changed = bytes;
    const size_t at = std::uniform_int_distribution<size_t>(0, 900)(random);  // preamble, header
    changed[at] = static_cast<unsigned char>(random());
    WriteBytes(damaged, changed);
    const std::string error = ErrorOf(damaged);
    if (!error.empty()) {
      EXPECT_NE(error.find(damaged), std::string::npos) << error;
    }
  }
}

}  // namespace
}  // namespace stillmap
