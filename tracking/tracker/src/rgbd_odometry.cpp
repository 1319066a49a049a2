#include "stillmap/tracking/rgbd_odometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace stillmap {
namespace {

constexpr int kSmoothCells = 5;            // normals are averaged over this many cells squared
constexpr double kSmoothAngleDeg = 20.0;   // ... of those within this angle of each other
constexpr double kNormalContrast = 0.2;    // intensities' standard deviation after normalizing
constexpr double kMinContrast = 0.005;     // below this an image is flat
constexpr float kMaxRelativeStep = 0.05f;  // a neighbour off by more is across a depth edge

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

bool Usable(float z, const RgbdOdometryOptions& options) {
  return z > 0.0f && z <= static_cast<float>(options.max_depth_m) && std::isfinite(z);
}

// A frame reduced to cells: mean depth (0 where a cell is under half read, crosses a depth edge
// or holds an ignored pixel), mean intensity (0-1), its gradient per cell, and normals (unit,
// facing the camera, zero where there is none), each the mean of the raw ones within
// kSmoothCells cells so that the sensor's noise does not pass for structure.
struct CellFrame {
  cv::Mat depth;          // CV_32F [m]
  cv::Mat intensity;      // CV_32F
  cv::Mat gradient;       // CV_32FC2, d intensity / d (u, v)
  cv::Mat normals;        // CV_32FC3
  bool contrast = false;  // false: a flat image, no photometry
};

void AverageCells(const RgbdImages& images, int cell, const RgbdOdometryOptions& options,
                  CellFrame* frame) {
  const int rows = images.depth_m.rows / cell, columns = images.depth_m.cols / cell;
  frame->depth = cv::Mat(rows, columns, CV_32F, cv::Scalar(0.0));
  cv::resize(images.gray, frame->intensity, cv::Size(columns, rows), 0, 0, cv::INTER_AREA);
  frame->intensity.convertTo(frame->intensity, CV_32F, 1.0 / 255.0);
  for (int row = 0; row < rows; ++row) {
    for (int column = 0; column < columns; ++column) {
      float sum = 0.0f, low = std::numeric_limits<float>::max(), high = 0.0f;
      int count = 0;
      bool ignored = false;
      for (int v = row * cell; v < (row + 1) * cell; ++v) {
        const float* z = images.depth_m.ptr<float>(v);
        const std::uint8_t* mask =
            images.ignore_mask.empty() ? nullptr : images.ignore_mask.ptr<std::uint8_t>(v);
        for (int u = column * cell; u < (column + 1) * cell; ++u) {
          ignored = ignored || (mask != nullptr && mask[u] != 0);
          if (!Usable(z[u], options)) continue;
          sum += z[u];
          low = std::min(low, z[u]);
          high = std::max(high, z[u]);
          ++count;
        }
      }
      if (ignored || 2 * count < cell * cell) continue;
      const float mean = sum / static_cast<float>(count);
      if (high - low > kMaxRelativeStep * mean + 0.02f) continue;
      frame->depth.at<float>(row, column) = mean;
    }
  }
}

// The intensities of the cells with depth brought to mean 0.5 and standard deviation
// kNormalContrast, so that a change of exposure or gain between two frames is not taken for a
// change of view. False for an image without contrast: it adds no photometric residuals.
bool NormalizeContrast(const cv::Mat& depth, cv::Mat* intensity) {
  cv::Scalar mean, deviation;
  cv::meanStdDev(*intensity, mean, deviation, depth > 0.0f);
  if (deviation[0] < kMinContrast) {
    intensity->setTo(0.5);
    return false;
  }
  intensity->convertTo(*intensity, CV_32F, kNormalContrast / deviation[0],
                       0.5 - mean[0] * kNormalContrast / deviation[0]);
  return true;
}

// The camera-frame point of cell (u, v) of `depth`, which must read there.
Eigen::Vector3f CellPoint(const CellCamera& camera, const cv::Mat& depth, int u, int v) {
  const float z = depth.at<float>(v, u);
  const Eigen::Vector2f& ray = camera.Ray(u, v);
  return {ray.x() * z, ray.y() * z, z};
}

// The normal spanned by the four neighbours of cell (u, v), or zero at an edge or a hole.
cv::Vec3f RawNormal(const CellCamera& camera, const cv::Mat& depth, int u, int v) {
  const float z = depth.at<float>(v, u);
  for (const auto& [x, y] : {std::pair{u - 1, v}, {u + 1, v}, {u, v - 1}, {u, v + 1}}) {
    const float neighbour = depth.at<float>(y, x);
    if (neighbour <= 0.0f || std::abs(neighbour - z) > kMaxRelativeStep * z) return {};
  }
  const Eigen::Vector3f across =
      CellPoint(camera, depth, u + 1, v) - CellPoint(camera, depth, u - 1, v);
  const Eigen::Vector3f down =
      CellPoint(camera, depth, u, v + 1) - CellPoint(camera, depth, u, v - 1);
  Eigen::Vector3f normal = across.cross(down);
  const float length = normal.norm();
  if (length <= 0.0f) return {};
  normal /= length;
  if (normal.dot(CellPoint(camera, depth, u, v)) > 0.0f) normal = -normal;
  return {normal.x(), normal.y(), normal.z()};
}

// Each raw normal replaced by the mean of those within kSmoothCells cells that agree with it
// (within kSmoothAngleDeg): the noise averages out, a crease between two planes stays sharp.
void SmoothNormals(const cv::Mat& raw, cv::Mat* smooth) {
  *smooth = cv::Mat(raw.size(), CV_32FC3, cv::Scalar::all(0.0));
  const float min_cosine = static_cast<float>(std::cos(kSmoothAngleDeg * M_PI / 180.0));
  const int half = kSmoothCells / 2;
  for (int v = 0; v < raw.rows; ++v) {
    for (int u = 0; u < raw.cols; ++u) {
      const cv::Vec3f& centre = raw.at<cv::Vec3f>(v, u);
      if (centre == cv::Vec3f()) continue;
      cv::Vec3f sum;
      for (int y = std::max(0, v - half); y <= std::min(raw.rows - 1, v + half); ++y) {
        for (int x = std::max(0, u - half); x <= std::min(raw.cols - 1, u + half); ++x) {
          const cv::Vec3f& other = raw.at<cv::Vec3f>(y, x);
          if (other.dot(centre) >= min_cosine) sum += other;
        }
      }
      smooth->at<cv::Vec3f>(v, u) = sum / static_cast<float>(cv::norm(sum));
    }
  }
}

CellFrame MakeCellFrame(const CellCamera& camera, const RgbdImages& images,
                        const RgbdOdometryOptions& options) {
  CellFrame frame;
  AverageCells(images, camera.cell_px(), options, &frame);
  frame.contrast = NormalizeContrast(frame.depth, &frame.intensity);
  cv::Mat du, dv;
  cv::Sobel(frame.intensity, du, CV_32F, 1, 0, 1, 0.5);  // central differences
  cv::Sobel(frame.intensity, dv, CV_32F, 0, 1, 1, 0.5);
  cv::merge(std::vector<cv::Mat>{du, dv}, frame.gradient);
  cv::Mat raw(frame.depth.size(), CV_32FC3, cv::Scalar::all(0.0));
  for (int v = 1; v + 1 < raw.rows; ++v) {
    for (int u = 1; u + 1 < raw.cols; ++u) {
      if (frame.depth.at<float>(v, u) > 0.0f) {
        raw.at<cv::Vec3f>(v, u) = RawNormal(camera, frame.depth, u, v);
      }
    }
  }
  SmoothNormals(raw, &frame.normals);
  return frame;
}

// A current-frame cell with a point and a normal, and its intensity.
struct Sample {
  Eigen::Vector3f point;   // in the current camera
  Eigen::Vector3f normal;  // facing the camera
  float intensity;
};

std::vector<Sample> Samples(const CellCamera& camera, const CellFrame& frame) {
  std::vector<Sample> samples;
  for (int v = 0; v < frame.depth.rows; ++v) {
    for (int u = 0; u < frame.depth.cols; ++u) {
      const cv::Vec3f& normal = frame.normals.at<cv::Vec3f>(v, u);
      if (normal == cv::Vec3f()) continue;
      samples.push_back({CellPoint(camera, frame.depth, u, v),
                         Eigen::Vector3f(normal[0], normal[1], normal[2]),
                         frame.intensity.at<float>(v, u)});
    }
  }
  return samples;
}

// Bilinear intensity and gradient of `frame` at (x, y), cell units; false off the image.
bool Photometry(const CellFrame& frame, float x, float y, float* intensity,
                Eigen::Vector2f* gradient) {
  const int u = static_cast<int>(std::floor(x)), v = static_cast<int>(std::floor(y));
  if (u < 1 || v < 1 || u + 2 >= frame.intensity.cols || v + 2 >= frame.intensity.rows) {
    return false;
  }
  const float a = x - static_cast<float>(u), b = y - static_cast<float>(v);
  auto mix = [&](const cv::Mat& image, auto zero, auto get) {
    auto value = zero;
    value += (1 - a) * (1 - b) * get(image, u, v) + a * (1 - b) * get(image, u + 1, v);
    value += (1 - a) * b * get(image, u, v + 1) + a * b * get(image, u + 1, v + 1);
    return value;
  };
  *intensity =
      mix(frame.intensity, 0.0f, [](const cv::Mat& m, int c, int r) { return m.at<float>(r, c); });
  const cv::Vec2f g = mix(frame.gradient, cv::Vec2f(),
                          [](const cv::Mat& m, int c, int r) { return m.at<cv::Vec2f>(r, c); });
  *gradient = Eigen::Vector2f(g[0], g[1]);
  return true;
}

// One pass over the current cells at `reference_from_current`: the whitened normal equations
// (Huber-weighted) and, unweighted, the information they hold.
struct Pass {
  Matrix6 hessian = Matrix6::Zero();
  Vector6 gradient = Vector6::Zero();
  Matrix6 information = Matrix6::Zero();
  int paired = 0;
  int textured = 0;
  double squared_sum = 0.0;  // of the point-to-plane distances [m^2]
  // Sums for the correlation of the two frames' intensities over the textured cells.
  double sum_reference = 0.0, sum_current = 0.0, sum_reference_squared = 0.0,
         sum_current_squared = 0.0, sum_product = 0.0;
  double Correlation() const {
    if (textured < 2) return 1.0;
    const double n = textured;
    const double covariance = sum_product - sum_reference * sum_current / n;
    const double reference_variance = sum_reference_squared - sum_reference * sum_reference / n;
    const double current_variance = sum_current_squared - sum_current * sum_current / n;
    const double scale = std::sqrt(reference_variance * current_variance);
    return scale > 0.0 ? covariance / scale : 0.0;
  }
  double depth_sum = 0.0;
  void Add(const Vector6& row, double error, double sigma) {
    const double whitened = error / sigma;
    const double weight = std::abs(whitened) <= 2.0 ? 1.0 : 2.0 / std::abs(whitened);
    const Vector6 scaled = row / sigma;
    hessian.noalias() += weight * scaled * scaled.transpose();
    gradient.noalias() += weight * whitened * scaled;
    information.noalias() += scaled * scaled.transpose();
  }
};

// The photometric row of a point p (reference camera) whose intensity gradient there is `g`
// (per cell), with fx, fy of the cell camera.
Vector6 PhotometricRow(const Eigen::Vector3f& p, const Eigen::Vector2f& g, const Camera& cells) {
  const float z = p.z();
  const Eigen::Vector3f along(g.x() * static_cast<float>(cells.fx) / z,
                              g.y() * static_cast<float>(cells.fy) / z,
                              -(g.x() * static_cast<float>(cells.fx) * p.x() +
                                g.y() * static_cast<float>(cells.fy) * p.y()) /
                                  (z * z));
  Vector6 row;
  row.head<3>() = p.cross(along).cast<double>();
  row.tail<3>() = along.cast<double>();
  return row;
}

Pass Accumulate(const CellCamera& camera, const CellFrame& reference,
                const std::vector<Sample>& samples, const Eigen::Isometry3d& reference_from_current,
                double bound_m, bool photometric, const RgbdOdometryOptions& options) {
  const Eigen::Matrix3f rotation = reference_from_current.linear().cast<float>();
  const Eigen::Vector3f translation = reference_from_current.translation().cast<float>();
  const float min_cosine = static_cast<float>(std::cos(options.max_normal_angle_deg * M_PI / 180));
  const cv::Mat& depth = reference.depth;
  Pass pass;
  for (const Sample& sample : samples) {
    const Eigen::Vector3f p = rotation * sample.point + translation;
    if (p.z() <= 0.0f) continue;
    const Eigen::Vector2f pixel = camera.Project(p);
    const int u = static_cast<int>(std::lround(pixel.x()));
    const int v = static_cast<int>(std::lround(pixel.y()));
    if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) continue;
    const cv::Vec3f& normal = reference.normals.at<cv::Vec3f>(v, u);
    if (normal == cv::Vec3f()) continue;
    const Eigen::Vector3f n(normal[0], normal[1], normal[2]);
    const Eigen::Vector3f difference = p - CellPoint(camera, depth, u, v);
    if (difference.norm() > bound_m || (rotation * sample.normal).dot(n) < min_cosine) continue;
    const double error = n.dot(difference);
    Vector6 row;
    row.head<3>() = p.cross(n).cast<double>();
    row.tail<3>() = n.cast<double>();
    pass.Add(row, error, options.sigma_depth_m);
    ++pass.paired;
    pass.squared_sum += error * error;
    pass.depth_sum += p.z();
    // The same pair, photometrically: the reference's intensity where the point lands.
    float intensity = 0.0f;
    Eigen::Vector2f g;
    if (!photometric || !Photometry(reference, pixel.x(), pixel.y(), &intensity, &g) ||
        g.norm() < options.min_gradient) {
      continue;
    }
    pass.Add(PhotometricRow(p, g, camera.camera()), intensity - sample.intensity,
             options.sigma_intensity);
    ++pass.textured;
    pass.sum_reference += intensity;
    pass.sum_current += sample.intensity;
    pass.sum_reference_squared += intensity * intensity;
    pass.sum_current_squared += sample.intensity * sample.intensity;
    pass.sum_product += intensity * sample.intensity;
  }
  return pass;
}

// The standard deviation along the weakest direction of the pass's information, rotations
// scaled by the mean depth [m].
double WeakestSigma(const Pass& pass) {
  if (pass.paired == 0) return std::numeric_limits<double>::infinity();
  Vector6 scale = Vector6::Ones();
  scale.head<3>().setConstant(pass.paired / pass.depth_sum);
  const Matrix6 scaled = scale.asDiagonal() * pass.information * scale.asDiagonal();
  const double weakest = Eigen::SelfAdjointEigenSolver<Matrix6>(scaled, Eigen::EigenvaluesOnly)
                             .eigenvalues()
                             .minCoeff();
  return weakest > 0.0 ? 1.0 / std::sqrt(weakest) : std::numeric_limits<double>::infinity();
}

// T <- Exp(delta) T for the left perturbation p' = exp(w^) p + v, delta = [w, v].
Eigen::Isometry3d Update(const Vector6& delta, const Eigen::Isometry3d& transform) {
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  const double angle = delta.head<3>().norm();
  if (angle > 0.0) step.linear() = Eigen::AngleAxisd(angle, delta.head<3>() / angle).matrix();
  step.translation() = delta.tail<3>();
  return step * transform;
}

// The camera of images reduced by `cell`: the same distortion, the intrinsics scaled, pixel
// centres mapped onto cell centres.
Camera CoarseCamera(const Camera& camera, int cell) {
  Camera coarse = camera;
  coarse.width = camera.width / cell;
  coarse.height = camera.height / cell;
  coarse.fx = camera.fx / cell;
  coarse.fy = camera.fy / cell;
  coarse.cx = (camera.cx + 0.5) / cell - 0.5;
  coarse.cy = (camera.cy + 0.5) / cell - 0.5;
  return coarse;
}

}  // namespace

CellCamera::CellCamera(const Camera& camera, int cell_px)
    : camera_(CoarseCamera(camera, cell_px)),
      cell_px_(cell_px),
      rays_(PixelRays(camera_)),
      projection_(camera_) {}

RgbdAlignment AlignRgbd(const CellCamera& camera, const RgbdImages& reference,
                        const RgbdImages& current, const Eigen::Isometry3d& initial,
                        const RgbdOdometryOptions& options) {
  RgbdAlignment alignment;
  const CellFrame reference_cells = MakeCellFrame(camera, reference, options);
  const CellFrame current_cells = MakeCellFrame(camera, current, options);
  const std::vector<Sample> samples = Samples(camera, current_cells);
  // Photometry only between two images with contrast: a flat one matches nothing.
  const bool photometric = reference_cells.contrast && current_cells.contrast;
  alignment.sampled = static_cast<int>(samples.size());
  if (samples.size() < 6) return alignment;
  Eigen::Isometry3d transform = initial;
  double bound = options.max_pair_distance_m;
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    const Pass pass =
        Accumulate(camera, reference_cells, samples, transform, bound, photometric, options);
    if (pass.paired < 6) return alignment;
    const Vector6 delta = pass.hessian.ldlt().solve(-pass.gradient);
    if (!delta.allFinite()) return alignment;
    transform = Update(delta, transform);
    bound = std::max(options.min_pair_distance_m, 0.5 * bound);
    if (delta.head<3>().norm() < 1e-6 && delta.tail<3>().norm() < 1e-5 &&
        bound <= options.min_pair_distance_m) {
      break;
    }
  }
  const Pass last =
      Accumulate(camera, reference_cells, samples, transform, bound, photometric, options);
  alignment.reference_from_current = transform;
  alignment.paired = last.paired;
  alignment.textured = last.textured;
  alignment.rmse_m = last.paired > 0 ? std::sqrt(last.squared_sum / last.paired) : 0.0;
  alignment.intensity_correlation = last.Correlation();
  alignment.weakest_sigma_m = WeakestSigma(last);
  using Verdict = RgbdAlignment::Verdict;
  if (last.paired < options.min_paired_share * alignment.sampled || last.paired < 6) {
    alignment.verdict = Verdict::kFewPairs;
  } else if (alignment.rmse_m > options.max_rmse_m ||
             alignment.intensity_correlation < options.min_intensity_correlation) {
    alignment.verdict = Verdict::kLoose;
  } else if (alignment.weakest_sigma_m > options.max_weakest_sigma_m) {
    alignment.verdict = Verdict::kUnconstrained;
  } else {
    alignment.verdict = Verdict::kOk;
  }
  return alignment;
}

}  // namespace stillmap
