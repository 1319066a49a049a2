#include "stillmap/io/camera.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <opencv2/calib3d.hpp>
#include <set>
#include <stdexcept>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/io/sequence.h"
#include "stillmap/io/yaml_file.h"

namespace stillmap {

bool Camera::HasDistortion() const {
  for (double k : distortion) {
    if (k != 0.0) return true;
  }
  for (double k : rational) {
    if (k != 0.0) return true;
  }
  return false;
}

std::vector<double> Camera::Coefficients() const {
  std::vector<double> coefficients(distortion.begin(), distortion.end());
  if (rational[0] != 0.0 || rational[1] != 0.0 || rational[2] != 0.0) {
    coefficients.insert(coefficients.end(), rational.begin(), rational.end());
  }
  return coefficients;
}

std::vector<Eigen::Vector2f> PixelRays(const Camera& camera) {
  const size_t count = static_cast<size_t>(camera.width) * static_cast<size_t>(camera.height);
  std::vector<Eigen::Vector2f> rays;
  rays.reserve(count);
  if (!camera.HasDistortion()) {
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        rays.emplace_back(static_cast<float>((u - camera.cx) / camera.fx),
                          static_cast<float>((v - camera.cy) / camera.fy));
      }
    }
    return rays;
  }
  std::vector<cv::Point2f> pixels, undistorted;
  pixels.reserve(count);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
    }
  }
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  cv::undistortPoints(pixels, undistorted, k, camera.Coefficients());
  for (const cv::Point2f& ray : undistorted) rays.emplace_back(ray.x, ray.y);
  return rays;
}

PixelProjection::PixelProjection(const Camera& camera)
    : fx_(static_cast<float>(camera.fx)),
      fy_(static_cast<float>(camera.fy)),
      cx_(static_cast<float>(camera.cx)),
      cy_(static_cast<float>(camera.cy)),
      k1_(static_cast<float>(camera.distortion[0])),
      k2_(static_cast<float>(camera.distortion[1])),
      p1_(static_cast<float>(camera.distortion[2])),
      p2_(static_cast<float>(camera.distortion[3])),
      k3_(static_cast<float>(camera.distortion[4])),
      k4_(static_cast<float>(camera.rational[0])),
      k5_(static_cast<float>(camera.rational[1])),
      k6_(static_cast<float>(camera.rational[2])),
      distorted_(camera.HasDistortion()) {}

namespace {

// Why the distortion does not map the image one-to-one onto viewing rays, or "" when it does.
// The radial term r (1 + k1 r^2 + k2 r^4 + k3 r^6) must keep growing until it reaches the image's
// farthest corner (else pixels fold over), and undistorting the image's border and distorting it
// again must give the same pixels back (else OpenCV's undistortion, used for every pixel's ray,
// does not converge).
std::string DistortionProblem(const Camera& camera) {
  const auto& d = camera.distortion;
  const auto& q = camera.rational;
  double corner_radius = 0.0;  // distorted normalized radius of the farthest corner
  std::vector<cv::Point2d> border;
  for (int i = 0; i <= 8; ++i) {
    const double u = (camera.width - 1) * i / 8.0, v = (camera.height - 1) * i / 8.0;
    for (const cv::Point2d& p : {cv::Point2d(u, 0), cv::Point2d(u, camera.height - 1),
                                 cv::Point2d(0, v), cv::Point2d(camera.width - 1, v)}) {
      border.push_back(p);
      corner_radius = std::max(
          corner_radius, std::hypot((p.x - camera.cx) / camera.fx, (p.y - camera.cy) / camera.fy));
    }
  }
  double previous = 0.0;
  bool reached = false;
  for (double r = 1e-3; r <= 20.0 && !reached; r += 1e-3) {  // up to 87 degrees off axis
    const double r2 = r * r;
    const double radial = r * (1.0 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]))) /
                          (1.0 + r2 * (q[0] + r2 * (q[1] + r2 * q[2])));
    if (!(radial > previous)) {
      return "its radial term turns back at " +
             std::to_string(static_cast<int>(std::atan(r) * 180.0 / M_PI)) +
             " degrees off axis, inside the image (pixels fold over)";
    }
    previous = radial;
    reached = radial >= corner_radius;
  }
  if (!reached) return "the image's corners lie beyond 87 degrees off axis";
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> coefficients = camera.Coefficients();
  std::vector<cv::Point2d> rays, back;
  cv::undistortPoints(border, rays, k, coefficients);
  std::vector<cv::Point3d> points;
  points.reserve(rays.size());
  for (const cv::Point2d& ray : rays) points.emplace_back(ray.x, ray.y, 1.0);
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, coefficients, back);
  for (size_t i = 0; i < border.size(); ++i) {
    if (!(cv::norm(back[i] - border[i]) < 1.0)) {
      return "undistorting the image border and distorting it again misses by more than a pixel";
    }
  }
  return "";
}

}  // namespace

void Camera::Validate(const std::string& source) const {
  auto fail = [&](const std::string& what) {
    throw InputError(source + ": invalid camera: " + what);
  };
  if (width <= 0 || height <= 0 || width > kMaxImageSide || height > kMaxImageSide) {
    fail("width and height must be between 1 and " + std::to_string(kMaxImageSide) + " pixels");
  }
  if (!(fx > 0.0) || !(fy > 0.0) || !std::isfinite(fx) || !std::isfinite(fy)) {
    fail("fx and fy must be positive, finite focal lengths in pixels");
  }
  // Between about 1 and 170 degrees of field of view, and pixels at most 2:1.
  if (fx < 0.05 * width || fx > 50.0 * width || fy < 0.5 * fx || fy > 2.0 * fx) {
    fail(
        "fx and fy must lie between 0.05 and 50 times the width, within a factor 2 of each "
        "other (a field of view of 1 to 170 degrees); are they in pixels?");
  }
  if (!(cx >= 0.0 && cx <= width && cy >= 0.0 && cy <= height)) {
    fail("the principal point (cx, cy) must lie inside the image");
  }
  for (double k : Coefficients()) {
    if (!std::isfinite(k)) fail("distortion coefficients must be finite");
  }
  if (HasDistortion()) {
    const std::string problem = DistortionProblem(*this);
    if (!problem.empty()) fail("distortion [k1 k2 p1 p2 k3] is not usable: " + problem);
  }
  if (!(depth_factor > 0.0 && depth_factor <= 1e6)) {
    fail("depth_factor (depth PNG value per metre) must be in (0, 1e6]");
  }
  if (groundtruth_body_from_camera) {
    const Eigen::Matrix3d r = groundtruth_body_from_camera->linear();
    if (!r.allFinite() || (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() > 1e-3 ||
        r.determinant() < 0.0 || !groundtruth_body_from_camera->translation().allFinite()) {
      fail("groundtruth_body_from_camera must hold a rotation (orthonormal, determinant +1)");
    }
  }
}

std::vector<std::string> CameraPresetNames() {
  return {"tum1", "tum2", "tum3", "bonn", "ros_default"};
}

std::string CameraPresetChoices() {
  std::string choices;
  for (const std::string& preset : CameraPresetNames()) {
    choices += (choices.empty() ? "" : "|") + preset;
  }
  return choices;
}

Camera CameraPreset(const std::string& name) {
  Camera camera;
  if (name == "tum1") {
    camera.fx = 517.3, camera.fy = 516.5, camera.cx = 318.6, camera.cy = 255.3;
    camera.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  } else if (name == "tum2") {
    camera.fx = 520.9, camera.fy = 521.0, camera.cx = 325.1, camera.cy = 249.7;
    camera.distortion = {0.2312, -0.7849, -0.0033, -0.0001, 0.9172};
  } else if (name == "tum3") {
    camera.fx = 535.4, camera.fy = 539.2, camera.cx = 320.1, camera.cy = 247.6;
  } else if (name == "bonn") {
    camera.fx = 542.822841, camera.fy = 542.576870, camera.cx = 315.593520, camera.cy = 237.756098;
    camera.distortion = {0.039903, -0.099343, -0.000730, -0.000144, 0.0};
  } else if (name == "ros_default") {
    camera.fx = 525.0, camera.fy = 525.0, camera.cx = 319.5, camera.cy = 239.5;
  } else {
    std::string known;
    for (const std::string& preset : CameraPresetNames()) known += " " + preset;
    throw InputError(fmt::format("{}: unknown preset '{}' (known:{})",
                                 OptionKey(&CameraOverrides::preset), name, known));
  }
  return camera;
}

namespace {

double ReadScalar(const YAML::Node& root, const std::string& key, const std::string& path) {
  const YAML::Node node = root[key];
  if (!node) {
    throw InputError(path + ": missing key '" + key +
                     "' (camera.yaml needs width, height, fx, "
                     "fy, cx, cy, distortion, depth_factor)");
  }
  try {
    return node.as<double>();
  } catch (const YAML::Exception&) {
    throw InputError(WhereInFile(path, node.Mark().line + 1) + ": key '" + key +
                     "' must be a number");
  }
}

std::vector<double> ReadList(const YAML::Node& root, const std::string& key,
                             const std::string& path, size_t expected) {
  const YAML::Node node = root[key];
  const std::string where = WhereInFile(path, node ? node.Mark().line + 1 : 0);
  if (!node || !node.IsSequence() || node.size() != expected) {
    throw InputError(where + ": key '" + key + "' must be a list of " + std::to_string(expected) +
                     " numbers");
  }
  std::vector<double> values;
  try {
    for (const YAML::Node& item : node) values.push_back(item.as<double>());
  } catch (const YAML::Exception&) {
    throw InputError(where + ": key '" + key + "' must hold numbers only");
  }
  return values;
}

}  // namespace

Camera LoadCameraYaml(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "camera file");
  if (!root.IsMap()) throw InputError(path + ": expected a YAML map of camera keys");
  const std::set<std::string> known = {
      "width",      "height",       "fx",
      "fy",         "cx",           "cy",
      "distortion", "depth_factor", "groundtruth_body_from_camera"};
  for (const auto& item : root) {
    const std::string key = item.first.as<std::string>();
    if (known.count(key) == 0) {
      throw InputError(WhereInFile(path, item.first.Mark().line + 1) + ": unknown key '" + key +
                       "' (known: width height fx fy cx cy distortion depth_factor "
                       "groundtruth_body_from_camera)");
    }
  }
  Camera camera;
  const double width = ReadScalar(root, "width", path);
  const double height = ReadScalar(root, "height", path);
  if (width != std::floor(width) || height != std::floor(height) || !(width >= 1.0) ||
      !(height >= 1.0) || width > Camera::kMaxImageSide || height > Camera::kMaxImageSide) {
    throw InputError(path + ": width and height must be whole numbers of pixels, 1 to " +
                     std::to_string(Camera::kMaxImageSide));
  }
  camera.width = static_cast<int>(width);
  camera.height = static_cast<int>(height);
  camera.fx = ReadScalar(root, "fx", path);
  camera.fy = ReadScalar(root, "fy", path);
  camera.cx = ReadScalar(root, "cx", path);
  camera.cy = ReadScalar(root, "cy", path);
  const std::vector<double> distortion = ReadList(root, "distortion", path, 5);
  std::copy(distortion.begin(), distortion.end(), camera.distortion.begin());
  camera.depth_factor = ReadScalar(root, "depth_factor", path);
  if (root["groundtruth_body_from_camera"]) {
    const std::vector<double> m = ReadList(root, "groundtruth_body_from_camera", path, 16);
    Eigen::Matrix4d matrix;
    for (int i = 0; i < 16; ++i) matrix(i / 4, i % 4) = m[i];
    if ((matrix.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
      throw InputError(path + ": groundtruth_body_from_camera's last row must be 0 0 0 1");
    }
    Eigen::Isometry3d body_from_camera = Eigen::Isometry3d::Identity();
    body_from_camera.linear() = matrix.topLeftCorner<3, 3>();
    body_from_camera.translation() = matrix.topRightCorner<3, 1>();
    camera.groundtruth_body_from_camera = body_from_camera;
  }
  camera.Validate(path);
  return camera;
}

void WriteCameraYaml(const std::string& path, const Camera& camera, const std::string& comment) {
  std::ofstream out(path);
  out << std::setprecision(10);
  if (!comment.empty()) out << "# " << comment << "\n";
  out << "width: " << camera.width << "\nheight: " << camera.height << "\nfx: " << camera.fx
      << "\nfy: " << camera.fy << "\ncx: " << camera.cx << "\ncy: " << camera.cy
      << "\ndistortion: [" << camera.distortion[0] << ", " << camera.distortion[1] << ", "
      << camera.distortion[2] << ", " << camera.distortion[3] << ", " << camera.distortion[4]
      << "]\n# depth PNG value per metre\ndepth_factor: " << camera.depth_factor << "\n";
  if (camera.groundtruth_body_from_camera) {
    const Eigen::Matrix4d m = camera.groundtruth_body_from_camera->matrix();
    out << "groundtruth_body_from_camera: [";
    for (int i = 0; i < 16; ++i) out << m(i / 4, i % 4) << (i < 15 ? ", " : "]\n");
  }
  if (!out.flush()) throw std::runtime_error(WriteFailure(path, "the camera file"));
}

}  // namespace stillmap
