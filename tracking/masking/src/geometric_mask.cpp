// GeometricMasker: paper 002's multi-view depth check of every current reading against the
// references, then growth from its seeds over continuous depth.
#include <algorithm>
#include <cmath>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "mask_growth.h"
#include "stillmap/io/image_regions.h"
#include "stillmap/tracking/dynamic_mask.h"

namespace stillmap {
namespace {

using mask_growth::Continuous;
using mask_growth::Grow;
using mask_growth::kCandidate;
using mask_growth::kConsistent;
using mask_growth::kNoVerdict;
using mask_growth::kSeed;

// What the verdicts against every reference share: the current depth and rays, and the
// thresholds from the options.
struct VerdictContext {
  const float* z;  // current depth [m], row-major
  int width, height;
  const std::vector<Eigen::Vector2f>& rays;
  const PixelProjection& project;
  const DynamicMaskOptions& options;
  float seed_difference, grow_difference, grow_sigmas, seed_factor, cos_limit, sin_limit;
};

// One reference's verdict on current readings. Each reading is placed in 3-D and looked up in the
// reference's nearest static depth `near`: where the reference saw farther than the point along
// the same ray, the point was not there then (the depth difference above tau_d, evaluated for
// every current pixel so that visibility is explicit); points outside the reference, where it had
// no reading or its own mask, or hidden behind a nearer surface there, get no verdict from it.
class Judge {
 public:
  Judge(const VerdictContext& c, const float* near, const Eigen::Isometry3f& reference_from_current)
      : rotation_(reference_from_current.linear()),
        centre_(reference_from_current.translation()),
        baseline_squared_(centre_.squaredNorm()),
        rays_(c.rays.data()),
        project_(c.project),
        near_(near),
        width_(c.width),
        height_(c.height),
        seed_difference_(c.seed_difference),
        grow_difference_(c.grow_difference),
        grow_sigmas_(c.grow_sigmas),
        seed_factor_(c.seed_factor),
        cos_limit_(c.cos_limit),
        sin_limit_squared_(c.sin_limit * c.sin_limit) {}

  // The verdict on current pixel i, whose reading is `depth` [m].
  std::uint8_t operator()(int i, float depth) const {
    const Eigen::Vector2f& ray = rays_[i];
    const Eigen::Vector3f q =
        rotation_ * Eigen::Vector3f(depth * ray.x(), depth * ray.y(), depth) + centre_;
    if (q.z() < 0.1f) return kNoVerdict;
    const Eigen::Vector2f pixel = project_(q.x() / q.z(), q.y() / q.z());
    const float pu = pixel.x() + 0.5f, pv = pixel.y() + 0.5f;
    if (!(pu >= 0.0f && pv >= 0.0f && pu < static_cast<float>(width_) &&
          pv < static_cast<float>(height_))) {
      return kNoVerdict;
    }
    const float seen = near_[static_cast<int>(pv) * width_ + static_cast<int>(pu)];
    if (!(seen > 0.0f)) return kNoVerdict;
    // Parallax: the angle at the point between the rays to the two camera centres. Its sine is
    // at most baseline / distance, so the exact test is needed only for near points.
    if (baseline_squared_ > sin_limit_squared_ * q.squaredNorm()) {
      const Eigen::Vector3f to_current = centre_ - q;
      const float cos_angle = (-q).dot(to_current) / (q.norm() * to_current.norm() + 1e-12f);
      if (cos_angle < cos_limit_) return kNoVerdict;
    }
    const float difference = seen - q.z();
    const float noise = grow_difference_ + grow_sigmas_ * KinectDepthSigma(q.z());
    // Far seeds must stand clear of the sensor noise too (options: seed_noise_factor).
    if (difference > std::max(seed_difference_, seed_factor_ * noise)) return kSeed;
    if (difference > noise) return kCandidate;
    if (difference > -noise) return kConsistent;
    return kNoVerdict;  // hidden behind a nearer surface in the reference
  }

 private:
  Eigen::Matrix3f rotation_;
  Eigen::Vector3f centre_;  // the current camera's centre in the reference
  float baseline_squared_;
  const Eigen::Vector2f* rays_;
  PixelProjection project_;
  const float* near_;
  int width_, height_;
  float seed_difference_, grow_difference_, grow_sigmas_, seed_factor_, cos_limit_,
      sin_limit_squared_;
};

// The strongest verdict of `judges` on current pixel i, whose reading is `depth` [m].
std::uint8_t Strongest(const std::vector<Judge>& judges, int i, float depth) {
  std::uint8_t strongest = kNoVerdict;
  for (const Judge& judge : judges) {
    strongest = std::max(strongest, judge(i, depth));
    if (strongest == kSeed) break;
  }
  return strongest;
}

// The verdicts of all `judges` on the blocks of rows `rows`, written into `s` (AddVerdicts). The
// readings continuous with a block's centre depend on no reference, so every reference is judged
// block by block and each pixel is visited once, not once per reference (perf: the pass per
// reference was 7 % of a bonn_crowd_a build). The loop's values are locals: the verdicts are
// stored through a byte pointer, which may alias anything.
void AddVerdictRows(const std::vector<Judge>& judges, const float* z, int width, int height,
                    int stride, float block_continuity, const cv::Range& rows, std::uint8_t* s) {
  for (int bv = rows.start * stride; bv < std::min(rows.end * stride, height); bv += stride) {
    const int v_end = std::min(bv + stride, height);
    const int centre_row = std::min(bv + stride / 2, v_end - 1);
    for (int bu = 0; bu < width; bu += stride) {
      const int u_end = std::min(bu + stride, width);
      const int centre_index = centre_row * width + std::min(bu + stride / 2, u_end - 1);
      const float centre_depth = z[centre_index];
      const bool centre_valid = centre_depth > 0.0f;
      const std::uint8_t centre_verdict =
          centre_valid ? Strongest(judges, centre_index, centre_depth) : std::uint8_t{kNoVerdict};
      // mask_growth::Continuous with the centre, its tolerance computed once per block.
      const float tolerance = 0.01f + block_continuity * centre_depth;
      for (int v = bv; v < v_end; ++v) {
        for (int i = v * width + bu, end = v * width + u_end; i < end; ++i) {
          const float depth = z[i];
          if (!(depth > 0.0f)) continue;
          s[i] = centre_valid && std::abs(centre_depth - depth) <= tolerance
                     ? centre_verdict
                     : Strongest(judges, i, depth);
        }
      }
    }
  }
}

// Every reference's verdicts on the current readings, written into `s` (the strongest wins; `s`
// holds kNoVerdict before). One verdict per stride x stride block, from its centre, for the
// readings continuous with the centre's; the others (object edges) are judged on their own. Rows
// of blocks are independent and run in parallel (the growth stays sequential; timings:
// stillmap_masking_benchmark).
void AddVerdicts(const VerdictContext& c, const std::vector<Judge>& judges, std::uint8_t* s) {
  if (judges.empty()) return;
  const int width = c.width, height = c.height, stride = c.options.depth_check_stride;
  const auto block_continuity = static_cast<float>(c.options.block_continuity);
  const int block_rows = (height + stride - 1) / stride;
  cv::parallel_for_(cv::Range(0, block_rows), [&](const cv::Range& rows) {
    AddVerdictRows(judges, c.z, width, height, stride, block_continuity, rows, s);
  });
}

// Grows `region` (its seeds set, listed in `queue`) over continuous readings not confirmed
// static; steps through pixels no reference judged are counted and bounded by
// options.max_unknown_steps.
void GrowFromSeeds(const cv::Mat& state, const float* z, const DynamicMaskOptions& options,
                   std::vector<int> queue, cv::Mat* region) {
  const std::uint8_t* s = state.data;
  std::vector<std::uint8_t> unknown_steps(state.total(), 0);
  const int max_steps = options.max_unknown_steps;
  const double continuity = options.continuity;
  Grow(region, std::move(queue), [&](int next, int from) {
    if (s[next] == kConsistent || !(z[next] > 0.0f) || !Continuous(z[from], z[next], continuity)) {
      return false;
    }
    if (s[next] != kNoVerdict) return true;
    const int steps = unknown_steps[static_cast<size_t>(from)] + 1;
    if (steps > max_steps) return false;
    unknown_steps[static_cast<size_t>(next)] = static_cast<std::uint8_t>(steps);
    return true;
  });
}

}  // namespace

GeometricMasker::GeometricMasker(const Camera& camera, const DynamicMaskOptions& options)
    : camera_(camera), options_(options), rays_(PixelRays(camera)) {}

cv::Mat GeometricMasker::Compute(const cv::Mat& depth_m, const Eigen::Isometry3d& world_from_camera,
                                 const std::vector<const MaskReference*>& references,
                                 const std::vector<cv::Point>& extra_seeds, int* depth_seeds,
                                 cv::Mat* consistent) const {
  CV_Assert(depth_m.type() == CV_32FC1 && depth_m.isContinuous());
  const int width = depth_m.cols, height = depth_m.rows;
  const PixelProjection project(camera_);
  const double parallax = options_.depth.max_parallax_deg * M_PI / 180.0;
  const VerdictContext context{depth_m.ptr<float>(),
                               width,
                               height,
                               rays_,
                               project,
                               options_,
                               static_cast<float>(options_.depth.max_depth_difference_m),
                               static_cast<float>(options_.grow_depth_difference_m),
                               static_cast<float>(options_.grow_noise_sigmas),
                               static_cast<float>(options_.seed_noise_factor),
                               static_cast<float>(std::cos(parallax)),
                               static_cast<float>(std::sin(parallax))};
  cv::Mat state(height, width, CV_8UC1, cv::Scalar(kNoVerdict));
  std::uint8_t* s = state.data;
  const float* z = context.z;
  std::vector<cv::Mat> nearest;  // kept alive for the judges
  std::vector<Judge> judges;
  for (const MaskReference* reference : references) {
    if (reference->depth_m.size() != depth_m.size()) continue;
    // The reference depth is the minimum over a 5x5 neighbourhood (one-pixel pose or edge errors
    // at thin objects are no evidence), cached in the reference when it was made.
    nearest.push_back(reference->nearest_depth_m.empty() ? NearestStaticDepth(*reference)
                                                         : reference->nearest_depth_m);
    judges.emplace_back(context, nearest.back().ptr<float>(),
                        (reference->world_from_camera.inverse() * world_from_camera).cast<float>());
  }
  AddVerdicts(context, judges, s);

  cv::Mat region(height, width, CV_8UC1, cv::Scalar(0));
  std::vector<int> queue;
  for (int i = 0; i < width * height; ++i) {
    if (s[i] == kSeed) {
      region.data[i] = 255;
      queue.push_back(i);
    }
  }
  if (depth_seeds != nullptr) *depth_seeds = static_cast<int>(queue.size());
  if (consistent != nullptr) *consistent = state == kConsistent;
  for (const cv::Point& seed : extra_seeds) {
    if (seed.x < 0 || seed.y < 0 || seed.x >= width || seed.y >= height) continue;
    const int i = seed.y * width + seed.x;
    if ((s[i] == kNoVerdict || s[i] == kCandidate) && z[i] > 0.0f && region.data[i] == 0) {
      region.data[i] = 255;
      queue.push_back(i);
    }
  }
  GrowFromSeeds(state, z, options_, std::move(queue), &region);
  DropSmallRegions(options_.min_region_px, &region);  // noise at depth edges, flow outliers
  return region;
}

}  // namespace stillmap
