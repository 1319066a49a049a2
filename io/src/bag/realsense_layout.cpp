#include "bag/realsense_layout.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>

#include "bag/depth_registration.h"

namespace stillmap {
namespace {

std::vector<std::string> Parts(const std::string& topic) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (start <= topic.size()) {
    const size_t slash = std::min(topic.find('/', start), topic.size());
    parts.push_back(topic.substr(start, slash - start));
    start = slash + 1;
  }
  return parts;
}

// "device_3" for prefix "device_": a name and a number.
bool Numbered(const std::string& part, const char* prefix) {
  const std::string start(prefix);
  return part.size() > start.size() && part.compare(0, start.size(), start) == 0 &&
         std::all_of(part.begin() + static_cast<std::ptrdiff_t>(start.size()), part.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

// "Depth_0", "Color_0", "Infrared_1": a stream type and its index.
bool StreamPart(const std::string& part) {
  const size_t underscore = part.rfind('_');
  return underscore != std::string::npos && underscore > 0 &&
         Numbered(part.substr(underscore), "_");
}

bool Under(const std::vector<std::string>& parts, size_t sensors) {
  return parts.size() >= 2 + sensors && parts[0].empty() && Numbered(parts[1], "device_") &&
         (sensors == 0 || Numbered(parts[2], "sensor_"));
}

std::string Join(const std::vector<std::string>& parts, size_t count) {
  std::string text;
  for (size_t i = 1; i < count; ++i) text += "/" + parts[i];
  return text;
}

// One lens model as a map from undistorted to distorted normalized coordinates.
using LensMap = std::function<Eigen::Vector2d(const Eigen::Vector2d&)>;

// librealsense's Brown-Conrady polynomial (k1 k2 p1 p2 k3); `modified` applies the tangential
// terms to the radially scaled point, as its "Modified Brown Conrady" does.
Eigen::Vector2d BrownConrady(const std::vector<double>& c, const Eigen::Vector2d& p,
                             bool modified) {
  const double r2 = p.squaredNorm();
  const double f = 1.0 + r2 * (c[0] + r2 * (c[1] + r2 * c[4]));
  const Eigen::Vector2d q = modified ? Eigen::Vector2d(p * f) : p;
  return {p.x() * f + 2.0 * c[2] * q.x() * q.y() + c[3] * (r2 + 2.0 * q.x() * q.x()),
          p.y() * f + 2.0 * c[3] * q.x() * q.y() + c[2] * (r2 + 2.0 * q.y() * q.y())};
}

// The plumb_bob k1 k2 p1 p2 k3 closest, in the least-squares sense, to pairs of undistorted and
// distorted points (the model is linear in its coefficients).
std::vector<double> FitPlumbBob(const std::vector<Eigen::Vector2d>& undistorted,
                                const std::vector<Eigen::Vector2d>& distorted) {
  const Eigen::Index n = static_cast<Eigen::Index>(undistorted.size());
  Eigen::MatrixXd a(2 * n, 5);
  Eigen::VectorXd b(2 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = undistorted[i].x(), y = undistorted[i].y(), r2 = x * x + y * y;
    a.row(2 * i) << x * r2, x * r2 * r2, 2.0 * x * y, r2 + 2.0 * x * x, x * r2 * r2 * r2;
    a.row(2 * i + 1) << y * r2, y * r2 * r2, r2 + 2.0 * y * y, 2.0 * x * y, y * r2 * r2 * r2;
    b(2 * i) = distorted[i].x() - x;
    b(2 * i + 1) = distorted[i].y() - y;
  }
  const Eigen::VectorXd k = a.colPivHouseholderQr().solve(b);
  return {k(0), k(1), k(2), k(3), k(4)};
}

// Restates `info` with a plumb_bob fitted to the model over a grid of its image; the largest
// difference [px].
double RestateByFit(RosCameraInfo* info, bool inverse) {
  const std::vector<double> c = info->d;
  const double fx = info->k[0], fy = info->k[4], cx = info->k[2], cy = info->k[5];
  std::vector<Eigen::Vector2d> undistorted, distorted;
  constexpr int kSteps = 32;
  for (int i = 0; i <= kSteps; ++i) {
    for (int j = 0; j <= kSteps; ++j) {
      const Eigen::Vector2d grid(((info->width - 1.0) * i / kSteps - cx) / fx,
                                 ((info->height - 1.0) * j / kSteps - cy) / fy);
      // "Inverse": the polynomial takes a distorted image point to its undistorted one.
      undistorted.push_back(inverse ? BrownConrady(c, grid, false) : grid);
      distorted.push_back(inverse ? grid : BrownConrady(c, grid, true));
    }
  }
  info->d = FitPlumbBob(undistorted, distorted);
  double worst = 0.0;
  for (size_t i = 0; i < undistorted.size(); ++i) {
    const Eigen::Vector2d error = BrownConrady(info->d, undistorted[i], false) - distorted[i];
    worst = std::max(worst, std::hypot(error.x() * fx, error.y() * fy));
  }
  return worst;
}

}  // namespace

RealSenseTopic ClassifyRealSenseTopic(const std::string& topic) {
  if (topic.compare(0, 8, "/device_") != 0) return RealSenseTopic::kNone;
  const std::vector<std::string> parts = Parts(topic);
  if (parts.size() == 3 && Under(parts, 0) && parts[2] == "info") {
    return RealSenseTopic::kDeviceInfo;
  }
  if (parts.size() == 4 && Under(parts, 1) && parts[3] == "info") {
    return RealSenseTopic::kSensorInfo;
  }
  if (parts.size() == 6 && Under(parts, 1) && StreamPart(parts[3]) && parts[4] == "tf") {
    return RealSenseTopic::kExtrinsic;
  }
  const bool units = parts.size() == 6 && parts[4].size() == 11 &&
                     (parts[4] == "Depth Units" || parts[4] == "Depth_Units");
  if (units && Under(parts, 1) && parts[3] == "option" && parts[5] == "value") {
    return RealSenseTopic::kDepthUnits;
  }
  return RealSenseTopic::kNone;
}

std::string RealSenseStreamOf(const std::string& topic) {
  if (topic.compare(0, 8, "/device_") != 0) return {};
  const std::vector<std::string> parts = Parts(topic);
  if (parts.size() != 6 || !Under(parts, 1) || !StreamPart(parts[3]) || parts[4] != "image" ||
      parts[5] != "data") {
    return {};
  }
  return Join(parts, 4);
}

std::string RealSenseSensorOf(const std::string& stream) {
  const size_t slash = stream.rfind('/');
  return slash == std::string::npos ? std::string() : stream.substr(0, slash);
}

void AddRealSenseDetail(RealSenseTopic kind, const std::string& topic, const std::uint8_t* data,
                        size_t size, BagSerialization serialization, RealSenseDetails* details) {
  std::string error, key, value;
  const std::vector<std::string> parts = Parts(topic);
  bool decoded = false;
  if (kind == RealSenseTopic::kDeviceInfo || kind == RealSenseTopic::kSensorInfo) {
    decoded = DecodeRosKeyValue(data, size, serialization, &key, &value, &error);
    if (decoded && kind == RealSenseTopic::kDeviceInfo) details->device.emplace_back(key, value);
    if (decoded && kind == RealSenseTopic::kSensorInfo && key == "Name") {
      details->sensor_names[Join(parts, 3)] = value;
    }
  } else if (kind == RealSenseTopic::kExtrinsic) {
    RosTransform transform;
    decoded = DecodeRosTransform(data, size, serialization, &transform, &error);
    if (decoded) details->stream_from_reference[Join(parts, 4)][parts[5]] = transform;
  } else if (kind == RealSenseTopic::kDepthUnits) {
    float units = 0.0f;
    decoded = DecodeRosFloat32(data, size, serialization, &units, &error);
    // A float32 as the decimal it was written as (0.0002, not 0.000199999995).
    char text[32];
    std::snprintf(text, sizeof(text), "%.7g", static_cast<double>(units));
    if (decoded) details->depth_units[Join(parts, 3)] = std::strtod(text, nullptr);
  }
  if (!decoded && kind != RealSenseTopic::kNone) ++details->undecoded;
}

std::optional<Eigen::Isometry3d> RealSenseColorFromDepth(const RealSenseDetails& details,
                                                         const std::string& color_stream,
                                                         const std::string& depth_stream) {
  const auto color = details.stream_from_reference.find(color_stream);
  const auto depth = details.stream_from_reference.find(depth_stream);
  if (color == details.stream_from_reference.end() ||
      depth == details.stream_from_reference.end()) {
    return std::nullopt;
  }
  for (const auto& [group, color_from_reference] : color->second) {
    const auto same = depth->second.find(group);
    if (same == depth->second.end()) continue;
    return IsometryOf(color_from_reference) * IsometryOf(same->second).inverse();
  }
  return std::nullopt;
}

bool RestateRealSenseModel(RosCameraInfo* info, double* fit_error_px) {
  static const char* const kNames[] = {"None",
                                       "Brown Conrady",
                                       "Inverse Brown Conrady",
                                       "Modified Brown Conrady",
                                       "Kannala Brandt4",
                                       "Ftheta"};
  const std::string& model = info->distortion_model;
  if (std::find(std::begin(kNames), std::end(kNames), model) == std::end(kNames)) return false;
  *fit_error_px = 0.0;
  const bool none = std::all_of(info->d.begin(), info->d.end(), [](double c) { return c == 0.0; });
  const bool brown = model.find("Brown Conrady") != std::string::npos;
  if (!none && (!brown || info->d.size() != 5 || !(info->k[0] > 0.0) || !(info->k[4] > 0.0))) {
    return false;
  }
  if (none) {
    info->d.assign(5, 0.0);
  } else if (model != "Brown Conrady") {
    *fit_error_px = RestateByFit(info, model == "Inverse Brown Conrady");
  }
  info->distortion_model = "plumb_bob";
  return true;
}

std::string DescribeRealSenseDevice(const RealSenseDetails& details) {
  std::string name, extra;
  for (const auto& [key, value] : details.device) {
    if (key == "Name") name = value;
    if (key == "Serial Number") extra += std::string(extra.empty() ? "" : ", ") + "serial " + value;
    if (key == "Firmware Version") {
      extra += std::string(extra.empty() ? "" : ", ") + "firmware " + value;
    }
  }
  if (name.empty() && details.sensor_names.empty()) return {};
  std::string text = name.empty() ? "a RealSense device" : name;
  if (!extra.empty()) text += " (" + extra + ")";
  std::string sensors;
  for (const auto& [sensor, sensor_name] : details.sensor_names) {
    sensors += std::string(sensors.empty() ? "" : ", ") + sensor_name;
  }
  if (!sensors.empty()) text += "; sensors: " + sensors;
  return text;
}

}  // namespace stillmap
