// The bundle adjustment: with exact observations, perturbed poses and points go back to the truth
// and wrong observations are flagged. Joint depth self-calibration (issue 17): a known depth error
// over the image is recovered with the poses; a sensor without error gives an estimate that is not
// significant; a camera that does not move leaves the correction unseen. A global adjustment over
// a long path, solved sparse, gives the dense solver's solution.
#include "stillmap/tracking/bundle_adjustment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace stillmap {
namespace {

// The scenes' random numbers: uniform in [-1, 1] and standard normal, from one seeded generator.
struct Noise {
  explicit Noise(unsigned seed) : rng(seed) {}
  double Uniform() { return uniform(rng); }
  double Gauss() { return gauss(rng); }

  std::mt19937 rng;
  std::uniform_real_distribution<double> uniform{-1.0, 1.0};
  std::normal_distribution<double> gauss{0.0, 1.0};
};

struct Scene {
  BundleAdjustmentProblem problem;
  std::vector<Eigen::Isometry3d> true_poses;
};

// Landmark `landmark` at `point`, observed by every keyframe of `scene` that has it inside a
// 640x480 view, with image noise and inverse-depth noise of `sigma_inverse_depth`; raw depths
// carry `error` (z_raw = z / (1 + delta)).
void ObserveLandmark(int landmark, const Eigen::Vector3d& point, double sigma_inverse_depth,
                     const DepthCorrection& error, Noise& noise, Scene* scene) {
  for (size_t k = 0; k < scene->true_poses.size(); ++k) {
    const Eigen::Vector3d q = scene->true_poses[k] * point;
    const Eigen::Vector2d n = q.head<2>() / q.z();
    if (std::abs(n.x()) > 0.55 || std::abs(n.y()) > 0.42) continue;  // outside the view
    BundleAdjustmentObservation observation;
    observation.keyframe = static_cast<int>(k);
    observation.landmark = landmark;
    RgbdObservation& o = observation.observation;
    o.normalized = n + o.sigma_normalized * Eigen::Vector2d(noise.Gauss(), noise.Gauss());
    o.sigma_inverse_depth = sigma_inverse_depth;
    const double inverse_depth = 1.0 / q.z() + o.sigma_inverse_depth * noise.Gauss();
    o.depth_m = 1.0 / inverse_depth / error.Factor(n.x(), n.y());
    scene->problem.observations.push_back(observation);
  }
}

// Keyframes looking at points 2-4 m away; `motion` scales how far the camera moves and turns
// (0: every keyframe at the same place). Raw depths carry `error` (z_raw = z / (1 + delta)) and
// noise; the solve starts from perturbed poses and points and from no correction.
Scene MakeScene(double motion, const DepthCorrection& error, unsigned seed) {
  Noise noise(seed);
  Scene scene;
  BundleAdjustmentProblem& problem = scene.problem;
  for (int k = 0; k < 8; ++k) {
    Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
    const double a = motion * (k - 3.5) / 3.5;
    camera_from_world.linear() =
        (Eigen::AngleAxisd(0.25 * a, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(0.15 * a * (k % 2 ? 1 : -1), Eigen::Vector3d::UnitX()))
            .matrix();
    camera_from_world.translation() = Eigen::Vector3d(0.4 * a, 0.1 * a, 0.2 * a * (k % 3 - 1));
    scene.true_poses.push_back(camera_from_world);
    Eigen::Isometry3d start = camera_from_world;
    if (k > 0)
      start.translation() +=
          0.005 * Eigen::Vector3d(noise.Uniform(), noise.Uniform(), noise.Uniform());
    problem.keyframes.push_back({start, k == 0});
  }
  for (int i = 0; i < 600; ++i) {
    const Eigen::Vector3d point(2.0 * noise.Uniform(), 1.5 * noise.Uniform(),
                                3.0 + noise.Uniform());
    problem.landmarks.push_back(point +
                                0.01 * Eigen::Vector3d(noise.Uniform(), noise.Uniform(), 0.0));
    ObserveLandmark(i, point, 0.0025, error, noise, &scene);
  }
  problem.depth_correction = DepthCorrection{};
  return scene;
}

// The exact observation of a point at `in_camera` by keyframe `keyframe`, with its depth.
BundleAdjustmentObservation ExactObservation(int keyframe, int landmark,
                                             const Eigen::Vector3d& in_camera) {
  BundleAdjustmentObservation observation;
  observation.keyframe = keyframe;
  observation.landmark = landmark;
  observation.observation.normalized = in_camera.head<2>() / in_camera.z();
  observation.observation.depth_m = in_camera.z();
  return observation;
}

BundleAdjustmentOptions ManyIterations() {
  BundleAdjustmentOptions options;
  options.iterations_first = 30;
  options.iterations_second = 30;
  return options;
}

TEST(BundleAdjustmentTest, RecoversAKnownDepthErrorWithThePoses) {
  const DepthCorrection error{{0.02, 0.05, 0.14, -0.05, 0.15}};  // like the Bonn Xtion's
  Scene scene = MakeScene(1.0, error, 3);
  const BundleAdjustmentResult result = SolveBundleAdjustment(scene.problem, ManyIterations());
  ASSERT_TRUE(result.depth_correction.has_value());
  for (size_t c = 0; c < 5; ++c) {
    EXPECT_NEAR(result.depth_correction->coefficients[c], error.coefficients[c], 0.01) << c;
  }
  EXPECT_GT(result.depth_correction_significance, 1000.0);
  EXPECT_LT(result.depth_correction_weakest_sd, 0.05);
  // The camera centres: much nearer the truth than when the error is ignored.
  BundleAdjustmentProblem ignored = scene.problem;
  ignored.depth_correction.reset();
  const BundleAdjustmentResult uncorrected = SolveBundleAdjustment(ignored, ManyIterations());
  auto worst_centre_error = [&scene](const BundleAdjustmentResult& solved) {
    double worst = 0.0;
    for (size_t k = 1; k < scene.true_poses.size(); ++k) {
      const Eigen::Vector3d centre = solved.camera_from_world[k].inverse().translation();
      worst = std::max(worst, (centre - scene.true_poses[k].inverse().translation()).norm());
    }
    return worst;
  };
  EXPECT_LT(worst_centre_error(result), 0.01);
  EXPECT_LT(worst_centre_error(result), worst_centre_error(uncorrected) / 3.0)
      << worst_centre_error(uncorrected);
}

TEST(BundleAdjustmentTest, WithoutDepthErrorTheEstimateIsNotSignificant) {
  // Without error p' I p is chi-square with 5 degrees of freedom (99.9 %: 20.5), pose coupling
  // aside; the tracker takes an estimate from 200 on.
  for (unsigned seed : {1u, 2u, 3u}) {
    Scene scene = MakeScene(1.0, DepthCorrection{}, seed);
    const BundleAdjustmentResult result = SolveBundleAdjustment(scene.problem, ManyIterations());
    ASSERT_TRUE(result.depth_correction.has_value());
    EXPECT_LT(result.depth_correction_significance, 50.0) << seed;
    for (double c : result.depth_correction->coefficients) EXPECT_LT(std::abs(c), 0.01) << seed;
  }
}

TEST(BundleAdjustmentTest, ACameraThatDoesNotMoveLeavesTheCorrectionUnseen) {
  Scene scene = MakeScene(0.0, DepthCorrection{}, 4);
  const BundleAdjustmentResult result = SolveBundleAdjustment(scene.problem, ManyIterations());
  ASSERT_TRUE(result.depth_correction.has_value());
  EXPECT_GT(result.depth_correction_weakest_sd, 0.05);  // the tracker's limit
}

TEST(BundleAdjustmentTest, WithoutACorrectionToEstimateNoneIsReturned) {
  Scene scene = MakeScene(1.0, DepthCorrection{}, 5);
  scene.problem.depth_correction.reset();
  const BundleAdjustmentResult result = SolveBundleAdjustment(scene.problem, ManyIterations());
  EXPECT_FALSE(result.depth_correction.has_value());
}

// A camera moving 18 m along a wall, 120 keyframes 15 cm apart, each point seen by the keyframes
// within its view: the global adjustment of a corridor. Every pose but the first starts 1 cm and
// half a degree off.
Scene MakeCorridor() {
  Noise noise(6);
  Scene scene;
  BundleAdjustmentProblem& problem = scene.problem;
  for (int k = 0; k < 120; ++k) {
    Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
    world_from_camera.translation() = Eigen::Vector3d(0.15 * k, 0.0, 0.0);
    scene.true_poses.push_back(world_from_camera.inverse());
    Eigen::Isometry3d start = scene.true_poses.back();
    if (k > 0) {
      const Eigen::Vector3d axis(noise.Uniform(), noise.Uniform(), noise.Uniform());
      start.linear() *= Eigen::AngleAxisd(0.5 * M_PI / 180.0, axis.normalized()).matrix();
      start.translation() +=
          0.01 * Eigen::Vector3d(noise.Uniform(), noise.Uniform(), noise.Uniform());
    }
    problem.keyframes.push_back({start, k == 0});
  }
  for (int i = 0; i < 2500; ++i) {
    const Eigen::Vector3d point(9.0 + 10.0 * noise.Uniform(), 1.2 * noise.Uniform(),
                                2.5 + noise.Uniform());
    problem.landmarks.push_back(point +
                                0.02 * Eigen::Vector3d(noise.Uniform(), noise.Uniform(), 0.0));
    ObserveLandmark(i, point, RgbdObservation{}.sigma_inverse_depth, DepthCorrection{}, noise,
                    &scene);
  }
  return scene;
}

double TranslationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}

// Above dense_schur_max_poses free poses the sparse solver takes over: the same solution as the
// dense one, and the path's shape recovered (keyframe to keyframe; the whole path drifts a little
// from the fixed first keyframe, as any open path does).
TEST(BundleAdjustmentTest, ALongPathSolvedSparseAgreesWithTheDenseSolution) {
  const Scene scene = MakeCorridor();
  BundleAdjustmentOptions dense = ManyIterations();
  dense.dense_schur_max_poses = 1000;
  BundleAdjustmentOptions sparse = ManyIterations();
  ASSERT_LT(sparse.dense_schur_max_poses, 119);
  const BundleAdjustmentResult a = SolveBundleAdjustment(scene.problem, dense);
  const BundleAdjustmentResult b = SolveBundleAdjustment(scene.problem, sparse);
  ASSERT_EQ(a.camera_from_world.size(), scene.true_poses.size());
  ASSERT_EQ(b.camera_from_world.size(), scene.true_poses.size());
  std::vector<Eigen::Isometry3d> start;
  for (const auto& keyframe : scene.problem.keyframes) start.push_back(keyframe.camera_from_world);
  double start_step_error = 0.0, step_error = 0.0;
  for (size_t k = 0; k < scene.true_poses.size(); ++k) {
    EXPECT_LT(TranslationError(a.camera_from_world[k], b.camera_from_world[k]), 1e-6) << k;
    if (k == 0) continue;
    const auto step = [&](const std::vector<Eigen::Isometry3d>& poses) -> Eigen::Vector3d {
      return (poses[k] * poses[k - 1].inverse()).translation();
    };
    const Eigen::Vector3d truth = step(scene.true_poses);
    start_step_error = std::max(start_step_error, (step(start) - truth).norm());
    step_error = std::max(step_error, (step(b.camera_from_world) - truth).norm());
  }
  EXPECT_GT(start_step_error, 0.01);
  EXPECT_LT(step_error, 0.005);
  for (size_t i = 0; i < a.landmarks.size(); ++i) {
    EXPECT_LT((a.landmarks[i] - b.landmarks[i]).norm(), 1e-6) << i;
  }
}

// Bundle adjustment with exact observations: perturbed poses and points go back to the truth,
// the fixed keyframe stays put, and wrong observations are flagged.
TEST(BundleAdjustmentTest, RecoversTheTruthAndFlagsOutliers) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  BundleAdjustmentProblem problem;
  std::vector<Eigen::Isometry3d> true_poses;
  for (int k = 0; k < 4; ++k) {
    Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
    camera_from_world.linear() = Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitY()).matrix();
    camera_from_world.translation() = Eigen::Vector3d(-0.1 * k, 0.02 * k, 0.0);
    true_poses.push_back(camera_from_world);
    Eigen::Isometry3d perturbed = camera_from_world;
    if (k > 0) {
      perturbed.linear() =
          Eigen::AngleAxisd(0.01, Eigen::Vector3d(uniform(rng), uniform(rng), 1).normalized()) *
          perturbed.linear();
      perturbed.translation() += 0.02 * Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
    }
    problem.keyframes.push_back({perturbed, k == 0});
  }
  std::vector<Eigen::Vector3d> true_points;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d point(uniform(rng), 0.7 * uniform(rng), 3.0 + uniform(rng));
    true_points.push_back(point);
    problem.landmarks.push_back(point +
                                0.01 * Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)));
  }
  std::vector<bool> wrong;
  for (size_t k = 0; k < true_poses.size(); ++k) {
    for (size_t i = 0; i < true_points.size(); ++i) {
      BundleAdjustmentObservation observation = ExactObservation(
          static_cast<int>(k), static_cast<int>(i), true_poses[k] * true_points[i]);
      if (i % 3 == 0) observation.observation.depth_m = 0.0;  // some without depth
      // One wrong observation (a mismatch) in some landmarks, in one of the free keyframes.
      const bool is_wrong = i % 25 == 7 && k == 1 + (i / 25) % 3;
      if (is_wrong) observation.observation.normalized.x() += 0.04;  // 21 px off
      wrong.push_back(is_wrong);
      problem.observations.push_back(observation);
    }
  }
  // More iterations than the tracker's 5 + 10: this start is farther off than a new keyframe's.
  BundleAdjustmentOptions options;
  options.iterations_first = 20;
  options.iterations_second = 20;
  const BundleAdjustmentResult result = SolveBundleAdjustment(problem, options);
  EXPECT_LT(result.final_cost, result.initial_cost);
  for (size_t k = 0; k < true_poses.size(); ++k) {
    const Eigen::Isometry3d error = true_poses[k].inverse() * result.camera_from_world[k];
    EXPECT_LT(error.translation().norm(), 1e-6) << "keyframe " << k;
    EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle() * 180.0 / M_PI, 1e-5) << "keyframe " << k;
  }
  EXPECT_TRUE(result.camera_from_world[0].isApprox(problem.keyframes[0].camera_from_world));
  for (size_t i = 0; i < true_points.size(); ++i) {
    EXPECT_LT((result.landmarks[i] - true_points[i]).norm(), 1e-6) << "landmark " << i;
  }
  ASSERT_EQ(result.outlier.size(), wrong.size());
  for (size_t o = 0; o < wrong.size(); ++o) EXPECT_EQ(result.outlier[o], wrong[o]) << o;
}

// A keyframe seen by fewer landmarks than min_keyframe_observations keeps its pose: here its 5
// observations are of points that moved (a person), as if the camera stood 0.5 m to the side of
// where it is. The other keyframes still go back to the truth, the moved points' observations
// flagged. Without the rule the 5 points take the keyframe away.
TEST(BundleAdjustmentTest, AKeyframeSeenByTooFewLandmarksKeepsItsPose) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  BundleAdjustmentProblem problem;
  std::vector<Eigen::Isometry3d> true_poses;
  for (int k = 0; k < 4; ++k) {
    Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
    camera_from_world.translation() = Eigen::Vector3d(-0.1 * k, 0.0, 0.0);
    true_poses.push_back(camera_from_world);
    Eigen::Isometry3d start = camera_from_world;
    if (k > 0) start.translation() += 0.01 * Eigen::Vector3d(uniform(rng), uniform(rng), 0.0);
    problem.keyframes.push_back({start, k == 0});
  }
  const Eigen::Isometry3d weak_start = problem.keyframes[3].camera_from_world;
  problem.keyframes.push_back({weak_start, false});  // keyframe 4: where keyframe 3 was
  Eigen::Isometry3d seen_from = true_poses[3];
  seen_from.translation().x() += 0.5;  // what the moved points say
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d point(uniform(rng), 0.7 * uniform(rng), 3.0 + uniform(rng));
    problem.landmarks.push_back(point);
    for (int k = 0; k < 5; ++k) {
      if (k == 4 && i >= 5) continue;
      const Eigen::Isometry3d& pose = k == 4 ? seen_from : true_poses[static_cast<size_t>(k)];
      problem.observations.push_back(ExactObservation(k, i, pose * point));
    }
  }
  BundleAdjustmentOptions options = ManyIterations();
  ASSERT_GT(options.min_keyframe_observations, 5);
  const BundleAdjustmentResult held = SolveBundleAdjustment(problem, options);
  EXPECT_TRUE(held.camera_from_world[4].isApprox(weak_start));
  for (size_t k = 0; k < true_poses.size(); ++k) {
    EXPECT_LT(TranslationError(held.camera_from_world[k], true_poses[k]), 1e-6) << k;
  }
  for (size_t o = 0; o < problem.observations.size(); ++o) {
    EXPECT_EQ(held.outlier[o], problem.observations[o].keyframe == 4) << o;
  }
  options.min_keyframe_observations = 0;
  const BundleAdjustmentResult moved = SolveBundleAdjustment(problem, options);
  EXPECT_GT(TranslationError(moved.camera_from_world[4], weak_start), 0.1);
}

}  // namespace
}  // namespace stillmap
