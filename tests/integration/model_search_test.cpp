// The detectors' models for a new user: scripts/fetch-models installs them from a local copy of
// the shared models (nothing downloaded in a test) only when every file matches the checksum that
// the model's PROVENANCE.txt gives; `stillmap info` then finds them in the user's data folder and
// names the default detector; a tampered copy installs nothing and names the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "test_util.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;

bool SameBytes(const std::string& a, const std::string& b) {
  return testing::ReadText(a) == testing::ReadText(b);
}

class FetchModelsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::optional<std::string> models = testing::SharedModels("yolox_nano");
    if (!models || !testing::SharedModels("yolo_fastest_1.1")) {
      GTEST_SKIP() << "yolox_nano or yolo_fastest_1.1 not in ../shared/models";
    }
    shared_ = *models;
    yolox_ = shared_ + "/yolox_nano";
    fastest_ = shared_ + "/yolo_fastest_1.1";
  }
  int Fetch(const std::string& from, const std::string& dest, std::string* output) const {
    return testing::RunCommand(
        std::string(STILLMAP_FETCH_MODELS) + " --from '" + from + "' --dest '" + dest + "'",
        output);
  }
  std::string yolox_, fastest_, shared_;
  testing::TempDir dir_;
};

TEST_F(FetchModelsTest, PinsTheChecksumsOfTheProvenance) {
  const std::string script = testing::ReadText(STILLMAP_FETCH_MODELS);
  const std::regex line(R"((\S+)\s+size=(\d+) bytes\s+sha256=([0-9a-f]{64}))");
  size_t files = 0;
  for (const std::string& folder : {yolox_, fastest_}) {
    const std::string provenance = testing::ReadText(folder + "/PROVENANCE.txt");
    for (auto it = std::sregex_iterator(provenance.begin(), provenance.end(), line);
         it != std::sregex_iterator(); ++it, ++files) {
      EXPECT_NE(script.find((*it)[3].str()), std::string::npos) << (*it)[1] << "'s sha256";
      EXPECT_NE(script.find((*it)[2].str() + ", \"" + (*it)[3].str()), std::string::npos)
          << (*it)[1] << "'s size";
    }
  }
  EXPECT_EQ(files, 5u);  // yolox_nano.onnx, coco.names; the Yolo-Fastest cfg, weights, coco.names
}

TEST_F(FetchModelsTest, InstallsIntoTheUserDataFolderWhereInfoFindsIt) {
  const std::string data = dir_ / "data";
  std::string output;
  ASSERT_EQ(Fetch(shared_, data + "/stillmap/models", &output), 0) << output;
  for (const char* file : {"yolox_nano.onnx", "coco.names"}) {
    EXPECT_TRUE(SameBytes(data + "/stillmap/models/yolox_nano/" + file, yolox_ + "/" + file));
  }
  for (const char* file : {"yolo-fastest-1.1.cfg", "yolo-fastest-1.1.weights", "coco.names"}) {
    EXPECT_TRUE(
        SameBytes(data + "/stillmap/models/yolo_fastest_1.1/" + file, fastest_ + "/" + file));
  }
  ASSERT_EQ(Fetch(shared_, data + "/stillmap/models", &output), 0) << output;
  EXPECT_NE(output.find("already there"), std::string::npos) << output;
  const std::optional<std::string> sequence = testing::SharedSequence("tum_fr3_teddy_200");
  if (!sequence) GTEST_SKIP() << "tum_fr3_teddy_200 not in ../shared/data";
  ASSERT_EQ(testing::RunStillmap("info " + *sequence, &output,
                                 "env -u STILLMAP_MODELS XDG_DATA_HOME=" + data),
            0)
      << output;
  EXPECT_NE(output.find("detector:   yolo-fastest+yolox (models in " + data +
                        "/stillmap/models, found through user data folder)"),
            std::string::npos)
      << output;
}

TEST_F(FetchModelsTest, ATamperedCopyInstallsNothing) {
  const std::string copy = dir_ / "copy";
  fs::create_directories(copy);
  fs::copy(fastest_, copy + "/yolo_fastest_1.1", fs::copy_options::recursive);
  fs::create_directories(copy + "/yolox_nano");
  fs::copy_file(yolox_ + "/yolox_nano.onnx", copy + "/yolox_nano/yolox_nano.onnx");
  testing::WriteText(copy + "/yolox_nano/coco.names",
                     testing::ReadText(yolox_ + "/coco.names") + "unicorn\n");
  const std::string dest = dir_ / "dest";
  std::string output;
  EXPECT_NE(Fetch(copy, dest, &output), 0);
  EXPECT_NE(output.find("coco.names does not match its pinned checksum"), std::string::npos)
      << output;
  EXPECT_FALSE(fs::exists(dest + "/yolox_nano/yolox_nano.onnx"));
  EXPECT_FALSE(fs::exists(dest + "/yolox_nano/coco.names"));
  EXPECT_FALSE(fs::exists(dest + "/yolo_fastest_1.1"));  // never half of the models
}

}  // namespace
}  // namespace stillmap
