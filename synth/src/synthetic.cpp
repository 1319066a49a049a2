#include "stillmap/synth/synthetic.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "stillmap/io/cloud_files.h"
#include "stillmap/io/error.h"
#include "stillmap/io/image_io.h"
#include "stillmap/io/input_files.h"
#include "stillmap/io/output_files.h"
#include "stillmap/io/timing.h"
#include "stillmap/io/trajectory.h"
#include "synthetic_scene.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using synth::kFirstDynamicId;

constexpr double kFrameRate = 30.0;    // [Hz]
constexpr double kStartTime = 1000.0;  // timestamp of frame 0 [s]

double FrameTime(size_t index) { return kStartTime + static_cast<double>(index) / kFrameRate; }

std::string FrameName(size_t index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%.6f.png", FrameTime(index));
  return name;
}

// Kinect/Xtion-like depth: no reading nearer than 0.4 m or farther than 5 m, fewer and fewer
// nearer than 0.8 m (the projected pattern saturates: none at 0.4 m, all at 0.8 m), none at grazing
// angles
// (beyond 80 deg) and, half of the time, on the far side of depth discontinuities (the
// projector's shadow); axial noise sigma(z) = 1.2 mm + 1.9 mm (z - 0.4)^2 (Nguyen et al., 3DIMPVT
// 2012); quantized to the depth factor.
cv::Mat DepthModel(const RasterBuffers& buffers, const Camera& camera, bool noisy, cv::RNG& rng) {
  const cv::Mat& depth = buffers.depth;
  cv::Mat out(depth.size(), CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      float z = depth.at<float>(v, u);
      if (z == 0.0f) continue;
      if (noisy) {
        if (z < 0.4f || z > 5.0f || buffers.cos_incidence.at<float>(v, u) < 0.17f) continue;
        if (z < 0.8f && rng.uniform(0.0, 1.0) > (z - 0.4f) / 0.4f) continue;
        bool edge = false;
        for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int nu = u + du, nv = v + dv;
          if (nu < 0 || nv < 0 || nu >= depth.cols || nv >= depth.rows) continue;
          const float n = depth.at<float>(nv, nu);
          edge = edge || (n > 0.0f && z - n > 0.03f + 0.02f * z);  // this pixel is behind
        }
        if (edge && rng.uniform(0.0, 1.0) < 0.5) continue;
        const float sigma = 0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f);
        z += sigma * static_cast<float>(rng.gaussian(1.0));
      }
      const double value = std::round(z * camera.depth_factor);
      out.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(std::clamp(value, 1.0, 65535.0));
    }
  }
  return out;
}

// Encoded in memory and written by stillmap, so that a full disk is said in the user's words.
void WritePng(const std::string& path, const cv::Mat& image) { WriteImage(path, image, ".png"); }

// Draws the whole scene at `time`; the static-only depth is copied out when asked.
void Render(const synth::Scene& scene, const std::string& scenario, double time, Rasterizer* raster,
            cv::Mat* static_depth) {
  const Eigen::Isometry3f camera_from_world = synth::CameraPose(scenario, time).inverse();
  raster->Clear();
  for (const synth::StaticObject& object : scene.statics) {
    raster->Draw(object.mesh, Eigen::Isometry3f::Identity(), camera_from_world, object.id,
                 object.material, scene.light_in_world);
  }
  if (static_depth != nullptr) *static_depth = raster->buffers().depth.clone();
  for (const synth::MovingObject& object : scene.movers) {
    const Eigen::Isometry3f world_from_body = synth::BodyPose(scene, object, time);
    const std::vector<Eigen::Isometry3f> parts = synth::PartPoses(object, time);
    for (size_t k = 0; k < object.parts.size(); ++k) {
      raster->Draw(object.parts[k].mesh, world_from_body * parts[k], camera_from_world, object.id,
                   object.parts[k].material, scene.light_in_world);
    }
  }
}

// Samples the static surfaces every `spacing` metres (a grid in each triangle's plane), colored by
// their texture.
std::vector<VoxelPoint> SampleStaticSurfaces(const synth::Scene& scene, double spacing) {
  std::vector<VoxelPoint> points;
  const float s = static_cast<float>(spacing);
  for (const synth::StaticObject& object : scene.statics) {
    const Material& material = scene.materials[object.material];
    for (const auto& face : object.mesh.faces) {
      const Eigen::Vector3f a = object.mesh.vertices[face[0]];
      const Eigen::Vector3f ab = object.mesh.vertices[face[1]] - a;
      const Eigen::Vector3f ac = object.mesh.vertices[face[2]] - a;
      const Eigen::Vector3f normal = ab.cross(ac);
      if (normal.norm() < 1e-12f) continue;
      const Eigen::Vector3f e1 = ab.normalized();
      const Eigen::Vector3f e2 = normal.normalized().cross(e1);
      // Triangle in 2-D: a = (0, 0), b = (|ab|, 0), c = (ac.e1, ac.e2).
      const Eigen::Vector2f b2(ab.norm(), 0.0f), c2(ac.dot(e1), ac.dot(e2));
      const float det = b2.x() * c2.y() - c2.x() * b2.y();
      const float x_min = std::min({0.0f, b2.x(), c2.x()}),
                  x_max = std::max({0.0f, b2.x(), c2.x()});
      const float y_min = std::min({0.0f, c2.y()}), y_max = std::max({0.0f, c2.y()});
      for (float y = y_min + s / 2; y < y_max; y += s) {
        for (float x = x_min + s / 2; x < x_max; x += s) {
          // Barycentric coordinates of (x, y): p = a + beta * ab + gamma * ac.
          const float beta = (x * c2.y() - c2.x() * y) / det;
          const float gamma = (b2.x() * y - x * b2.y()) / det;
          if (beta < 0.0f || gamma < 0.0f || beta + gamma > 1.0f) continue;
          const Eigen::Vector2f uv = (1 - beta - gamma) * object.mesh.uvs[face[0]] +
                                     beta * object.mesh.uvs[face[1]] +
                                     gamma * object.mesh.uvs[face[2]];
          const Eigen::Vector3f bgr = SampleTexture(material.texture, uv.x(), uv.y());
          VoxelPoint point;
          point.position = a + beta * ab + gamma * ac;
          point.rgb = {static_cast<std::uint8_t>(bgr[2]), static_cast<std::uint8_t>(bgr[1]),
                       static_cast<std::uint8_t>(bgr[0])};
          point.count = 1;
          points.push_back(point);
        }
      }
    }
  }
  return points;
}

// Marks the surface points that a camera with this static-only depth sees: in the image, within
// range, and not behind another static surface.
void MarkVisible(const std::vector<VoxelPoint>& points, const Eigen::Isometry3f& camera_from_world,
                 const cv::Mat& static_depth, const Camera& camera, double max_range,
                 std::vector<std::atomic<std::uint8_t>>* seen) {
  const float max_z = static_cast<float>(max_range);
  for (size_t i = 0; i < points.size(); ++i) {
    if ((*seen)[i].load(std::memory_order_relaxed) != 0) continue;
    const Eigen::Vector3f q = camera_from_world * points[i].position;
    if (q.z() < 0.1f || q.z() > max_z) continue;
    const int u = static_cast<int>(std::lround(camera.fx * q.x() / q.z() + camera.cx));
    const int v = static_cast<int>(std::lround(camera.fy * q.y() / q.z() + camera.cy));
    if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
    const float surface = static_depth.at<float>(v, u);
    if (surface > 0.0f && std::abs(surface - q.z()) < 0.01f + 0.01f * q.z()) {
      (*seen)[i].store(1, std::memory_order_relaxed);
    }
  }
}

void WriteTimestampList(const std::string& path, const std::string& what, const std::string& folder,
                        size_t frames) {
  std::ofstream out(path);
  out << "# " << what << "\n# timestamp filename\n";
  char line[96];
  for (size_t i = 0; i < frames; ++i) {
    std::snprintf(line, sizeof(line), "%.6f %s/%s\n", FrameTime(i), folder.c_str(),
                  FrameName(i).c_str());
    out << line;
  }
  if (!out.flush()) throw std::runtime_error(WriteFailure(path, "the file"));
}

}  // namespace

void SynthOptions::Validate() const {
  const std::vector<std::string> names = SynthScenarioNames();
  if (std::find(names.begin(), names.end(), scenario) == names.end()) {
    std::string known;
    for (const std::string& name : names) known += " " + name;
    throw InputError("--scenario: unknown scenario '" + scenario + "' (known:" + known + ")");
  }
  if (frames < 2 || frames > 100000) throw InputError("--frames must be between 2 and 100000");
  if (!(static_gt_spacing >= 0.001 && static_gt_spacing <= 0.1)) {
    throw InputError("static_gt_spacing must be between 0.001 and 0.1 m");
  }
  if (!(static_gt_max_range > 0.4)) throw InputError("static_gt_max_range must exceed 0.4 m");
  if (threads < 1) throw InputError("--threads must be at least 1");
}

std::vector<std::string> SynthScenarioNames() {
  return {"static",  "walking_static", "walking_xyz", "walking_rpy", "walking_halfsphere",
          "sitting", "carried_object", "crowd_start", "lens_pass",   "stop_and_go",
          "loop",    "look_alike",     "busy_office"};
}

Camera SynthCamera() {
  Camera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 525.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.depth_factor = 5000.0;
  return camera;
}

namespace {

// Refuses to write into anything but a new or empty folder or an earlier synthetic sequence (it
// holds synth's record of the files it wrote: a synth.json alone does not count); in the latter,
// only the files the earlier run wrote are replaced or removed.
void CheckSynthFolder(const std::string& out_dir) {
  std::error_code error;
  if (!fs::is_directory(out_dir, error) ||
      PathExists((fs::path(out_dir) / ".stillmap-synth-outputs").string())) {
    return;
  }
  for (const fs::directory_entry& entry : fs::directory_iterator(out_dir, error)) {
    if (OutputSet::IsInternalName(entry.path().filename().string())) continue;
    throw InputError(out_dir +
                     ": exists and is not an earlier stillmap synth output (it holds no record "
                     "of one); choose an empty or new folder");
  }
}

// The scene's meshes written as OBJ into WORK/scene and read back through assimp, which is what
// renders.
void PassMeshesThroughFiles(const fs::path& work, synth::Scene* scene) {
  for (synth::StaticObject& object : scene->statics) {
    const std::string path = (work / "scene" / (object.name + ".obj")).string();
    WriteObj(path, object.mesh);
    object.mesh = LoadMesh(path);
  }
  for (synth::MovingObject& object : scene->movers) {
    for (synth::MovingPart& part : object.parts) {
      const std::string path = (work / "scene" / (object.name + "_" + part.name + ".obj")).string();
      WriteObj(path, part.mesh);
      part.mesh = LoadMesh(path);
    }
  }
}

// What rendering the frames shares, and what it gathers.
struct FrameJob {
  const synth::Scene& scene;
  const SynthOptions& options;
  const Camera& camera;
  const fs::path& work;
  const std::vector<VoxelPoint>& surface;        // static surface samples
  std::vector<std::atomic<std::uint8_t>>& seen;  // per sample: some frame saw it
  std::vector<double>& dynamic_share;            // per frame
};

// The color image of frame time `time`, with motion blur and noise when asked.
cv::Mat ColorImage(const FrameJob& job, double time, cv::RNG& rng, Rasterizer* raster) {
  cv::Mat color = raster->Shade(job.scene.materials);
  if (job.options.motion_blur) {
    // Two more renders 8 ms either side of the frame time, averaged (color only).
    cv::Mat sum;
    color.convertTo(sum, CV_32FC3);
    for (double offset : {-0.008, 0.008}) {
      Render(job.scene, job.options.scenario, time + offset, raster, nullptr);
      cv::Mat other;
      raster->Shade(job.scene.materials).convertTo(other, CV_32FC3);
      sum += other;
    }
    sum.convertTo(color, CV_8UC3, 1.0 / 3.0);
  }
  if (job.options.color_noise) {
    cv::Mat noise(color.size(), CV_16SC3);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
    cv::Mat noisy;
    color.convertTo(noisy, CV_16SC3);
    noisy += noise;
    noisy.convertTo(color, CV_8UC3);
  }
  return color;
}

// Renders frame i and writes its color, depth and mask images.
void RenderFrame(const FrameJob& job, size_t i, Rasterizer* raster) {
  const SynthOptions& options = job.options;
  const double time = static_cast<double>(i) / kFrameRate;
  cv::Mat static_depth;
  Render(job.scene, options.scenario, time, raster, &static_depth);
  MarkVisible(job.surface, synth::CameraPose(options.scenario, time).inverse(), static_depth,
              job.camera, options.static_gt_max_range, &job.seen);
  cv::RNG rng(options.seed * 1000003ULL + i);
  const cv::Mat depth = DepthModel(raster->buffers(), job.camera, options.depth_noise, rng);
  const cv::Mat mask = raster->buffers().object_id >= kFirstDynamicId;
  job.dynamic_share[i] = cv::countNonZero(mask) / static_cast<double>(mask.total());
  const cv::Mat color = ColorImage(job, time, rng, raster);
  WritePng((job.work / "rgb" / FrameName(i)).string(), color);
  WritePng((job.work / "depth" / FrameName(i)).string(), depth);
  WritePng((job.work / "masks" / FrameName(i)).string(), mask);
}

// Renders every frame on options.threads threads (frames taken in turn).
void RenderFrames(const FrameJob& job) {
  const size_t frames = job.options.frames;
  std::atomic<size_t> next{0};
  std::mutex failure_mutex;
  std::string failure;
  auto worker = [&] {
    Rasterizer raster(job.camera);
    try {
      for (size_t i = next++; i < frames; i = next++) RenderFrame(job, i, &raster);
    } catch (const std::exception& e) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      failure = e.what();
      next = frames;
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < job.options.threads; ++t) threads.emplace_back(worker);
  worker();
  for (std::thread& thread : threads) thread.join();
  if (!failure.empty()) throw std::runtime_error(failure);
}

// objects.txt (every moving object's pose per frame) and groundtruth.txt.
void WritePoses(const synth::Scene& scene, const SynthOptions& options, const fs::path& work) {
  std::vector<StampedPose> camera_poses;
  std::ofstream objects(work / "objects.txt");
  objects << "# world_from_object of every moving object per frame (people: feet on the floor, "
             "facing +y)\n# timestamp object_id name tx ty tz qx qy qz qw\n";
  char line[256];
  for (size_t i = 0; i < options.frames; ++i) {
    const double time = static_cast<double>(i) / kFrameRate;
    camera_poses.push_back(
        {FrameTime(i), synth::CameraPose(options.scenario, time).cast<double>()});
    for (const synth::MovingObject& object : scene.movers) {
      const Eigen::Isometry3f pose = synth::BodyPose(scene, object, time);
      const Eigen::Quaternionf q(pose.linear());
      std::snprintf(line, sizeof(line), "%.6f %d %s %.6f %.6f %.6f %.7f %.7f %.7f %.7f\n",
                    FrameTime(i), object.id, object.name.c_str(), pose.translation().x(),
                    pose.translation().y(), pose.translation().z(), q.x(), q.y(), q.z(), q.w());
      objects << line;
    }
  }
  if (!objects.flush())
    throw std::runtime_error(WriteFailure((work / "objects.txt").string(), "the objects list"));
  objects.close();
  Trajectory(camera_poses)
      .WriteTum((work / "groundtruth.txt").string(),
                "stillmap synth ground truth: camera-to-world, world z up");
}

void WriteSynthInfo(const SynthOptions& options, const SynthSummary& summary, size_t movers,
                    const fs::path& work) {
  nlohmann::json info = {{"generator", "stillmap synth"},
                         {"scenario", options.scenario},
                         {"frames", options.frames},
                         {"seed", options.seed},
                         {"depth_noise", options.depth_noise},
                         {"color_noise", options.color_noise},
                         {"motion_blur", options.motion_blur},
                         {"static_gt_spacing_m", options.static_gt_spacing},
                         {"static_gt_max_range_m", options.static_gt_max_range},
                         {"static_gt_points", summary.static_gt_points},
                         {"moving_objects", movers},
                         {"dynamic_pixel_share", summary.dynamic_pixel_share}};
  std::ofstream info_file(work / "synth.json");
  info_file << info.dump(2) << "\n";
  if (!info_file.flush())
    throw std::runtime_error(WriteFailure((work / "synth.json").string(), "the run description"));
}

}  // namespace

SynthSummary WriteSyntheticSequence(const std::string& out_dir, const SynthOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.Validate();
  CheckSynthFolder(out_dir);
  OutputSet outputs(
      out_dir, "synth",
      {"rgb/", "depth/", "masks/", "scene/", "rgb.txt", "depth.txt", "masks.txt", "objects.txt",
       "groundtruth.txt", "camera.yaml", "static_gt.ply", "synth.json"});
  const fs::path work = outputs.staging_dir();
  for (const char* sub : {"rgb", "depth", "masks", "scene"}) fs::create_directories(work / sub);
  synth::Scene scene = synth::BuildScene(options.scenario, options.seed);
  PassMeshesThroughFiles(work, &scene);

  const Camera camera = SynthCamera();
  // The static ground truth: surface samples, kept when some frame sees them.
  const std::vector<VoxelPoint> surface = SampleStaticSurfaces(scene, options.static_gt_spacing);
  std::vector<std::atomic<std::uint8_t>> seen(surface.size());
  for (auto& flag : seen) flag.store(0, std::memory_order_relaxed);
  std::vector<double> dynamic_share(options.frames, 0.0);
  RenderFrames({scene, options, camera, work, surface, seen, dynamic_share});

  // Lists, trajectories and ground truth.
  WriteTimestampList((work / "rgb.txt").string(), "color images (stillmap synth)", "rgb",
                     options.frames);
  WriteTimestampList((work / "depth.txt").string(),
                     "depth images (16-bit PNG, 5000 per metre, stillmap synth)", "depth",
                     options.frames);
  WriteTimestampList((work / "masks.txt").string(),
                     "masks of moving objects (8-bit PNG, 255 = dynamic)", "masks", options.frames);
  WritePoses(scene, options, work);
  WriteCameraYaml((work / "camera.yaml").string(), camera,
                  "stillmap synth camera: ideal pinhole, depth registered to color");
  std::vector<VoxelPoint> static_gt;
  for (size_t i = 0; i < surface.size(); ++i) {
    if (seen[i].load(std::memory_order_relaxed) != 0) static_gt.push_back(surface[i]);
  }
  WritePly((work / "static_gt.ply").string(), static_gt);

  SynthSummary summary;
  summary.frames = options.frames;
  summary.static_gt_points = static_gt.size();
  for (double share : dynamic_share) summary.dynamic_pixel_share += share / options.frames;
  summary.seconds = SecondsSince(start);
  WriteSynthInfo(options, summary, scene.movers.size(), work);
  for (const OutputSet::SetAside& entry : outputs.PlanSetAside()) {
    summary.warnings.push_back(outputs.FinalPath(entry.name) +
                               " was not written by stillmap synth; it is kept as " +
                               outputs.FinalPath(entry.kept_as));
  }
  // Replace an earlier output only now that this one is complete.
  outputs.Commit();
  return summary;
}

}  // namespace stillmap
