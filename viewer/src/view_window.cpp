// The only file that includes PCL's visualization (VTK) headers.
#include "stillmap/viewer/view_window.h"

#include <octomap/OcTree.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/visualization/pcl_visualizer.h>
#include <vtkLogger.h>
#include <vtkObject.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include "stillmap/io/error.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/output_files.h"
#include "stillmap/viewer/build_folder.h"

namespace stillmap {

namespace {

using ColorCloud = pcl::PointCloud<pcl::PointXYZRGB>;

struct Scene {
  ColorCloud::Ptr cloud = pcl::make_shared<ColorCloud>();
  ColorCloud::Ptr voxels = pcl::make_shared<ColorCloud>();  // occupied, colored by height
  std::vector<Eigen::Isometry3d> trajectory, keyframes;
};

Scene LoadScene(const std::filesystem::path& out) {
  RenderInput folder = ReadBuildFolder(out.string());
  Scene scene;
  for (const VoxelPoint& p : folder.cloud) {
    pcl::PointXYZRGB point(p.rgb[0], p.rgb[1], p.rgb[2]);
    point.x = p.position.x();
    point.y = p.position.y();
    point.z = p.position.z();
    scene.cloud->push_back(point);
  }
  scene.trajectory = std::move(folder.trajectory);
  scene.keyframes = std::move(folder.keyframes);
  if (PathExists((out / "map.bt").string())) {
    octomap::OcTree tree(0.05);
    if (!tree.readBinary((out / "map.bt").string())) {
      throw InputError((out / "map.bt").string() + ": not a readable OctoMap (.bt)");
    }
    std::vector<octomap::point3d> centres;
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
      if (!tree.isNodeOccupied(*it)) continue;
      centres.push_back(it.getCoordinate());
      low = std::min<double>(low, centres.back().y());
      high = std::max<double>(high, centres.back().y());
    }
    for (const octomap::point3d& c : centres) {
      // Camera-style worlds have y down: color from blue (high) to orange (low).
      const double t = high > low ? (c.y() - low) / (high - low) : 0.5;
      pcl::PointXYZRGB point(static_cast<std::uint8_t>(40 + 200 * t), 120,
                             static_cast<std::uint8_t>(240 - 200 * t));
      point.x = c.x();
      point.y = c.y();
      point.z = c.z();
      scene.voxels->push_back(point);
    }
  }
  return scene;
}

class Window {
 public:
  explicit Window(const Scene& scene) : scene_(scene), viewer_("stillmap view") {
    viewer_.setBackgroundColor(0.96, 0.96, 0.96);
    viewer_.setSize(1280, 960);
    ShowCloud(true);
    ShowTrajectory(true);
    viewer_.registerKeyboardCallback(
        [this](const pcl::visualization::KeyboardEvent& event) { OnKey(event); });
    ResetView();
  }

  // VTK writes the PNG itself: to a temporary name first, renamed when whole.
  void Screenshot(const std::string& path) {
    viewer_.spinOnce(200, true);
    const std::string temporary = TemporaryPathFor(path) + ".png";
    std::remove(temporary.c_str());
    viewer_.saveScreenshot(temporary);
    CommitTemporary(temporary, path);
  }
  void Run() {
    while (!viewer_.wasStopped()) viewer_.spinOnce(50);
  }

 private:
  // Adds (on) or removes the colored points `cloud` under `id`, drawn `size` pixels wide.
  void ShowPoints(const ColorCloud::Ptr& cloud, const std::string& id, int size, bool on) {
    viewer_.removePointCloud(id);
    if (!on || cloud->empty()) return;
    const pcl::visualization::PointCloudColorHandlerRGBField<pcl::PointXYZRGB> rgb(cloud);
    viewer_.addPointCloud<pcl::PointXYZRGB>(cloud, rgb, id);
    viewer_.setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_POINT_SIZE, size,
                                             id);
  }
  void ShowCloud(bool on) {
    cloud_on_ = on;
    ShowPoints(scene_.cloud, "cloud", 2, on);
  }
  void ShowVoxels(bool on) {
    voxels_on_ = on;
    ShowPoints(scene_.voxels, "voxels", 6, on);
  }
  void ShowTrajectory(bool on) {
    for (const std::string& id : trajectory_ids_) viewer_.removeShape(id);
    for (const std::string& id : keyframe_ids_) viewer_.removeCoordinateSystem(id);
    trajectory_ids_.clear();
    keyframe_ids_.clear();
    trajectory_on_ = on;
    if (!on) return;
    // The path as segments (every 3rd pose), the keyframes as 10 cm axes (x red, y green, z blue).
    const size_t step = 3;
    for (size_t i = step; i < scene_.trajectory.size(); i += step) {
      const Eigen::Vector3d a = scene_.trajectory[i - step].translation();
      const Eigen::Vector3d b = scene_.trajectory[i].translation();
      const std::string id = "path" + std::to_string(i);
      viewer_.addLine(pcl::PointXYZ(a.x(), a.y(), a.z()), pcl::PointXYZ(b.x(), b.y(), b.z()), 0.1,
                      0.35, 0.8, id);
      viewer_.setShapeRenderingProperties(pcl::visualization::PCL_VISUALIZER_LINE_WIDTH, 3, id);
      trajectory_ids_.push_back(id);
    }
    for (size_t k = 0; k < scene_.keyframes.size(); ++k) {
      const std::string id = "keyframe" + std::to_string(k);
      viewer_.addCoordinateSystem(0.1, Eigen::Affine3f(scene_.keyframes[k].matrix().cast<float>()),
                                  id);
      keyframe_ids_.push_back(id);
    }
  }
  void ResetView() {
    // From 1.5 m behind and 0.7 m above the first camera, looking where it looked.
    Eigen::Isometry3d first = Eigen::Isometry3d::Identity();
    if (!scene_.trajectory.empty()) first = scene_.trajectory.front();
    const Eigen::Vector3d eye = first * Eigen::Vector3d(0.0, -0.7, -1.5);
    const Eigen::Vector3d focus = first * Eigen::Vector3d(0.0, 0.0, 2.0);
    const Eigen::Vector3d up = -first.linear().col(1);
    viewer_.setCameraPosition(eye.x(), eye.y(), eye.z(), focus.x(), focus.y(), focus.z(), up.x(),
                              up.y(), up.z());
  }
  void OnKey(const pcl::visualization::KeyboardEvent& event) {
    if (!event.keyDown()) return;
    const std::string& key = event.getKeySym();
    if (key == "v") ShowVoxels(!voxels_on_);
    if (key == "t") ShowTrajectory(!trajectory_on_);
    if (key == "m") ShowCloud(!cloud_on_);
    if (key == "r") ResetView();
  }

  const Scene& scene_;
  pcl::visualization::PCLVisualizer viewer_;
  bool cloud_on_ = false, voxels_on_ = false, trajectory_on_ = false;
  std::vector<std::string> trajectory_ids_, keyframe_ids_;
};

}  // namespace

void RunViewWindow(const std::string& out_dir, const std::string& screenshot_path) {
  if (!screenshot_path.empty()) CheckImageOutputPath(screenshot_path, true);
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0') {
    throw std::runtime_error(
        "no display (DISPLAY is not set): run it in a desktop session, under xvfb-run with "
        "--screenshot, or use --png for the renders");
  }
  const Scene scene = LoadScene(out_dir);
  // Debian's VTK 9.1 warns about PCL's use of deprecated shader calls once per actor.
  vtkObject::GlobalWarningDisplayOff();
  vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_ERROR);
  Window window(scene);
  if (!screenshot_path.empty()) {
    window.Screenshot(screenshot_path);
    return;
  }
  window.Run();
}

}  // namespace stillmap
