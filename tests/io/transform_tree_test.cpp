#include "stillmap/io/transform_tree.h"

#include <gtest/gtest.h>

#include <cmath>

#include "stillmap/io/error.h"

namespace stillmap {
namespace {

TransformSample Sample(const std::string& parent, const std::string& child, double stamp,
                       const Eigen::Vector3d& translation, double yaw_rad = 0.0) {
  TransformSample sample;
  sample.parent = parent;
  sample.child = child;
  sample.stamp = stamp;
  sample.translation = translation;
  sample.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
  return sample;
}

void Add(TransformTree* tree, const TransformSample& sample, bool is_static) {
  std::string why;
  ASSERT_TRUE(tree->Add(sample, is_static, &why)) << why;
}

// A robot driving along x and turning about z at constant rates: odom -> base_link sampled at
// 0, 1 and 2 s; the camera 0.2 m ahead and 0.5 m up on /tf_static, looking along x.
TransformTree RobotTree() {
  TransformTree tree;
  for (const double t : {0.0, 1.0, 2.0}) {
    Add(&tree, Sample("/odom", "/base_link", t, {t, 0.0, 0.0}, 0.4 * t), false);
  }
  Add(&tree, Sample("base_link", "camera", 0.0, {0.2, 0.0, 0.5}), true);
  return tree;
}

TEST(TransformTreeTest, ChainsEdgesAndInterpolatesEachAtTheStamp) {
  const TransformTree tree = RobotTree();
  EXPECT_EQ(tree.Chain("odom", "camera", "test"), "odom -> base_link -> camera");
  // At 1.5 s the base is at x = 1.5, turned 0.6 rad: the camera lies 0.2 m ahead of it along
  // the turned x axis, 0.5 m up (worked out by hand, not with the tree's own interpolation).
  const std::optional<Eigen::Isometry3d> odom_from_camera =
      tree.Lookup("odom", "/camera", 1.5, 1.5, nullptr);
  ASSERT_TRUE(odom_from_camera);
  const Eigen::Vector3d expected(1.5 + 0.2 * std::cos(0.6), 0.2 * std::sin(0.6), 0.5);
  EXPECT_LT((odom_from_camera->translation() - expected).norm(), 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(odom_from_camera->linear()).angle(), 0.6, 1e-12);
  // The other way round is the inverse; a sample's own stamp is the sample.
  const std::optional<Eigen::Isometry3d> camera_from_odom =
      tree.Lookup("camera", "odom", 1.5, 1.5, nullptr);
  ASSERT_TRUE(camera_from_odom);
  EXPECT_TRUE(
      (*camera_from_odom * *odom_from_camera).isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  const std::optional<Eigen::Isometry3d> at_sample =
      tree.Lookup("odom", "base_link", 2.0, 0.1, nullptr);
  ASSERT_TRUE(at_sample);
  EXPECT_NEAR(at_sample->translation().x(), 2.0, 1e-15);
}

TEST(TransformTreeTest, NeverExtrapolatesNorBridgesAWideGap) {
  const TransformTree tree = RobotTree();
  LookupMiss miss;
  EXPECT_FALSE(tree.Lookup("odom", "camera", -0.25, 5.0, &miss));
  EXPECT_EQ(miss.kind, LookupMiss::Kind::kBefore);
  EXPECT_DOUBLE_EQ(miss.seconds, 0.25);
  EXPECT_EQ(miss.edge, "odom -> base_link");
  EXPECT_FALSE(tree.Lookup("odom", "camera", 2.5, 5.0, &miss));
  EXPECT_EQ(miss.kind, LookupMiss::Kind::kAfter);
  EXPECT_DOUBLE_EQ(miss.seconds, 0.5);
  EXPECT_FALSE(tree.Lookup("odom", "camera", 0.5, 0.9, &miss));  // samples 1 s apart
  EXPECT_EQ(miss.kind, LookupMiss::Kind::kGap);
  EXPECT_DOUBLE_EQ(miss.seconds, 1.0);
  const auto [first, last] = tree.Span("odom", "camera");
  EXPECT_EQ(first, 0.0);
  EXPECT_EQ(last, 2.0);
  // A static edge alone holds at any time.
  EXPECT_TRUE(tree.Lookup("base_link", "camera", 1e9, 0.1, nullptr));
}

TEST(TransformTreeTest, SaysWhichFramesItHasAndWhichTreesDoNotMeet) {
  TransformTree tree = RobotTree();
  Add(&tree, Sample("map", "other", 0.0, {0, 0, 0}), true);
  try {
    tree.Chain("odom", "camera_rgb_optical_frame", "bag.mcap");
    FAIL() << "a frame not in the tree was chained";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bag.mcap: frame 'camera_rgb_optical_frame' is not in the transform tree"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("base_link, camera, map, odom, other"), std::string::npos) << what;
  }
  try {
    tree.Chain("other", "camera", "bag.mcap");
    FAIL() << "two trees were chained";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("two trees"), std::string::npos) << what;
    EXPECT_NE(what.find("rooted at 'map' and 'odom'"), std::string::npos) << what;
  }
}

TEST(TransformTreeTest, RefusesWhatIsNotARigidMotionOrASecondParent) {
  TransformTree tree = RobotTree();
  std::string why;
  TransformSample broken = Sample("odom", "base_link", 3.0, {0, 0, 0});
  broken.rotation.coeffs() *= 2.0;
  EXPECT_FALSE(tree.Add(broken, false, &why));
  EXPECT_NE(why.find("not a rigid motion"), std::string::npos) << why;
  broken = Sample("odom", "base_link", 3.0, {NAN, 0, 0});
  EXPECT_FALSE(tree.Add(broken, false, &why));
  EXPECT_FALSE(tree.Add(Sample("map", "base_link", 3.0, {0, 0, 0}), false, &why));
  EXPECT_NE(why.find("a frame has one parent"), std::string::npos) << why;
  EXPECT_FALSE(tree.Add(Sample("", "base_link", 3.0, {0, 0, 0}), false, &why));
  // None of them changed the tree: the base still ends at 2 s.
  EXPECT_EQ(tree.Span("odom", "camera").second, 2.0);
}

TEST(TransformTreeTest, SamplesArriveInAnyOrderAndALaterRepeatWins) {
  TransformTree tree;
  Add(&tree, Sample("odom", "base_link", 2.0, {2, 0, 0}), false);
  Add(&tree, Sample("odom", "base_link", 0.0, {0, 0, 0}), false);
  Add(&tree, Sample("odom", "base_link", 1.0, {5, 0, 0}), false);
  Add(&tree, Sample("odom", "base_link", 1.0, {1, 0, 0}), false);
  const std::optional<Eigen::Isometry3d> pose = tree.Lookup("odom", "base_link", 1.5, 1.0, nullptr);
  ASSERT_TRUE(pose);
  EXPECT_NEAR(pose->translation().x(), 1.5, 1e-12);
}

}  // namespace
}  // namespace stillmap
