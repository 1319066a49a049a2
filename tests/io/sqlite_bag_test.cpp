// ROS 2 sqlite3 bags as rosbag2 lays them out (../shared/data/bags: a Humble-style folder with
// compressedDepth and a Jazzy-style one), read back against the sequence they were written from;
// a bag split over two files (made here from the shared one with SQLite) reads as the one it was
// split from, with or without its metadata.yaml; a file cut short says "truncated".
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/imgcodecs.hpp>

#include "bag/ros_messages.h"
#include "bag_test_util.h"
#include "stillmap/io/error.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

constexpr char kRealsenseDb3[] = "teddy_realsense_db3";
constexpr char kDepthTopic[] = "/camera/camera/aligned_depth_to_color/image_raw/compressedDepth";

// Runs `sql` on the database at `path` (written, unlike the reader's immutable view).
void Execute(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  const int status = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error);
  EXPECT_EQ(status, SQLITE_OK) << (error != nullptr ? error : "");
  sqlite3_free(error);
  sqlite3_close(db);
}

class SqliteBagTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::optional<std::string> sequence = testing::SharedSequence("tum_fr3_teddy_200");
    const std::optional<std::string> folder = testing::SharedBag(kRealsenseDb3);
    if (!sequence || !folder) GTEST_SKIP() << "teddy or bags/" << kRealsenseDb3 << " not shared";
    sequence_ = *sequence;
    folder_ = *folder;
  }
  std::string sequence_, folder_;
};

TEST_F(SqliteBagTest, FolderAndLoneFileGiveTheSequencesDepth) {
  const auto depths = ListOf(sequence_, "depth.txt");
  for (const std::string& path : {folder_, folder_ + "/teddy_realsense_db3_0.db3"}) {
    ASSERT_TRUE(LooksLikeBag(path)) << path;
    const std::unique_ptr<BagReader> bag = OpenBag(path);
    ASSERT_EQ(bag->serialization(), BagSerialization::kCdr);
    const Scanned scanned = ScanAll(*bag);
    EXPECT_FALSE(bag->truncated()) << path;
    EXPECT_TRUE(bag->warnings().empty()) << path;
    EXPECT_EQ(scanned.data.at("/camera/camera/color/image_raw/compressed").size(), 30u);
    const auto& depth = scanned.data.at(kDepthTopic);
    ASSERT_EQ(depth.size(), 31u);
    for (const auto& bytes : depth) {
      RosCompressedImage image;
      std::string error;
      ASSERT_TRUE(DecodeRosCompressedImage(bytes.data(), bytes.size(), BagSerialization::kCdr,
                                           &image, &error))
          << error;
      cv::Mat truth;
      cv::imread(sequence_ + "/" + depths.at(Stamp(image.header.stamp)), cv::IMREAD_UNCHANGED)
          .convertTo(truth, CV_32F, 1.0 / 5000.0);
      EXPECT_LE(cv::norm(DepthFromRosCompressed(image, 0.001, "test"), truth, cv::NORM_INF),
                0.0005 + 1e-6);  // millimetres in the PNG
    }
    EXPECT_EQ(bag->Read(scanned.by_topic.at(kDepthTopic).back().position), depth.back());
  }
}

TEST_F(SqliteBagTest, JazzyLayoutReads) {
  const std::optional<std::string> folder = testing::SharedBag("teddy_tum_jazzy_db3");
  if (!folder) GTEST_SKIP() << "bags/teddy_tum_jazzy_db3 not shared";
  const std::unique_ptr<BagReader> bag = OpenBag(*folder);
  const Scanned scanned = ScanAll(*bag);
  EXPECT_EQ(scanned.data.at("/camera/rgb/image_color/compressed").size(), 20u);
  EXPECT_EQ(scanned.data.at("/camera/depth/image").size(), 21u);
}

// The shared bag split at a row into NAME_0.db3 and NAME_1.db3: every message once, in order.
TEST_F(SqliteBagTest, ASplitBagReadsAsTheBagItWasSplitFrom) {
  const std::unique_ptr<BagReader> whole = OpenBag(folder_);
  const Scanned expected = ScanAll(*whole);
  testing::TempDir dir;
  const fs::path split = fs::path(dir.path()) / "split";
  fs::create_directories(split);
  const std::string source = folder_ + "/teddy_realsense_db3_0.db3";
  fs::copy_file(source, split / "split_0.db3");
  fs::copy_file(source, split / "split_1.db3");
  Execute((split / "split_0.db3").string(), "DELETE FROM messages WHERE id > 40");
  Execute((split / "split_1.db3").string(), "DELETE FROM messages WHERE id <= 40");
  std::ofstream(split / "metadata.yaml") << "rosbag2_bagfile_information:\n"
                                            "  version: 5\n  storage_identifier: sqlite3\n"
                                            "  relative_file_paths:\n"
                                            "    - split_0.db3\n    - split_1.db3\n";
  for (const bool with_metadata : {true, false}) {
    if (!with_metadata) fs::remove(split / "metadata.yaml");
    ASSERT_TRUE(LooksLikeBag(split.string()));
    const std::unique_ptr<BagReader> bag = OpenBag(split.string());
    const Scanned scanned = ScanAll(*bag);
    EXPECT_EQ(scanned.data, expected.data);
    EXPECT_EQ(bag->warnings().size(), with_metadata ? 0u : 1u);
    if (!with_metadata) {
      EXPECT_NE(bag->warnings()[0].find("no metadata.yaml"), std::string::npos);
    }
    const auto& depth = scanned.by_topic.at(kDepthTopic);
    EXPECT_EQ(depth.front().position.part, 0u);
    EXPECT_EQ(depth.back().position.part, 1u);
    EXPECT_EQ(bag->Read(depth.front().position), scanned.data.at(kDepthTopic).front());
    EXPECT_EQ(bag->Read(depth.back().position), scanned.data.at(kDepthTopic).back());
  }
}

TEST_F(SqliteBagTest, AFileCutShortReadsWhatItHoldsAndSaysTruncated) {
  testing::TempDir dir;
  const std::string cut = dir / "cut.db3";
  fs::copy_file(folder_ + "/teddy_realsense_db3_0.db3", cut);
  fs::resize_file(cut, fs::file_size(cut) * 6 / 10);
  const std::unique_ptr<BagReader> bag = OpenBag(cut);
  const Scanned scanned = ScanAll(*bag);
  EXPECT_TRUE(bag->truncated());
  ASSERT_FALSE(bag->warnings().empty());
  EXPECT_NE(bag->warnings().back().find("truncated"), std::string::npos);
  EXPECT_NE(bag->warnings().back().find("cut.db3"), std::string::npos);
  const auto depth = scanned.data.find(kDepthTopic);
  ASSERT_NE(depth, scanned.data.end());
  EXPECT_GT(depth->second.size(), 5u);
  EXPECT_LT(depth->second.size(), 31u);
}

// Rewrites the blobs of one topic's messages with `edit`.
void EditMessages(const std::string& path, int topic_id,
                  const std::function<void(std::vector<std::uint8_t>*)>& edit) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* select = nullptr;
  sqlite3_stmt* update = nullptr;
  sqlite3_prepare_v2(db, "SELECT id, data FROM messages WHERE topic_id = ?", -1, &select, nullptr);
  sqlite3_prepare_v2(db, "UPDATE messages SET data = ? WHERE id = ?", -1, &update, nullptr);
  sqlite3_bind_int(select, 1, topic_id);
  while (sqlite3_step(select) == SQLITE_ROW) {
    const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(select, 1));
    std::vector<std::uint8_t> bytes(data, data + sqlite3_column_bytes(select, 1));
    edit(&bytes);
    sqlite3_reset(update);
    sqlite3_bind_blob(update, 1, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(update, 2, sqlite3_column_int64(select, 0));
    EXPECT_EQ(sqlite3_step(update), SQLITE_DONE);
  }
  sqlite3_finalize(select);
  sqlite3_finalize(update);
  sqlite3_close(db);
}

void Replace(std::vector<std::uint8_t>* bytes, const std::string& text, const std::string& to) {
  const std::vector<std::uint8_t> from(text.begin(), text.end());  // bytes, not signed chars
  const auto at = std::search(bytes->begin(), bytes->end(), from.begin(), from.end());
  ASSERT_NE(at, bytes->end()) << from.size() << " bytes not in " << bytes->size();
  std::copy(to.begin(), to.end(), at);
}

std::string DoubleBytes(double value) {
  std::string bytes(sizeof(value), '\0');
  std::memcpy(bytes.data(), &value, sizeof(value));
  return bytes;
}

// The Jazzy teddy bag with its depth camera made another (frame /openni_dep_optical_frame, fx 540):
// refused without /tf_static, naming both frames; registered into colour with it.
TEST(SqliteBagRegistrationTest, DepthWithItsOwnCameraNeedsTfStaticAndIsRegisteredWithIt) {
  const std::optional<std::string> folder = testing::SharedBag("teddy_tum_jazzy_db3");
  if (!folder) GTEST_SKIP() << "bags/teddy_tum_jazzy_db3 not shared";
  testing::TempDir dir;
  const std::string bag = dir / "own_depth.db3";
  fs::copy_file(*folder + "/teddy_tum_jazzy_db3_0.db3", bag);
  EditMessages(bag, 3, [](std::vector<std::uint8_t>* bytes) {  // /camera/depth/camera_info
    Replace(bytes, "/openni_rgb_optical_frame", "/openni_dep_optical_frame");
    Replace(bytes, DoubleBytes(535.4), DoubleBytes(540.0));
  });
  try {
    Sequence::OpenBag(bag, {});
    ADD_FAILURE() << "depth with a camera of its own was taken without /tf_static";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("no /tf_static transform"), std::string::npos) << what;
    EXPECT_NE(what.find("/openni_dep_optical_frame"), std::string::npos) << what;
    EXPECT_NE(what.find("aligned_depth_to_color"), std::string::npos) << what;
  }
  Cdr tf;
  tf.U32(1);
  tf.U32(1341841873);
  tf.U32(0);
  tf.String("/openni_rgb_optical_frame");
  tf.String("/openni_dep_optical_frame");
  for (const double value : {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0}) tf.F64(value);
  Execute(bag,
          "INSERT INTO topics (id, name, type, serialization_format, offered_qos_profiles, "
          "type_description_hash) VALUES (9, '/tf_static', 'tf2_msgs/msg/TFMessage', 'cdr', "
          "'', '')");
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(bag.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* insert = nullptr;
  sqlite3_prepare_v2(db, "INSERT INTO messages (topic_id, timestamp, data) VALUES (9, 1, ?)", -1,
                     &insert, nullptr);
  sqlite3_bind_blob(insert, 1, tf.bytes().data(), static_cast<int>(tf.bytes().size()),
                    SQLITE_TRANSIENT);
  EXPECT_EQ(sqlite3_step(insert), SQLITE_DONE);
  sqlite3_finalize(insert);
  sqlite3_close(db);
  const Sequence sequence = Sequence::OpenBag(bag, {});
  bool said = false;
  for (const std::string& note : sequence.notes()) {
    said = said || note.find("registered into colour with /tf_static") != std::string::npos;
  }
  EXPECT_TRUE(said);
  const Frame frame = sequence.LoadFrame(0);
  ASSERT_EQ(frame.depth_m.size(), frame.color.size());
  // fx 540 against 535.4: the depth image shrinks about the centre by 0.85 %; its readings stay.
  const Frame as_recorded = Sequence::OpenBag(*folder, {}).LoadFrame(0);
  EXPECT_GT(cv::countNonZero(frame.depth_m), cv::countNonZero(as_recorded.depth_m) * 95 / 100);
  EXPECT_LT(cv::countNonZero(frame.depth_m), cv::countNonZero(as_recorded.depth_m) * 101 / 100);
}

TEST_F(SqliteBagTest, ABagWithoutDepthIsRefusedNamingDepthAndListingItsTopics) {
  testing::TempDir dir;
  const std::string bag = dir / "no_depth.db3";
  fs::copy_file(folder_ + "/teddy_realsense_db3_0.db3", bag);
  Execute(bag,
          "DELETE FROM messages WHERE topic_id IN (SELECT id FROM topics WHERE name LIKE "
          "'%depth%'); DELETE FROM topics WHERE name LIKE '%depth%'");
  try {
    Sequence::OpenBag(bag, {});
    ADD_FAILURE() << "a bag without depth was opened";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("no_depth.db3: no depth stream"), std::string::npos) << what;
    EXPECT_NE(what.find("/camera/camera/color/image_raw/compressed"), std::string::npos) << what;
    EXPECT_NE(what.find("30 messages"), std::string::npos) << what;
  }
}

TEST(SqliteBagOpenTest, ADatabaseThatIsNoBagAndABrokenFolderAreRefusedByName) {
  testing::TempDir dir;
  const std::string other = dir / "other.db3";
  Execute(other, "CREATE TABLE people(name TEXT)");
  ASSERT_TRUE(LooksLikeBag(other));
  try {
    OpenBag(other);
    ADD_FAILURE() << "an SQLite database without rosbag2's tables was opened";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("other.db3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a ROS 2 bag"), std::string::npos) << e.what();
  }
  const fs::path folder = fs::path(dir.path()) / "bag";
  fs::create_directories(folder);
  std::ofstream(folder / "metadata.yaml") << "rosbag2_bagfile_information:\n"
                                             "  relative_file_paths: [missing_0.db3]\n";
  try {
    OpenBag(folder.string());
    ADD_FAILURE() << "a folder naming a missing file was opened";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing_0.db3"), std::string::npos) << e.what();
  }
  std::ofstream(folder / "metadata.yaml") << "rosbag2_bagfile_information:\n"
                                             "  relative_file_paths: [.]\n";
  EXPECT_THROW(OpenBag(folder.string()), InputError);  // the folder itself: never recursed into
}

}  // namespace
}  // namespace stillmap
