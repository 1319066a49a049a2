// A bag's topics judged by their messages (issue 49), on copies of the shared Jazzy teddy bag
// edited with SQLite: a bad message costs only itself (a 0x0 image ahead of the good ones, a
// message recorded twice, negative stamps, stamps that jump back), a CameraInfo that changes is
// named, stamps that are all equal are refused at the start, a bag without CameraInfo builds when
// the camera is given, and a refusal keeps what the reading met.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "bag/ros_messages.h"
#include "bag_test_util.h"
#include "stillmap/io/error.h"
#include "stillmap/io/sequence.h"
#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

// The Jazzy layout's topic ids.
constexpr int kColorInfo = 1, kDepth = 4;

class BagStreamsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::optional<std::string> folder = testing::SharedBag("teddy_tum_jazzy_db3");
    if (!folder) GTEST_SKIP() << "bags/teddy_tum_jazzy_db3 not in ../shared/data";
    bag_ = dir_ / "teddy.db3";
    fs::copy_file(*folder + "/teddy_tum_jazzy_db3_0.db3", bag_);
    intact_frames_ = Sequence::OpenBag(bag_, {}, {}).frames().size();
  }
  // Runs `sql` on the copy.
  void Execute(const std::string& sql) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(bag_.c_str(), &db), SQLITE_OK);
    char* error = nullptr;
    EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK)
        << (error != nullptr ? error : "");
    sqlite3_free(error);
    sqlite3_close(db);
  }
  // Adds a message on `topic_id` recorded at `time_ns`.
  void Insert(int topic_id, std::int64_t time_ns, const std::vector<std::uint8_t>& data) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(bag_.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* insert = nullptr;
    sqlite3_prepare_v2(db, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", -1,
                       &insert, nullptr);
    sqlite3_bind_int(insert, 1, topic_id);
    sqlite3_bind_int64(insert, 2, time_ns);
    sqlite3_bind_blob(insert, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(insert), SQLITE_DONE);
    sqlite3_finalize(insert);
    sqlite3_close(db);
  }
  std::string ErrorOf(const CameraOverrides& overrides = {}) {
    try {
      Sequence::OpenBag(bag_, overrides, {});
    } catch (const InputError& error) {
      return error.what();
    }
    return "(no error)";
  }
  testing::TempDir dir_;
  std::string bag_;
  size_t intact_frames_ = 0;
};

// A sensor_msgs/Image with no pixels (0x0), stamped at `stamp_s`.
std::vector<std::uint8_t> EmptyImage(std::uint32_t stamp_s) {
  Cdr cdr;
  cdr.U32(stamp_s);
  cdr.U32(0);
  cdr.String("openni_depth_optical_frame");
  cdr.U32(0);  // height
  cdr.U32(0);  // width
  cdr.String("16UC1");
  cdr.U8(0);   // is_bigendian
  cdr.U32(0);  // step
  cdr.U32(0);  // data: no bytes
  return cdr.bytes();
}

TEST_F(BagStreamsTest, AnEmptyImageAheadOfTheGoodOnesCostsOnlyItself) {
  Insert(kDepth, 1341841873000000000, EmptyImage(1341841872));
  const Sequence sequence = Sequence::OpenBag(bag_, {}, {});
  EXPECT_EQ(sequence.frames().size(), intact_frames_);
  ASSERT_EQ(sequence.warnings().size(), 1u);
  EXPECT_NE(sequence.warnings()[0].find("1 of 22 messages on /camera/depth/image are left out"),
            std::string::npos)
      << sequence.warnings()[0];
}

TEST_F(BagStreamsTest, MessagesRecordedTwiceAreLeftOutAtTheStart) {
  Execute(
      "INSERT INTO messages (topic_id, timestamp, data) SELECT topic_id, timestamp, data "
      "FROM messages WHERE topic_id IN (2, 4)");
  const Sequence sequence = Sequence::OpenBag(bag_, {}, {});
  EXPECT_EQ(sequence.frames().size(), intact_frames_);
  ASSERT_EQ(sequence.warnings().size(), 2u);
  EXPECT_NE(sequence.warnings()[0].find("20 of 40 messages on /camera/rgb/image_color/compressed "
                                        "repeat the header stamp"),
            std::string::npos)
      << sequence.warnings()[0];
}

TEST_F(BagStreamsTest, AFileListedTwiceInTheMetadataIsReadOnce) {
  const std::string folder = dir_ / "twice";
  fs::copy(*testing::SharedBag("teddy_tum_jazzy_db3"), folder);
  std::string metadata = testing::ReadText(folder + "/metadata.yaml");
  const std::string entry = "    - teddy_tum_jazzy_db3_0.db3\n";
  const size_t at = metadata.find(entry);
  ASSERT_NE(at, std::string::npos);
  metadata.insert(at, "    - ./teddy_tum_jazzy_db3_0.db3\n");
  testing::WriteText(folder + "/metadata.yaml", metadata);
  const Sequence sequence = Sequence::OpenBag(folder, {}, {});
  EXPECT_EQ(sequence.frames().size(), intact_frames_);
  ASSERT_EQ(sequence.warnings().size(), 1u);
  EXPECT_NE(sequence.warnings()[0].find("metadata.yaml: relative_file_paths lists "
                                        "teddy_tum_jazzy_db3_0.db3 more than once; it is read "
                                        "once"),
            std::string::npos)
      << sequence.warnings()[0];
}

TEST_F(BagStreamsTest, StampsAllEqualAreRefusedNamingTheTopic) {
  // Every colour message's header stamp set to one time (sec and nanosec after the CDR header).
  Execute(
      "UPDATE messages SET data = substr(data, 1, 4) || x'0000000000000000' || "
      "substr(data, 13) WHERE topic_id = 2");
  const std::string error = ErrorOf();
  EXPECT_NE(error.find("every message on /camera/rgb/image_color/compressed has the same header "
                       "stamp"),
            std::string::npos)
      << error;
}

// The header stamp's seconds (after the CDR header) of the last `count` messages on `topic_id`,
// as SQL that sets them to `seconds` (little-endian int32).
std::string SetLastSeconds(int topic_id, int count, std::int32_t seconds) {
  char hex[9];
  const auto bits = static_cast<std::uint32_t>(seconds);
  std::snprintf(hex, sizeof(hex), "%02x%02x%02x%02x", bits & 0xff, (bits >> 8) & 0xff,
                (bits >> 16) & 0xff, bits >> 24);
  const std::string topic = std::to_string(topic_id);
  return "UPDATE messages SET data = substr(data, 1, 4) || x'" + std::string(hex) +
         "' || substr(data, 9) WHERE id IN (SELECT id FROM messages WHERE topic_id = " + topic +
         " ORDER BY timestamp DESC LIMIT " + std::to_string(count) + ")";
}

TEST_F(BagStreamsTest, NegativeStampsAreLeftOutAndCounted) {
  Execute(SetLastSeconds(2, 3, -5));
  const Sequence sequence = Sequence::OpenBag(bag_, {}, {});
  EXPECT_EQ(sequence.frames().size(), intact_frames_ - 3);
  ASSERT_EQ(sequence.warnings().size(), 1u);
  EXPECT_NE(sequence.warnings()[0].find("3 of 20 messages on /camera/rgb/image_color/compressed "
                                        "have a negative header stamp and are left out"),
            std::string::npos)
      << sequence.warnings()[0];
}

TEST_F(BagStreamsTest, StampsThatJumpBackAreLeftOutNamingTheJump) {
  // The clock reset 870 s back for the last five colour and depth images.
  const double last = Sequence::OpenBag(bag_, {}, {}).frames().back().time;
  Execute(SetLastSeconds(2, 5, 1341841000));
  Execute(SetLastSeconds(kDepth, 5, 1341841000));
  const Sequence sequence = Sequence::OpenBag(bag_, {}, {});
  EXPECT_EQ(sequence.frames().size(), intact_frames_ - 5);
  for (const FrameEntry& frame : sequence.frames()) EXPECT_GT(frame.time, 1341841800.0);
  EXPECT_LT(sequence.frames().back().time, last);
  ASSERT_EQ(sequence.warnings().size(), 2u);
  EXPECT_NE(sequence.warnings()[0].find("5 of 20 messages on /camera/rgb/image_color/compressed "
                                        "are stamped back in time and left out (the header stamp "
                                        "goes back from 13418418"),
            std::string::npos)
      << sequence.warnings()[0];
  EXPECT_NE(sequence.warnings()[0].find(" to 13418410"), std::string::npos)
      << sequence.warnings()[0];
}

TEST_F(BagStreamsTest, ACameraInfoThatChangesIsNamed) {
  // A colour CameraInfo near the end with fx 50 px more.
  std::vector<std::uint8_t> later;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(bag_.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* select = nullptr;
    sqlite3_prepare_v2(db, "SELECT data, timestamp FROM messages WHERE topic_id = 1 LIMIT 1", -1,
                       &select, nullptr);
    ASSERT_EQ(sqlite3_step(select), SQLITE_ROW);
    const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(select, 0));
    later.assign(data, data + sqlite3_column_bytes(select, 0));
    sqlite3_finalize(select);
    sqlite3_close(db);
  }
  RosCameraInfo info;
  std::string decode_error;
  ASSERT_TRUE(DecodeRosCameraInfo(later.data(), later.size(), BagSerialization::kCdr, &info,
                                  &decode_error));
  const double fx = info.k[0], changed = info.k[0] + 50.0;
  const auto* fx_bytes = reinterpret_cast<const std::uint8_t*>(&fx);
  const auto at = std::search(later.begin(), later.end(), fx_bytes, fx_bytes + 8);
  ASSERT_NE(at, later.end()) << "fx not in the CameraInfo";
  std::memcpy(&*at, &changed, 8);
  Insert(kColorInfo, 1341841873900000000, later);
  const Sequence sequence = Sequence::OpenBag(bag_, {}, {});
  ASSERT_EQ(sequence.warnings().size(), 1u);
  EXPECT_NE(sequence.warnings()[0].find("the CameraInfo on /camera/rgb/camera_info changes"),
            std::string::npos)
      << sequence.warnings()[0];
}

TEST_F(BagStreamsTest, ABagWithoutCameraInfoBuildsWithThePresetOrTheKeys) {
  Execute("DELETE FROM messages WHERE topic_id IN (1, 3)");
  EXPECT_NE(ErrorOf().find("no camera info beside the colour topic"), std::string::npos);
  CameraOverrides preset;
  preset.preset = "tum3";
  const Sequence with_preset = Sequence::OpenBag(bag_, preset, {});
  EXPECT_EQ(with_preset.frames().size(), intact_frames_);
  EXPECT_EQ(with_preset.camera().fx, CameraPreset("tum3").fx);
  EXPECT_EQ(with_preset.camera().depth_factor, 1000.0);  // 16UC1 is millimetres (REP 118)
  CameraOverrides keys;
  keys.fx = 530.0, keys.fy = 531.0, keys.cx = 320.5, keys.cy = 240.5;
  const Sequence with_keys = Sequence::OpenBag(bag_, keys, {});
  EXPECT_EQ(with_keys.camera().fx, 530.0);
  EXPECT_EQ(with_keys.camera().cy, 240.5);
  EXPECT_EQ(with_keys.camera().width, 640);  // the JPEG colour images' own size
  EXPECT_EQ(with_keys.camera().height, 480);
  EXPECT_EQ(with_keys.LoadFrame(0).color.cols, 640);
}

// Every colour message without an image: the refusal says what the reading met.
TEST_F(BagStreamsTest, ARefusalKeepsWhatTheReadingMet) {
  Execute("UPDATE messages SET data = substr(data, 1, 40) WHERE topic_id = 2");
  const std::string error = ErrorOf();
  EXPECT_NE(error.find("no colour stream"), std::string::npos) << error;
  EXPECT_NE(error.find("Reading the bag met:"), std::string::npos) << error;
  EXPECT_NE(error.find("20 of 20 messages on /camera/rgb/image_color/compressed are left out"),
            std::string::npos)
      << error;
}

// A .db3 cut short at any of these lengths is refused or read up to the cut in the bag's words
// (the file cut short, the database damaged), never SQLite's own text.
TEST_F(BagStreamsTest, ACutShortDatabaseIsSaidInTheBagsWords) {
  const auto size = fs::file_size(bag_);
  for (const double share : {0.002, 0.01, 0.1, 0.5, 0.9}) {
    const std::string cut = dir_ / "cut.db3";
    fs::copy_file(bag_, cut, fs::copy_options::overwrite_existing);
    fs::resize_file(cut, static_cast<std::uintmax_t>(share * static_cast<double>(size)));
    std::string said;
    try {
      const Sequence sequence = Sequence::OpenBag(cut, {}, {});
      for (const std::string& warning : sequence.warnings()) said += warning + "\n";
    } catch (const InputError& error) {
      said = error.what();
    }
    EXPECT_NE(said.find("cut short"), std::string::npos) << share << ": " << said;
    for (const char* library : {"malformed", "no such table", "not a database"}) {
      EXPECT_EQ(said.find(library), std::string::npos) << share << ": " << said;
    }
  }
}

}  // namespace
}  // namespace stillmap
