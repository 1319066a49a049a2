#include "stillmap/pipeline/config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <sstream>

#include "stillmap/io/error.h"
#include "stillmap/io/file_list.h"
#include "stillmap/io/input_files.h"

namespace stillmap {
namespace {

using Setter =
    std::function<void(BuildConfig*, const std::string& value, const std::string& where)>;
using Getter = std::function<std::string(const BuildConfig&)>;  // empty: not set

struct ConfigKey {
  std::string name;
  std::string help;
  Setter set;
  Getter get;
};

[[noreturn]] void BadValue(const std::string& where, const std::string& key,
                           const std::string& value, const std::string& expected) {
  throw InputError(fmt::format("{}: {}={}: expected {}", where, key, value, expected));
}

double ToDouble(const std::string& key, const std::string& value, const std::string& where) {
  double parsed = 0.0;
  if (!ParseFiniteDouble(value, &parsed)) BadValue(where, key, value, "a finite number");
  return parsed;
}

// A whole number that fits `T` exactly (no wrap-around: 4294968496 is refused for an int, not
// read as 1200). Written as digits or in exponent form ("1e3").
template <typename T>
T ToWhole(const std::string& key, const std::string& value, const std::string& where) {
  const double parsed = ToDouble(key, value, where);
  // Bounds as doubles that are exactly representable: [lowest, max + 1).
  const double lowest = static_cast<double>(std::numeric_limits<T>::lowest());
  const double beyond = std::ldexp(1.0, std::numeric_limits<T>::digits);
  if (parsed != std::floor(parsed)) BadValue(where, key, value, "a whole number");
  if (parsed < lowest || parsed >= beyond || parsed > 9007199254740992.0) {
    BadValue(where, key, value,
             fmt::format("a whole number in [{}, {}]", std::numeric_limits<T>::lowest(),
                         std::min<double>(static_cast<double>(std::numeric_limits<T>::max()),
                                          9007199254740992.0)));
  }
  return static_cast<T>(parsed);
}

int ToInt(const std::string& key, const std::string& value, const std::string& where) {
  return ToWhole<int>(key, value, where);
}

size_t ToCount(const std::string& key, const std::string& value, const std::string& where) {
  return ToWhole<size_t>(key, value, where);
}

bool ToBool(const std::string& key, const std::string& value, const std::string& where) {
  if (value == "true" || value == "1" || value == "on" || value == "yes") return true;
  if (value == "false" || value == "0" || value == "off" || value == "no") return false;
  BadValue(where, key, value, "true or false");
}

std::string Number(double value) { return fmt::format("{}", value); }

// Keys bound to fields: a double, a count, a bool.
ConfigKey DoubleKey(const std::string& name, const std::string& help,
                    const std::function<double&(BuildConfig&)>& field) {
  return {name, help,
          [name, field](BuildConfig* c, const std::string& v, const std::string& where) {
            field(*c) = ToDouble(name, v, where);
          },
          [field](const BuildConfig& c) {
            BuildConfig copy = c;
            return Number(field(copy));
          }};
}

ConfigKey OptionalDoubleKey(const std::string& name, const std::string& help,
                            const std::function<std::optional<double>&(BuildConfig&)>& field) {
  return {name, help,
          [name, field](BuildConfig* c, const std::string& v, const std::string& where) {
            field(*c) = ToDouble(name, v, where);
          },
          [field](const BuildConfig& c) {
            BuildConfig copy = c;
            const std::optional<double>& value = field(copy);
            return value ? Number(*value) : std::string();
          }};
}

ConfigKey OptionalIntKey(const std::string& name, const std::string& help,
                         const std::function<std::optional<int>&(BuildConfig&)>& field) {
  return {name, help,
          [name, field](BuildConfig* c, const std::string& v, const std::string& where) {
            field(*c) = ToInt(name, v, where);
          },
          [field](const BuildConfig& c) {
            BuildConfig copy = c;
            const std::optional<int>& value = field(copy);
            return value ? std::to_string(*value) : std::string();
          }};
}

ConfigKey CountKey(const std::string& name, const std::string& help,
                   const std::function<size_t&(BuildConfig&)>& field) {
  return {name, help,
          [name, field](BuildConfig* c, const std::string& v, const std::string& where) {
            field(*c) = ToCount(name, v, where);
          },
          [field](const BuildConfig& c) {
            BuildConfig copy = c;
            return std::to_string(field(copy));
          }};
}

ConfigKey IntKey(const std::string& name, const std::string& help,
                 const std::function<int&(BuildConfig&)>& field) {
  return {name, help,
          [name, field](BuildConfig* c, const std::string& v, const std::string& where) {
            field(*c) = ToInt(name, v, where);
          },
          [field](const BuildConfig& c) {
            BuildConfig copy = c;
            return std::to_string(field(copy));
          }};
}

ConfigKey BoolKey(const std::string& name, const std::string& help,
                  const std::function<bool&(BuildConfig&)>& field) {
  return {name, help,
          [name, field](BuildConfig* c, const std::string& v, const std::string& where) {
            field(*c) = ToBool(name, v, where);
          },
          [field](const BuildConfig& c) {
            BuildConfig copy = c;
            return std::string(field(copy) ? "true" : "false");
          }};
}

const std::vector<ConfigKey>& Keys() {
  static const std::vector<ConfigKey> kKeys = [] {
    std::vector<ConfigKey> k;
    k.push_back({"camera.preset",
                 "tum1|tum2|tum3|bonn|ros_default; used instead of the sequence's camera.yaml",
                 [](BuildConfig* c, const std::string& v, const std::string&) {
                   c->camera.preset = v;
                   if (!v.empty()) CameraPreset(v);  // throws for an unknown name
                 },
                 [](const BuildConfig& c) { return c.camera.preset; }});
    k.push_back(
        OptionalIntKey("camera.width", "image width [px]",
                       [](BuildConfig& c) -> std::optional<int>& { return c.camera.width; }));
    k.push_back(
        OptionalIntKey("camera.height", "image height [px]",
                       [](BuildConfig& c) -> std::optional<int>& { return c.camera.height; }));
    k.push_back(
        OptionalDoubleKey("camera.fx", "focal length x [px]",
                          [](BuildConfig& c) -> std::optional<double>& { return c.camera.fx; }));
    k.push_back(
        OptionalDoubleKey("camera.fy", "focal length y [px]",
                          [](BuildConfig& c) -> std::optional<double>& { return c.camera.fy; }));
    k.push_back(
        OptionalDoubleKey("camera.cx", "principal point x [px]",
                          [](BuildConfig& c) -> std::optional<double>& { return c.camera.cx; }));
    k.push_back(
        OptionalDoubleKey("camera.cy", "principal point y [px]",
                          [](BuildConfig& c) -> std::optional<double>& { return c.camera.cy; }));
    k.push_back({"camera.distortion", "k1,k2,p1,p2,k3 (OpenCV radial-tangential)",
                 [](BuildConfig* c, const std::string& v, const std::string& where) {
                   std::string text = v;
                   for (char& ch : text) {
                     if (ch == '[' || ch == ']') ch = ' ';
                   }
                   const std::vector<std::string> fields = SplitFields(text);
                   if (fields.size() != 5) {
                     BadValue(where, "camera.distortion", v, "5 numbers k1,k2,p1,p2,k3");
                   }
                   std::array<double, 5> d{};
                   for (size_t i = 0; i < 5; ++i)
                     d[i] = ToDouble("camera.distortion", fields[i], where);
                   c->camera.distortion = d;
                 },
                 [](const BuildConfig& c) {
                   if (!c.camera.distortion) return std::string();
                   const auto& d = *c.camera.distortion;
                   return fmt::format("[{}, {}, {}, {}, {}]", d[0], d[1], d[2], d[3], d[4]);
                 }});
    k.push_back(OptionalDoubleKey(
        "camera.depth_factor", "depth PNG value per metre",
        [](BuildConfig& c) -> std::optional<double>& { return c.camera.depth_factor; }));
    k.push_back(DoubleKey(
        "sequence.max_pair_time_difference", "color/depth association window [s] (TUM: 0.02)",
        [](BuildConfig& c) -> double& { return c.sequence.max_pair_time_difference; }));
    k.push_back(DoubleKey(
        "sequence.max_groundtruth_gap", "widest ground-truth gap a pose is interpolated across [s]",
        [](BuildConfig& c) -> double& { return c.sequence.max_groundtruth_gap; }));
    k.push_back(CountKey("sequence.first_frame", "index of the first color/depth pair used",
                         [](BuildConfig& c) -> size_t& { return c.first_frame; }));
    k.push_back(CountKey("sequence.max_frames", "pairs used from first_frame; 0 = all",
                         [](BuildConfig& c) -> size_t& { return c.max_frames; }));
    k.push_back(
        DoubleKey("mapping.min_depth", "depth readings nearer are ignored [m]",
                  [](BuildConfig& c) -> double& { return c.mapping.back_projection.min_depth; }));
    k.push_back(
        DoubleKey("mapping.max_depth", "depth readings farther are ignored [m]",
                  [](BuildConfig& c) -> double& { return c.mapping.back_projection.max_depth; }));
    k.push_back(
        IntKey("mapping.pixel_stride", "back-project every n-th pixel along u and v",
               [](BuildConfig& c) -> int& { return c.mapping.back_projection.pixel_stride; }));
    k.push_back(
        IntKey("mapping.smoothing_radius", "edge-preserving depth smoothing radius [px] (0 = off)",
               [](BuildConfig& c) -> int& { return c.mapping.back_projection.smoothing_radius; }));
    k.push_back(DoubleKey("mapping.voxel_leaf", "voxel edge of the colored cloud [m]",
                          [](BuildConfig& c) -> double& { return c.mapping.voxel.leaf_size; }));
    k.push_back(IntKey(
        "mapping.min_points_per_voxel", "voxels with fewer points are left out of map.ply/map.pcd",
        [](BuildConfig& c) -> int& { return c.mapping.voxel.min_points_per_voxel; }));
    k.push_back(
        BoolKey("mapping.clear_seen_through",
                "drop cloud voxels the OctoMap ends up calling free (later rays saw through them)",
                [](BuildConfig& c) -> bool& { return c.mapping.cleaning.clear_seen_through; }));
    k.push_back(BoolKey(
        "mapping.clear_seen_through_views",
        "drop cloud voxels that fused keyframes saw through, at the cloud's resolution",
        [](BuildConfig& c) -> bool& { return c.mapping.cleaning.clear_seen_through_views; }));
    k.push_back(DoubleKey(
        "mapping.view_margin", "view cleaning: a reading farther by this [m] + sigmas sees through",
        [](BuildConfig& c) -> double& { return c.mapping.cleaning.view_margin_m; }));
    k.push_back(DoubleKey(
        "mapping.view_margin_sigmas", "view cleaning: Kinect noise sigmas added to view_margin",
        [](BuildConfig& c) -> double& { return c.mapping.cleaning.view_margin_sigmas; }));
    k.push_back(IntKey("mapping.min_free_views",
                       "view check: keyframes that must have seen through a voxel",
                       [](BuildConfig& c) -> int& { return c.mapping.cleaning.min_free_views; }));
    k.push_back(DoubleKey(
        "mapping.free_view_ratio",
        "view check: keyframes seeing through a voxel must outnumber those seeing it this often",
        [](BuildConfig& c) -> double& { return c.mapping.cleaning.free_view_ratio; }));
    k.push_back(
        BoolKey("mapping.outlier_removal", "PCL statistical outlier removal on the cloud",
                [](BuildConfig& c) -> bool& { return c.mapping.cleaning.outlier_removal; }));
    k.push_back(
        IntKey("mapping.outlier_neighbors", "outlier removal: neighbours averaged per voxel",
               [](BuildConfig& c) -> int& { return c.mapping.cleaning.outlier_neighbors; }));
    k.push_back(DoubleKey(
        "mapping.outlier_std_ratio",
        "outlier removal: voxels this many standard deviations above the mean distance go",
        [](BuildConfig& c) -> double& { return c.mapping.cleaning.outlier_std_ratio; }));
    k.push_back(BoolKey("octomap.enabled", "build the OctoMap (map.bt, map.ot)",
                        [](BuildConfig& c) -> bool& { return c.mapping.occupancy_enabled; }));
    k.push_back(
        DoubleKey("octomap.resolution", "OctoMap leaf size [m]",
                  [](BuildConfig& c) -> double& { return c.mapping.occupancy.resolution; }));
    k.push_back(DoubleKey("octomap.max_range", "rays truncated at this range [m]; <= 0: none",
                          [](BuildConfig& c) -> double& { return c.mapping.occupancy.max_range; }));
    k.push_back(
        DoubleKey("octomap.probability_hit", "sensor model: P(occupied | hit)",
                  [](BuildConfig& c) -> double& { return c.mapping.occupancy.probability_hit; }));
    k.push_back(
        DoubleKey("octomap.probability_miss", "sensor model: P(occupied | pass-through)",
                  [](BuildConfig& c) -> double& { return c.mapping.occupancy.probability_miss; }));
    k.push_back(
        DoubleKey("octomap.clamping_min", "lower probability clamp",
                  [](BuildConfig& c) -> double& { return c.mapping.occupancy.clamping_min; }));
    k.push_back(
        DoubleKey("octomap.clamping_max", "upper probability clamp",
                  [](BuildConfig& c) -> double& { return c.mapping.occupancy.clamping_max; }));
    auto tracking_int = [&k](const std::string& name, const std::string& help,
                             int TrackerOptions::*field) {
      k.push_back(IntKey("tracking." + name, help,
                         [field](BuildConfig& c) -> int& { return c.tracking.*field; }));
    };
    auto tracking_double = [&k](const std::string& name, const std::string& help,
                                double TrackerOptions::*field) {
      k.push_back(DoubleKey("tracking." + name, help,
                            [field](BuildConfig& c) -> double& { return c.tracking.*field; }));
    };
    k.push_back(IntKey("tracking.max_features", "ORB features per frame",
                       [](BuildConfig& c) -> int& { return c.tracking.features.max_features; }));
    k.push_back(IntKey("tracking.fast_threshold", "FAST corner threshold (lower: more corners)",
                       [](BuildConfig& c) -> int& { return c.tracking.features.fast_threshold; }));
    k.push_back(
        DoubleKey("tracking.max_depth_spread",
                  "keypoints on a depth edge (3x3 spread above this share) get no depth",
                  [](BuildConfig& c) -> double& { return c.tracking.features.max_depth_spread; }));
    tracking_double("search_radius", "projection search radius around the prediction [px]",
                    &TrackerOptions::search_radius_px);
    tracking_double("wide_search_radius", "second, wider projection search radius [px]",
                    &TrackerOptions::wide_search_radius_px);
    tracking_int("max_descriptor_distance", "largest Hamming distance of a match (of 256)",
                 &TrackerOptions::max_descriptor_distance);
    tracking_double("sigma_px", "keypoint noise at pyramid level 0 [px]",
                    &TrackerOptions::sigma_px);
    tracking_double("sigma_inverse_depth", "keypoint depth noise, in inverse depth [1/m]",
                    &TrackerOptions::sigma_inverse_depth);
    tracking_double("far_depth", "far depth: beyond this depth [m] (see far_depth_power)",
                    &TrackerOptions::far_depth);
    tracking_double(
        "far_depth_power",
        "inverse-depth noise times (z / far_depth)^this beyond far_depth (0: off; Bonn/Xtion: 4)",
        &TrackerOptions::far_depth_power);
    k.push_back(
        BoolKey("tracking.depth_self_calibration",
                "estimate and correct the depth sensor's error over the image (depth_correction.h)",
                [](BuildConfig& c) -> bool& { return c.tracking.depth_self_calibration; }));
    tracking_int("depth_calibration_interval", "refit the depth correction every n keyframes",
                 &TrackerOptions::depth_calibration_interval);
    k.push_back(DoubleKey(
        "tracking.depth_calibration_max_delta",
        "a depth correction beyond this share anywhere in the image is refused",
        [](BuildConfig& c) -> double& { return c.tracking.depth_calibration.max_delta; }));
    tracking_double("max_landmark_depth", "landmarks are made from depth up to this [m]",
                    &TrackerOptions::max_landmark_depth);
    tracking_double("keyframe_ratio",
                    "new keyframe when inliers fall below this share of the reference's landmarks",
                    &TrackerOptions::keyframe_ratio);
    tracking_int("max_keyframe_interval", "a keyframe at least every this many frames",
                 &TrackerOptions::max_keyframe_interval);
    tracking_int("min_keyframe_interval",
                 "keyframes at least this many frames apart unless tracking is weak",
                 &TrackerOptions::min_keyframe_interval);
    tracking_int("min_keyframe_inliers", "no keyframe with this many inliers or fewer",
                 &TrackerOptions::min_keyframe_inliers);
    tracking_int("close_tracked_max",
                 "near-point rule: fewer near points than this tracked (with close_untracked_min)",
                 &TrackerOptions::close_tracked_max);
    tracking_int("close_untracked_min", "near-point rule: more near points than this untracked",
                 &TrackerOptions::close_untracked_min);
    tracking_double("cull_found_ratio",
                    "recent landmarks found in fewer than this share of their visible frames go",
                    &TrackerOptions::cull_found_ratio);
    tracking_int("cull_min_visible", "frames a landmark must be visible in before that rule",
                 &TrackerOptions::cull_min_visible);
    tracking_int("cull_single_view_age",
                 "keyframes after which a landmark seen by one keyframe only goes",
                 &TrackerOptions::cull_single_view_age);
    tracking_int("cull_recent_age", "keyframes a landmark stays subject to culling",
                 &TrackerOptions::cull_recent_age);
    tracking_int("local_map_keyframes", "keyframes whose landmarks are searched for per frame",
                 &TrackerOptions::local_map_keyframes);
    tracking_int("local_window", "keyframes optimized by the local bundle adjustment",
                 &TrackerOptions::local_window);
    k.push_back(
        BoolKey("tracking.background_bundle_adjustment",
                "run the local bundle adjustment on its own thread (false: inline, "
                "deterministic)",
                [](BuildConfig& c) -> bool& { return c.tracking.background_bundle_adjustment; }));
    tracking_int("min_tracked", "inliers for a frame to count as tracked",
                 &TrackerOptions::min_tracked);
    tracking_int("new_map_after_lost",
                 "consecutive lost frames before a new local map starts at the last good pose",
                 &TrackerOptions::new_map_after_lost);
    k.push_back(BoolKey("masking.enabled", "dynamic rejection (false: every pixel is used)",
                        [](BuildConfig& c) -> bool& { return c.masking_enabled; }));
    auto masking_bool = [&k](const std::string& name, const std::string& help,
                             bool DynamicMaskOptions::*field) {
      k.push_back(BoolKey("masking." + name, help,
                          [field](BuildConfig& c) -> bool& { return c.masking.*field; }));
    };
    auto masking_int = [&k](const std::string& name, const std::string& help,
                            int DynamicMaskOptions::*field) {
      k.push_back(IntKey("masking." + name, help,
                         [field](BuildConfig& c) -> int& { return c.masking.*field; }));
    };
    auto masking_double = [&k](const std::string& name, const std::string& help,
                               double DynamicMaskOptions::*field) {
      k.push_back(DoubleKey("masking." + name, help,
                            [field](BuildConfig& c) -> double& { return c.masking.*field; }));
    };
    masking_bool("semantics", "use the detector's detections", &DynamicMaskOptions::semantics);
    masking_bool("depth_check", "multi-view depth check against keyframes (paper 002)",
                 &DynamicMaskOptions::depth_check);
    masking_bool("flow_check", "KLT flow / epipolar distance DBSCAN check (paper 004)",
                 &DynamicMaskOptions::flow_check);
    k.push_back(DoubleKey(
        "masking.depth_difference",
        "tau_d: nearer than the keyframe's static depth by this [m] "
        "(paper 002: 0.4)",
        [](BuildConfig& c) -> double& { return c.masking.depth.max_depth_difference_m; }));
    k.push_back(
        DoubleKey("masking.max_parallax_deg",
                  "depth-check points seen under more parallax are skipped "
                  "(paper 002: 30)",
                  [](BuildConfig& c) -> double& { return c.masking.depth.max_parallax_deg; }));
    k.push_back(
        DoubleKey("masking.flow_epsilon_px",
                  "DBSCAN radius in the (flow length, epipolar distance) plane "
                  "[px] (paper 004)",
                  [](BuildConfig& c) -> double& { return c.masking.flow.dbscan_epsilon_px; }));
    k.push_back(IntKey("masking.flow_min_points", "DBSCAN core-point neighbours (paper 004)",
                       [](BuildConfig& c) -> int& { return c.masking.flow.dbscan_min_points; }));
    k.push_back(DoubleKey(
        "masking.flow_min_epipolar_px",
        "flow check: points outside the camera's cluster flagged only this far off their "
        "epipolar line [px]",
        [](BuildConfig& c) -> double& { return c.masking.flow.min_epipolar_distance_px; }));
    masking_int("flow_points", "corners tracked for the flow check",
                &DynamicMaskOptions::flow_points);
    masking_int("reference_keyframes", "keyframes the depth check compares with",
                &DynamicMaskOptions::reference_keyframes);
    masking_double("reference_spacing_s", "older references at least this far apart [s]",
                   &DynamicMaskOptions::reference_spacing_s);
    masking_int("depth_check_stride",
                "depth check: one verdict per n x n block of continuous readings",
                &DynamicMaskOptions::depth_check_stride);
    masking_double("grow_depth_difference",
                   "regions grow over pixels nearer than the static depth by this [m] (+ noise)",
                   &DynamicMaskOptions::grow_depth_difference_m);
    masking_double("grow_noise_sigmas",
                   "growth margin: grow_depth_difference + this many sigmas of Kinect noise",
                   &DynamicMaskOptions::grow_noise_sigmas);
    masking_double("seed_noise_factor", "seeds lie nearer by more than this many growth margins",
                   &DynamicMaskOptions::seed_noise_factor);
    masking_double("block_continuity",
                   "a reading takes its check block's verdict within 1 cm + this share of depth",
                   &DynamicMaskOptions::block_continuity);
    masking_double("continuity", "neighbours within 1 cm + this share of depth are one surface",
                   &DynamicMaskOptions::continuity);
    masking_int("max_unknown_steps", "growth through pixels no reference saw [px]",
                &DynamicMaskOptions::max_unknown_steps);
    k.push_back(
        {"masking.outline",
         "box detections cut to: depth (foreground), edges (Canny, paper 000), box",
         [](BuildConfig* c, const std::string& v, const std::string& where) {
           try {
             c->masking.outline = ParseOutlineMode(v);
           } catch (const InputError& e) {
             throw InputError(where + ": " + e.what());
           }
         },
         [](const BuildConfig& c) { return std::string(OutlineModeName(c.masking.outline)); }});
    masking_bool("outline_whole_box",
                 "depth outline seeded anywhere in the box, not only its centre, where not "
                 "confirmed static",
                 &DynamicMaskOptions::outline_whole_box);
    masking_double("medium_min_moving_share",
                   "medium-level objects are masked when geometry marks this share of them",
                   &DynamicMaskOptions::medium_min_moving_share);
    masking_int("detector_interval", "run the detector every n-th frame (boxes carried between)",
                &DynamicMaskOptions::detector_interval);
    masking_int("margin_px", "safety margin around moving objects [px]",
                &DynamicMaskOptions::margin_px);
    masking_int("min_region_px", "geometric regions smaller than this are dropped [px]",
                &DynamicMaskOptions::min_region_px);
    k.push_back(IntKey("masking.groundtruth_reference_interval",
                       "with --poses groundtruth, every n-th frame is a depth-check reference",
                       [](BuildConfig& c) -> int& { return c.groundtruth_reference_interval; }));
    k.push_back(BoolKey("masking.map_recheck",
                        "re-run the depth check on each keyframe against its neighbours (both "
                        "sides in time, final poses) before fusing it",
                        [](BuildConfig& c) -> bool& { return c.map_recheck; }));
    k.push_back(BoolKey("render.enabled", "write the renders (renders/*.png) at the end of a build",
                        [](BuildConfig& c) -> bool& { return c.render.enabled; }));
    k.push_back(BoolKey("mesh.enabled", "write the mesh (mesh.glb, or mesh.obj / mesh.ply)",
                        [](BuildConfig& c) -> bool& { return c.mesh.enabled; }));
    k.push_back(
        {"mesh.format", "glb, obj or ply",
         [](BuildConfig* c, const std::string& v, const std::string&) { c->mesh.format = v; },
         [](const BuildConfig& c) { return c.mesh.format; }});
    k.push_back(DoubleKey("mesh.voxel", "edge of the mesh's voxels [m]",
                          [](BuildConfig& c) -> double& { return c.mesh.voxel; }));
    k.push_back(IntKey("mesh.min_points", "map points a mesh voxel needs",
                       [](BuildConfig& c) -> int& { return c.mesh.min_points; }));
    k.push_back(BoolKey("grid.enabled", "write the 2-D occupancy grid (grid.pgm, grid.yaml)",
                        [](BuildConfig& c) -> bool& { return c.grid.enabled; }));
    k.push_back(DoubleKey("grid.min_height",
                          "lowest height above the floor that blocks a grid cell [m]",
                          [](BuildConfig& c) -> double& { return c.grid.min_height; }));
    k.push_back(DoubleKey("grid.max_height", "robot height: highest blocking height [m]",
                          [](BuildConfig& c) -> double& { return c.grid.max_height; }));
    k.push_back(DoubleKey("grid.occupied_probability",
                          "a voxel blocks its grid cell above this occupancy probability",
                          [](BuildConfig& c) -> double& { return c.grid.occupied_probability; }));
    k.push_back(DoubleKey(
        "grid.confirm_probability",
        "occupied cells stay occupied only when connected to one above this (else unknown)",
        [](BuildConfig& c) -> double& { return c.grid.confirm_probability; }));
    k.push_back(IntKey("grid.floor_ransac_rounds", "floor fit: planes tried at most",
                       [](BuildConfig& c) -> int& { return c.grid.floor_ransac_rounds; }));
    k.push_back(IntKey("grid.floor_ransac_iterations", "floor fit: RANSAC samples per plane",
                       [](BuildConfig& c) -> int& { return c.grid.floor_ransac_iterations; }));
    k.push_back(IntKey("grid.floor_min_points", "floor fit: fewest inliers of a plane",
                       [](BuildConfig& c) -> int& { return c.grid.floor_min_points; }));
    k.push_back(IntKey("grid.floor_min_inliers_per_mille",
                       "floor fit: fewest inliers, per mille of the voxels",
                       [](BuildConfig& c) -> int& { return c.grid.floor_min_inliers_per_mille; }));
    k.push_back(DoubleKey("grid.max_floor_tilt_deg",
                          "a fitted floor's normal is within this of the cameras' up",
                          [](BuildConfig& c) -> double& { return c.grid.max_floor_tilt_deg; }));
    k.push_back({"grid.floor",
                 "auto (fit a plane to the map) or 'a b c d': the floor a x + b y + c z + d = 0 in "
                 "the world frame, (a, b, c) pointing up",
                 [](BuildConfig* c, const std::string& v, const std::string& where) {
                   if (v == "auto") {
                     c->grid.floor.reset();
                     return;
                   }
                   std::stringstream in(v);
                   Eigen::Vector4d plane;
                   for (int i = 0; i < 4; ++i) {
                     std::string item;
                     if (!(in >> item)) BadValue(where, "grid.floor", v, "auto or four numbers");
                     plane[i] = ToDouble("grid.floor", item, where);
                   }
                   std::string extra;
                   if (in >> extra) BadValue(where, "grid.floor", v, "auto or four numbers");
                   c->grid.floor = plane;
                 },
                 [](const BuildConfig& c) {
                   if (!c.grid.floor) return std::string("auto");
                   const Eigen::Vector4d& p = *c.grid.floor;
                   return "\"" + Number(p[0]) + " " + Number(p[1]) + " " + Number(p[2]) + " " +
                          Number(p[3]) + "\"";
                 }});
    k.push_back(BoolKey("keyframes.selection",
                        "fuse only valid, non-redundant keyframes (paper 000)",
                        [](BuildConfig& c) -> bool& { return c.selection.enabled; }));
    k.push_back(DoubleKey("keyframes.max_masked_share",
                          "invalid: a larger share of the frame is masked as moving",
                          [](BuildConfig& c) -> double& { return c.selection.max_masked_share; }));
    k.push_back(DoubleKey(
        "keyframes.max_shared_landmarks",
        "redundant: more than this share of its landmarks is seen by the selected keyframes",
        [](BuildConfig& c) -> double& { return c.selection.max_shared_landmarks; }));
    k.push_back(DoubleKey("detector.score_threshold", "YOLOX: objectness x class probability",
                          [](BuildConfig& c) -> double& { return c.yolox.score_threshold; }));
    k.push_back({"detector.levels",
                 "motion-level overrides, e.g. chair=low,book=high (levels: high, medium, low)",
                 [](BuildConfig* c, const std::string& v, const std::string& where) {
                   BuildConfig copy = *c;
                   copy.detector_levels = v;
                   try {
                     MotionLevels(copy);
                   } catch (const InputError& e) {
                     throw InputError(where + ": detector.levels: " + e.what());
                   }
                   c->detector_levels = v;
                 },
                 [](const BuildConfig& c) { return c.detector_levels; }});
    k.push_back(DoubleKey("eval.max_time_difference", "ATE association window [s]",
                          [](BuildConfig& c) -> double& { return c.ate.max_time_difference; }));
    k.push_back(DoubleKey("eval.rpe_delta", "RPE pose-pair time delta [s]",
                          [](BuildConfig& c) -> double& { return c.rpe.delta; }));
    return k;
  }();
  return kKeys;
}

const ConfigKey& FindKey(const std::string& name, const std::string& where) {
  for (const ConfigKey& key : Keys()) {
    if (key.name == name) return key;
  }
  std::string known;
  for (const ConfigKey& key : Keys()) known += " " + key.name;
  throw InputError(
      fmt::format("{}: unknown configuration key '{}' (known:{})", where, name, known));
}

void Flatten(const YAML::Node& node, const std::string& prefix, const std::string& path,
             std::vector<std::pair<std::string, YAML::Node>>* out) {
  for (const auto& item : node) {
    const std::string name = (prefix.empty() ? "" : prefix + ".") + item.first.as<std::string>();
    if (item.second.IsMap()) {
      Flatten(item.second, name, path, out);
    } else {
      out->emplace_back(name, item.second);
    }
  }
}

}  // namespace

void BuildConfig::Validate() const {
  // Association looks at every pair within the window: beyond a second it pairs wrong frames and
  // its candidates grow with the square of the frame rate.
  if (!(sequence.max_pair_time_difference > 0.0 && sequence.max_pair_time_difference <= 1.0)) {
    throw InputError("sequence.max_pair_time_difference must be in (0, 1] s");
  }
  if (!(sequence.max_groundtruth_gap > 0.0)) {
    throw InputError("sequence.max_groundtruth_gap must be positive");
  }
  if (!(ate.max_time_difference > 0.0 && ate.max_time_difference <= 1.0)) {
    throw InputError("eval.max_time_difference must be in (0, 1] s");
  }
  if (!(rpe.delta > 0.0)) throw InputError("eval.rpe_delta must be > 0");
  if (groundtruth_reference_interval < 1 || groundtruth_reference_interval > 1000) {
    throw InputError("masking.groundtruth_reference_interval must be 1..1000 frames");
  }
  mapping.Validate();
  tracking.Validate();
  masking.Validate();
  selection.Validate();
  grid.Validate();
  mesh.Validate();
  if (!(yolox.score_threshold > 0.0 && yolox.score_threshold < 1.0)) {
    throw InputError("detector.score_threshold must be in (0, 1)");
  }
}

MotionLevelTable MotionLevels(const BuildConfig& config) {
  MotionLevelTable table = MotionLevelTable::Default();
  std::stringstream entries(config.detector_levels);
  std::string entry;
  while (std::getline(entries, entry, ',')) {
    if (entry.empty()) continue;
    const size_t equals = entry.find('=');
    if (equals == std::string::npos || equals == 0) {
      throw InputError("'" + entry + "' is not name=level");
    }
    table.Set(entry.substr(0, equals), entry.substr(equals + 1));
  }
  return table;
}

std::vector<ConfigKeyInfo> ListConfigKeys() {
  std::vector<ConfigKeyInfo> infos;
  for (const ConfigKey& key : Keys()) infos.push_back({key.name, key.help});
  return infos;
}

void SetConfigValue(BuildConfig* config, const std::string& key, const std::string& value,
                    const std::string& where) {
  FindKey(key, where).set(config, value, where);
}

void ApplySetArgument(BuildConfig* config, const std::string& argument) {
  const size_t equals = argument.find('=');
  if (equals == std::string::npos || equals == 0) {
    throw InputError("--set " + argument +
                     ": expected key=value, e.g. --set mapping.voxel_leaf=0.02");
  }
  SetConfigValue(config, argument.substr(0, equals), argument.substr(equals + 1), "--set");
}

void ApplyConfigFile(BuildConfig* config, const std::string& path) {
  CheckInputFile(path, "configuration file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw InputError(path + ": cannot open the configuration file");
  } catch (const YAML::Exception& e) {
    throw InputError(WhereInFile(path, e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (root.IsNull()) return;
  if (!root.IsMap()) throw InputError(path + ": expected a YAML map of configuration keys");
  std::vector<std::pair<std::string, YAML::Node>> entries;
  Flatten(root, "", path, &entries);
  for (const auto& [name, node] : entries) {
    const std::string where = WhereInFile(path, node.Mark().line + 1);
    std::string value;
    if (node.IsSequence()) {
      for (const YAML::Node& item : node) {
        if (!value.empty()) value += ',';
        value += item.as<std::string>();
      }
    } else if (node.IsScalar()) {
      value = node.as<std::string>();
    } else if (!node.IsNull()) {
      throw InputError(fmt::format("{}: key '{}' must hold a value", where, name));
    }
    SetConfigValue(config, name, value, where);
  }
}

std::string ConfigToYaml(const BuildConfig& config) {
  std::ostringstream out;
  out << "# stillmap effective configuration; rerun with: stillmap build SEQ -o OUT --config "
         "config.yaml\n";
  std::string section;
  for (const ConfigKey& key : Keys()) {
    const size_t dot = key.name.find('.');
    const std::string key_section = key.name.substr(0, dot);
    const std::string value = key.get(config);
    if (value.empty()) continue;  // unset optional keys stay unset
    if (key_section != section) {
      out << key_section << ":\n";
      section = key_section;
    }
    out << "  " << key.name.substr(dot + 1) << ": " << value << "  # " << key.help << "\n";
  }
  return out.str();
}

}  // namespace stillmap
