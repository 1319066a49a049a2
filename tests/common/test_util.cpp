#include "test_util.h"

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <queue>
#include <random>
#include <sstream>

#include "stillmap/io/error.h"

namespace stillmap::testing {

namespace fs = std::filesystem;

TempDir::TempDir() {
  static std::mt19937_64 rng(std::random_device{}());
  for (;;) {
    const fs::path candidate =
        fs::temp_directory_path() / ("stillmap_test_" + std::to_string(rng() % 100000000));
    if (fs::create_directory(candidate)) {
      path_ = candidate.string();
      return;
    }
  }
}

TempDir::~TempDir() {
  std::error_code error;
  fs::permissions(path_, fs::perms::owner_all, fs::perm_options::add, error);
  for (const auto& entry : fs::recursive_directory_iterator(path_, error)) {
    fs::permissions(entry.path(), fs::perms::owner_all, fs::perm_options::add, error);
  }
  fs::remove_all(path_, error);
}

std::optional<std::string> SharedSequence(const std::string& name) {
  const char* env = std::getenv("STILLMAP_DATA");
  const fs::path root = env != nullptr ? fs::path(env) : fs::path(STILLMAP_SHARED_DATA);
  const fs::path dir = root / name;
  if (!fs::exists(dir / "rgb.txt")) return std::nullopt;
  return dir.string();
}

std::optional<std::string> SharedBag(const std::string& name) {
  const char* env = std::getenv("STILLMAP_DATA");
  const fs::path root = env != nullptr ? fs::path(env) : fs::path(STILLMAP_SHARED_DATA);
  const fs::path path = root / "bags" / name;
  if (!fs::exists(path)) return std::nullopt;
  return path.string();
}

std::optional<std::string> SharedTool(const std::string& name) {
  const char* env = std::getenv("STILLMAP_DATA");
  const fs::path root = env != nullptr ? fs::path(env) : fs::path(STILLMAP_SHARED_DATA);
  const fs::path path = root / ".." / "tools" / name;
  if (!fs::exists(path)) return std::nullopt;
  return path.string();
}

std::optional<std::string> SharedModels(const std::string& name) {
  const char* env = std::getenv("STILLMAP_MODELS");
  const fs::path root =
      env != nullptr ? fs::path(env) : fs::path(STILLMAP_SHARED_DATA) / ".." / "models";
  if (!fs::is_directory(root / name)) return std::nullopt;
  return root.lexically_normal().string();
}

Camera SmallCamera(int width, int height) {
  Camera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = 0.8 * width;
  camera.cx = (width - 1) / 2.0;
  camera.cy = (height - 1) / 2.0;
  camera.depth_factor = 5000.0;
  return camera;
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

Trajectory WritePlaneSequence(const std::string& dir, const Camera& camera, const PlaneScene& scene,
                              const std::vector<Eigen::Isometry3d>& world_from_camera) {
  fs::create_directories(fs::path(dir) / "rgb");
  fs::create_directories(fs::path(dir) / "depth");
  std::ofstream rgb_list(dir + "/rgb.txt"), depth_list(dir + "/depth.txt");
  rgb_list << "# color images\n";
  depth_list << "# depth images\n";
  std::vector<StampedPose> poses;
  char name[64];
  for (size_t i = 0; i < world_from_camera.size(); ++i) {
    const double time = 1000.0 + static_cast<double>(i) / 30.0;
    const Eigen::Isometry3d& pose = world_from_camera[i];
    cv::Mat color(camera.height, camera.width, CV_8UC3);
    cv::Mat depth(camera.height, camera.width, CV_16UC1);
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const Eigen::Vector3d ray_in_camera((u - camera.cx) / camera.fx,
                                            (v - camera.cy) / camera.fy, 1.0);
        const Eigen::Vector3d ray = pose.linear() * ray_in_camera;
        const double denominator = scene.normal.dot(ray);
        double z = 0.0;
        if (std::abs(denominator) > 1e-9) {
          z = (scene.distance - scene.normal.dot(pose.translation())) / denominator;
        }
        const Eigen::Vector3d hit = pose.translation() + z * ray;
        const bool dark = (static_cast<int>(std::floor(hit.x() / 0.1)) +
                           static_cast<int>(std::floor(hit.y() / 0.1))) %
                              2 ==
                          0;
        color.at<cv::Vec3b>(v, u) = dark ? cv::Vec3b(40, 60, 200) : cv::Vec3b(230, 230, 230);
        const double value = z > 0 ? std::round(z * camera.depth_factor) : 0.0;
        depth.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(std::min(value, 65535.0));
      }
    }
    std::snprintf(name, sizeof(name), "%.6f.png", time);
    cv::imwrite(dir + "/rgb/" + name, color);
    cv::imwrite(dir + "/depth/" + name, depth);
    rgb_list << std::fixed << time << " rgb/" << name << "\n";
    depth_list << std::fixed << time << " depth/" << name << "\n";
    poses.push_back({time, pose});
  }
  Trajectory trajectory(poses);
  trajectory.WriteTum(dir + "/groundtruth.txt");
  WriteCameraYaml(dir + "/camera.yaml", camera, "test plane sequence");
  return trajectory;
}

void WriteSmallPlaneSequence(const std::string& dir) {
  std::vector<Eigen::Isometry3d> poses(4, Eigen::Isometry3d::Identity());
  for (size_t i = 0; i < poses.size(); ++i) poses[i].translation().x() = 0.01 * i;
  WritePlaneSequence(dir, SmallCamera(), {}, poses);
}

int RunCommand(const std::string& command, std::string* output) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer{};
  output->clear();
  size_t read = 0;
  while ((read = fread(buffer.data(), 1, buffer.size(), pipe)) > 0)
    output->append(buffer.data(), read);
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int RunStillmap(const std::string& arguments, std::string* output, const std::string& prefix) {
  return RunCommand((prefix.empty() ? "" : prefix + " ") + STILLMAP_BINARY + " " + arguments,
                    output);
}

std::string ErrorOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::vector<cv::Point> PlanPath(const std::vector<bool>& passable, int width, int height,
                                cv::Point start, cv::Point goal) {
  auto index = [width](cv::Point p) {
    return static_cast<size_t>(p.y) * static_cast<size_t>(width) + static_cast<size_t>(p.x);
  };
  auto open = [&](cv::Point p) {
    return p.x >= 0 && p.y >= 0 && p.x < width && p.y < height && passable[index(p)];
  };
  if (!open(start) || !open(goal)) return {};
  auto heuristic = [&goal](cv::Point p) {  // octile distance
    const int dx = std::abs(p.x - goal.x), dy = std::abs(p.y - goal.y);
    return std::max(dx, dy) + (std::sqrt(2.0) - 1.0) * std::min(dx, dy);
  };
  std::vector<double> cost(passable.size(), std::numeric_limits<double>::infinity());
  std::vector<long> parent(passable.size(), -1);
  using Entry = std::pair<double, cv::Point>;
  auto later = [](const Entry& a, const Entry& b) { return a.first > b.first; };
  std::priority_queue<Entry, std::vector<Entry>, decltype(later)> queue(later);
  cost[index(start)] = 0.0;
  queue.emplace(heuristic(start), start);
  while (!queue.empty() && queue.top().second != goal) {
    const cv::Point p = queue.top().second;
    queue.pop();
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const cv::Point q(p.x + dx, p.y + dy);
        if ((dx == 0 && dy == 0) || !open(q)) continue;
        if (dx != 0 && dy != 0 && (!open({p.x + dx, p.y}) || !open({p.x, p.y + dy}))) continue;
        const double reached = cost[index(p)] + (dx != 0 && dy != 0 ? std::sqrt(2.0) : 1.0);
        if (reached >= cost[index(q)]) continue;
        cost[index(q)] = reached;
        parent[index(q)] = static_cast<long>(index(p));
        queue.emplace(reached + heuristic(q), q);
      }
    }
  }
  if (queue.empty()) return {};
  std::vector<cv::Point> path;
  for (long k = static_cast<long>(index(goal)); k >= 0; k = parent[static_cast<size_t>(k)]) {
    path.emplace_back(k % width, k / width);
  }
  std::reverse(path.begin(), path.end());
  return path;
}

}  // namespace stillmap::testing
