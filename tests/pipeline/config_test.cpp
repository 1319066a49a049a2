#include "stillmap/pipeline/config.h"

#include <gtest/gtest.h>

#include "stillmap/io/error.h"
#include "test_util.h"

namespace stillmap {
namespace {

using testing::ErrorOf;

TEST(ConfigTest, DefaultsAreTheDesignDefaults) {
  const BuildConfig config;
  EXPECT_DOUBLE_EQ(config.mapping.voxel.leaf_size, 0.01);
  EXPECT_DOUBLE_EQ(config.mapping.occupancy.resolution, 0.05);
  EXPECT_DOUBLE_EQ(config.mapping.back_projection.min_depth, 0.1);
  EXPECT_DOUBLE_EQ(config.mapping.back_projection.max_depth, 4.0);
  EXPECT_DOUBLE_EQ(config.sequence.max_pair_time_difference, 0.02);
  EXPECT_NO_THROW(config.Validate());
}

TEST(ConfigTest, SetArgumentsReachTheirFields) {
  BuildConfig config;
  ApplySetArgument(&config, "mapping.voxel_leaf_size=0.02");
  ApplySetArgument(&config, "octomap.enabled=false");
  ApplySetArgument(&config, "camera.preset=tum1");
  ApplySetArgument(&config, "camera.distortion=[0.1,0,0,0,0]");
  ApplySetArgument(&config, "sequence.max_frames=30");
  EXPECT_DOUBLE_EQ(config.mapping.voxel.leaf_size, 0.02);
  EXPECT_FALSE(config.mapping.occupancy.enabled);
  EXPECT_EQ(config.camera.preset, "tum1");
  EXPECT_DOUBLE_EQ((*config.camera.distortion)[0], 0.1);
  EXPECT_EQ(config.max_frames, 30u);
}

TEST(ConfigTest, UnknownKeysAndBadValuesAreNamed) {
  BuildConfig config;
  const std::string unknown = ErrorOf([&] { ApplySetArgument(&config, "mapping.voxel_size=1"); });
  EXPECT_NE(unknown.find("unknown configuration key 'mapping.voxel_size'"), std::string::npos);
  EXPECT_NE(unknown.find("mapping.voxel_leaf_size"),
            std::string::npos);  // lists the section's keys
  EXPECT_EQ(unknown.find("tracking."), std::string::npos);
  EXPECT_NE(ErrorOf([&] { ApplySetArgument(&config, "maping.voxel=1"); }).find("mapping.*"),
            std::string::npos);  // an unknown section: the sections
  EXPECT_NE(ErrorOf([&] {
              ApplySetArgument(&config, "mapping.voxel_leaf_size=big");
            }).find("expected a finite number"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { ApplySetArgument(&config, "novalue"); }).find("key=value"),
            std::string::npos);
  EXPECT_NE(
      ErrorOf([&] { ApplySetArgument(&config, "camera.preset=kinect9"); }).find("unknown preset"),
      std::string::npos);
  ApplySetArgument(&config, "mapping.max_depth=0.05");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("mapping.max_depth"), std::string::npos);
}

// Each detector's input size and thresholds under their own keys, each checked and named.
TEST(ConfigTest, DetectorOptionsAreCheckedUnderTheirOwnKeys) {
  BuildConfig config;
  ApplySetArgument(&config, "detector.fastest_input_width=416");
  ApplySetArgument(&config, "detector.input_width=320");
  EXPECT_EQ(config.fastest.input_width, 416);
  EXPECT_EQ(config.yolox.input_width, 320);
  EXPECT_NO_THROW(config.Validate());
  ApplySetArgument(&config, "detector.fastest_input_height=250");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("detector.fastest_input_height"),
            std::string::npos);
  config = BuildConfig();
  ApplySetArgument(&config, "detector.fastest_coarse_input_width=0");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("detector.fastest_coarse_input_width"),
            std::string::npos);
  ApplySetArgument(&config, "detector.fastest_coarse_input_height=0");
  EXPECT_NO_THROW(config.Validate());
  ApplySetArgument(&config, "detector.fastest_coarse_input_width=352");
  ApplySetArgument(&config, "detector.fastest_coarse_input_height=128");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("detector.fastest_coarse_input_width"),
            std::string::npos);
  config = BuildConfig();
  ApplySetArgument(&config, "detector.fastest_score_threshold=1.5");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("detector.fastest_score_threshold"),
            std::string::npos);
  config = BuildConfig();
  ApplySetArgument(&config, "masking.high_static_share=0");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("high_static_share"), std::string::npos);
}

// The final poses' dense refinement: its keys reach their fields, bad values are named.
TEST(ConfigTest, DenseRefinementOptionsAreCheckedUnderTheirKeys) {
  BuildConfig config;
  EXPECT_TRUE(config.final_poses.enabled);  // on by default
  ApplySetArgument(&config, "final_poses.dense_enabled=false");
  ApplySetArgument(&config, "final_poses.dense_cycle_max_m=0.005");
  ApplySetArgument(&config, "final_poses.dense_span_drift_share=0.05");
  ApplySetArgument(&config, "final_poses.dense_span_rotation_drift_deg_per_m=0.2");
  EXPECT_FALSE(config.final_poses.enabled);
  EXPECT_DOUBLE_EQ(config.final_poses.cycle_max_m, 0.005);
  EXPECT_DOUBLE_EQ(config.final_poses.span_drift_share, 0.05);
  EXPECT_DOUBLE_EQ(config.final_poses.span_rotation_drift_deg_per_m, 0.2);
  EXPECT_NO_THROW(config.Validate());
  ApplySetArgument(&config, "final_poses.dense_cell_px=0");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("final_poses.dense_cell_px"),
            std::string::npos);
  config = BuildConfig();
  EXPECT_EQ(config.final_poses.coarse_cell_px, 0);
  ApplySetArgument(&config, "final_poses.dense_coarse_cell_px=8");
  EXPECT_NO_THROW(config.Validate());
  ApplySetArgument(&config, "final_poses.dense_coarse_cell_px=4");  // not coarser than the cells
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("final_poses.dense_coarse_cell_px"),
            std::string::npos);
  ApplySetArgument(&config, "final_poses.dense_coarse_cell_px=0");  // none
  EXPECT_NO_THROW(config.Validate());
  config = BuildConfig();
  ApplySetArgument(&config, "final_poses.dense_revisit_pairs=-1");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("final_poses.dense_revisit_pairs"),
            std::string::npos);
  config = BuildConfig();
  ApplySetArgument(&config, "final_poses.dense_max_change_deg=-0.5");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("final_poses.dense_max_change_deg"),
            std::string::npos);
  config = BuildConfig();
  ApplySetArgument(&config, "final_poses.dense_frame_smoothing_s=-1");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("final_poses.dense_frame_smoothing_s"),
            std::string::npos);
  for (const char* bad :
       {"final_poses.dense_span_drift_share=-0.1", "final_poses.dense_span_sigma_m=0",
        "final_poses.dense_span_rotation_sigma_deg=0", "final_poses.dense_max_span_keyframes=1",
        "final_poses.dense_anew_sigma_m=-0.01"}) {
    config = BuildConfig();
    ApplySetArgument(&config, bad);
    const std::string key = std::string(bad).substr(0, std::string(bad).find('='));
    EXPECT_NE(ErrorOf([&] { config.Validate(); }).find(key), std::string::npos) << bad;
  }
}

TEST(ConfigTest, TrajectorySmoothingIsReadAndCheckedUnderItsKeys) {
  BuildConfig config;
  ApplySetArgument(&config, "final_poses.smoothing_s=0.3");
  ApplySetArgument(&config, "final_poses.rotation_smoothing_s=0");
  EXPECT_DOUBLE_EQ(config.trajectory_smoothing.position_s, 0.3);
  EXPECT_DOUBLE_EQ(config.trajectory_smoothing.rotation_s, 0.0);
  EXPECT_NO_THROW(config.Validate());
  ApplySetArgument(&config, "final_poses.rotation_smoothing_s=-0.1");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("final_poses.rotation_smoothing_s"),
            std::string::npos);
  config = BuildConfig();
  ApplySetArgument(&config, "final_poses.smoothing_s=11");
  EXPECT_NE(ErrorOf([&] { config.Validate(); }).find("final_poses.smoothing_s"), std::string::npos);
}

TEST(ConfigTest, FileErrorsNameTheLine) {
  testing::TempDir dir;
  testing::WriteText(dir / "c.yaml", "mapping:\n  voxel_leaf_size: 0.02\n  voxel_size: 3\n");
  BuildConfig config;
  const std::string error = ErrorOf([&] { ApplyConfigFile(&config, dir / "c.yaml"); });
  EXPECT_NE(error.find("c.yaml:3"), std::string::npos) << error;
}

TEST(ConfigTest, EffectiveConfigurationReadsBackToTheSameConfiguration) {
  testing::TempDir dir;
  BuildConfig config;
  ApplySetArgument(&config, "mapping.voxel_leaf_size=0.025");
  ApplySetArgument(&config, "camera.fx=500");
  ApplySetArgument(&config, "camera.distortion=0.1,0.2,0,0,0.3");
  ApplySetArgument(&config, "octomap.max_range=3.5");
  const std::string yaml = ConfigToYaml(config);
  testing::WriteText(dir / "config.yaml", yaml);
  BuildConfig read_back;
  ApplyConfigFile(&read_back, dir / "config.yaml");
  EXPECT_EQ(ConfigToYaml(read_back), yaml);
  EXPECT_DOUBLE_EQ(read_back.mapping.voxel.leaf_size, 0.025);
  EXPECT_DOUBLE_EQ(*read_back.camera.fx, 500.0);
}

// Whole numbers are checked against their field's type: no wrap-around (4294968496 is not read
// as 1200 features, 4294967297 not as a stride of 1).
TEST(ConfigTest, WholeNumbersOutsideTheirTypeAreRefused) {
  BuildConfig config;
  EXPECT_THROW(ApplySetArgument(&config, "tracking.max_features=4294968496"), InputError);
  EXPECT_THROW(ApplySetArgument(&config, "mapping.pixel_stride=4294967297"), InputError);
  EXPECT_THROW(ApplySetArgument(&config, "sequence.first_frame=-1"), InputError);
  EXPECT_THROW(ApplySetArgument(&config, "sequence.max_frames=1e30"), InputError);
  EXPECT_THROW(ApplySetArgument(&config, "mapping.pixel_stride=2.5"), InputError);
  ApplySetArgument(&config, "mapping.pixel_stride=2147483647");
  EXPECT_EQ(config.mapping.back_projection.pixel_stride, 2147483647);
  ApplySetArgument(&config, "sequence.max_frames=1e3");
  EXPECT_EQ(config.max_frames, 1000u);
}
}  // namespace
}  // namespace stillmap
