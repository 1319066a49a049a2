#include "stillmap/synth/synthetic.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "floor_plan.h"
#include "static_truth.h"
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
    if (synth::SphereOutsideView(camera_from_world * object.bound_center, object.bound_radius,
                                 raster->camera(), 0.0f, std::numeric_limits<float>::max())) {
      continue;
    }
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
  if (frames != 0 && (frames < 2 || frames > 100000)) {
    throw InputError("--frames must be between 2 and 100000");
  }
  if (static_gt_spacing != 0.0 && !(static_gt_spacing >= 0.001 && static_gt_spacing <= 0.1)) {
    throw InputError("static_gt_spacing must be between 0.001 and 0.1 m");
  }
  if (!(static_gt_max_range > 0.4)) throw InputError("static_gt_max_range must exceed 0.4 m");
  if (threads < 1) throw InputError("--threads must be at least 1");
}

std::vector<std::string> SynthScenarioNames() {
  return {"static",  "walking_static", "walking_xyz", "walking_rpy", "walking_halfsphere",
          "sitting", "carried_object", "crowd_start", "lens_pass",   "stop_and_go",
          "loop",    "look_alike",     "busy_office", "floor",       "floor_lost"};
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
  synth::StaticTruth& truth;
  std::vector<double>& dynamic_share;  // per frame
};

// Sensor noise on a color image, when asked.
cv::Mat ColorNoise(const FrameJob& job, const cv::Mat& color, cv::RNG& rng) {
  if (!job.options.color_noise) return color;
  cv::Mat noise(color.size(), CV_16SC3);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
  cv::Mat noisy;
  color.convertTo(noisy, CV_16SC3);
  noisy += noise;
  cv::Mat out;
  noisy.convertTo(out, CV_8UC3);
  return out;
}

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
  return ColorNoise(job, color, rng);
}

// A frame taken with the lens covered: black but for the sensor's noise, no depth, nothing
// moving in view.
void WriteCoveredFrame(const FrameJob& job, size_t i) {
  const Camera& camera = job.camera;
  cv::RNG rng(job.options.seed * 1000003ULL + i);
  const cv::Mat black(camera.height, camera.width, CV_8UC3, cv::Scalar::all(0));
  const cv::Mat empty(camera.height, camera.width, CV_16UC1, cv::Scalar(0));
  WritePng((job.work / "rgb" / FrameName(i)).string(), ColorNoise(job, black, rng));
  WritePng((job.work / "depth" / FrameName(i)).string(), empty);
  WritePng((job.work / "masks" / FrameName(i)).string(), cv::Mat(black.size(), CV_8UC1, 0.0));
}

// Renders frame i and writes its color, depth and mask images.
void RenderFrame(const FrameJob& job, size_t i, Rasterizer* raster) {
  const SynthOptions& options = job.options;
  const double time = static_cast<double>(i) / kFrameRate;
  if (synth::FloorLensCovered(options.scenario, time)) return WriteCoveredFrame(job, i);
  cv::Mat static_depth;
  Render(job.scene, options.scenario, time, raster, &static_depth);
  job.truth.MarkVisible(synth::CameraPose(options.scenario, time).inverse(), static_depth,
                        job.camera);
  cv::RNG rng(options.seed * 1000003ULL + i);
  const cv::Mat depth = DepthModel(raster->buffers(), job.camera, options.depth_noise, rng);
  const cv::Mat mask = raster->buffers().object_id >= job.scene.first_dynamic_id;
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

SynthOptions SynthOptions::WithScenarioDefaults() const {
  SynthOptions resolved = *this;
  const bool floor = synth::IsFloorScenario(scenario);
  if (resolved.frames == 0) {
    resolved.frames =
        floor ? static_cast<size_t>(synth::FloorDuration(scenario) * kFrameRate) : 300;
  }
  if (resolved.static_gt_spacing == 0.0) resolved.static_gt_spacing = floor ? 0.01 : 0.005;
  return resolved;
}

SynthSummary WriteSyntheticSequence(const std::string& out_dir, const SynthOptions& requested) {
  const auto start = std::chrono::steady_clock::now();
  requested.Validate();
  const SynthOptions options = requested.WithScenarioDefaults();
  CheckSynthFolder(out_dir);
  OutputSet outputs(
      out_dir, "synth",
      {"rgb/", "depth/", "masks/", "scene/", "rgb.txt", "depth.txt", "masks.txt", "objects.txt",
       "groundtruth.txt", "camera.yaml", "static_gt.ply", "synth.json"});
  const fs::path work = outputs.staging_dir();
  for (const char* sub : {"rgb", "depth", "masks", "scene"}) fs::create_directories(work / sub);
  synth::Scene scene = synth::BuildScene(options.scenario, options.seed);
  PassMeshesThroughFiles(work, &scene);
  synth::BoundStatics(&scene);

  const Camera camera = SynthCamera();
  // The static ground truth: surface samples, kept when some frame sees them.
  synth::StaticTruth truth(scene, options.static_gt_spacing, options.static_gt_max_range);
  std::vector<double> dynamic_share(options.frames, 0.0);
  RenderFrames({scene, options, camera, work, truth, dynamic_share});

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
  const std::vector<VoxelPoint> static_gt = truth.Seen();
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
