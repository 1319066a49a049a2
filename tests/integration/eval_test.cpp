// `stillmap eval` through the binary: the ATE of a trajectory perturbed by a known rigid transform
// and known noise, recomputed here independently of the library.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "stillmap/io/trajectory.h"
#include "test_util.h"

namespace stillmap {
namespace {

TEST(EvalCommandTest, ReproducesTheAteOfAKnownPerturbation) {
  testing::TempDir dir;
  std::vector<StampedPose> truth, estimate;
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.linear() = Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  moved.translation() = Eigen::Vector3d(-4, 2, 1);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<Eigen::Vector3d> offsets;
  for (int i = 0; i < 1500; ++i) {
    const double t = i / 30.0;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(std::sin(0.3 * t), 0.5 * std::cos(0.2 * t), 0.1 * t);
    truth.push_back({t, pose});
    const Eigen::Vector3d offset(noise(rng), noise(rng), noise(rng));
    offsets.push_back(offset);
    Eigen::Isometry3d noisy = pose;
    noisy.translation() += offset;
    estimate.push_back({t + 0.004, moved * noisy});
  }
  Trajectory(truth).WriteTum(dir / "gt.txt");
  Trajectory(estimate).WriteTum(dir / "est.txt");
  // With the true alignment the error is the injected noise; the optimal alignment can only be
  // slightly better.
  double sum = 0.0;
  for (const auto& o : offsets) sum += o.squaredNorm();
  const double injected_rmse = std::sqrt(sum / offsets.size());

  std::string output;
  ASSERT_EQ(testing::RunStillmap("eval " + (dir / "gt.txt") + " " + (dir / "est.txt") +
                                     " --json --plot " + (dir / "plot.png"),
                                 &output),
            0)
      << output;
  const nlohmann::json json = nlohmann::json::parse(output);
  const double ate = json["ate_m"]["rmse"].get<double>();
  EXPECT_EQ(json["ate_m"]["count"], 1500);
  EXPECT_LE(ate, injected_rmse + 1e-9);
  EXPECT_GT(ate, 0.995 * injected_rmse);
  EXPECT_EQ(cv::imread(dir / "plot.png").cols, 1000);

  ASSERT_EQ(testing::RunStillmap("eval " + (dir / "gt.txt") + " " + (dir / "est.txt"), &output), 0);
  EXPECT_NE(output.find("ATE"), std::string::npos);
  EXPECT_NE(output.find("RPE"), std::string::npos);
}

TEST(EvalCommandTest, NonOverlappingTrajectoriesAreBadInput) {
  testing::TempDir dir;
  testing::WriteText(dir / "a.txt", "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n3 0 0 0 0 0 0 1\n");
  testing::WriteText(dir / "b.txt", "11 0 0 0 0 0 0 1\n12 0 0 0 0 0 0 1\n13 0 0 0 0 0 0 1\n");
  std::string output;
  EXPECT_EQ(testing::RunStillmap("eval " + (dir / "a.txt") + " " + (dir / "b.txt"), &output), 2);
  EXPECT_NE(output.find("associate"), std::string::npos) << output;
}

}  // namespace
}  // namespace stillmap
