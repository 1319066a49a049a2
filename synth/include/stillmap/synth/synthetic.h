// `stillmap synth`: dynamic RGB-D sequences of a furnished room (or a floor) with walking people,
// rendered on the CPU with a Kinect-like depth model, and the ground truth no real dataset has:
// per-frame masks of moving pixels, the static scene's surface, and every moving object's pose.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "stillmap/io/camera.h"

namespace stillmap {

struct SynthOptions {
  std::string scenario;              // one of SynthScenarioNames()
  size_t frames = 0;                 // at 30 Hz; 0: the scenario's (300, or a floor's whole path)
  std::uint64_t seed = 1;            // textures, paths and noise; same seed, same bytes
  bool depth_noise = true;           // Kinect-like noise, quantization and missing readings
  bool color_noise = true;           // mild per-pixel color noise (sigma 2 levels)
  bool motion_blur = false;          // average of 3 renders over an 16 ms exposure (color only)
  double static_gt_spacing = 0.0;    // sampling of static_gt.ply [m]; 0: 5 mm, on a floor 1 cm
  double static_gt_max_range = 4.0;  // static points farther from every camera are left out [m]
  int threads = 2;                   // frames rendered in parallel

  // Throws InputError naming the first impossible value.
  void Validate() const;
  // A copy with the scenario's frames and static_gt_spacing where they are 0.
  SynthOptions WithScenarioDefaults() const;
};

// static, walking_static, walking_xyz, walking_rpy, walking_halfsphere, sitting, carried_object,
// crowd_start (three people in view from the first frame), lens_pass (a person crossing 0.4-0.7 m
// before the lens), stop_and_go (a person walks in, stands 4 s, walks out), busy_office (the
// three at once: two people in view from the first frame, one crossing before the lens, one
// standing still for 4 s); floor (a robot's camera going round a 224 m^2 floor of four rooms off a
// 37.6 m corridor loop twice, into every room, with eight people: 329 s) and floor_lost (the same
// with the lens covered for 3 s twice, once while carried from one room to the next).
// The room scenarios' default length is 300 frames; the floor's is its whole path.
std::vector<std::string> SynthScenarioNames();

// The camera of every synthetic sequence: 640x480, fx = fy = 525, cx = 319.5, cy = 239.5, no
// distortion, 5000 depth units per metre (the "ROS default" Kinect).
Camera SynthCamera();

struct SynthSummary {
  size_t frames = 0;
  size_t static_gt_points = 0;
  double dynamic_pixel_share = 0.0;  // mean share of mask pixels per frame
  double seconds = 0.0;
  std::vector<std::string> warnings;  // files of the folder kept aside, renamed (not ours)
};

// Writes a TUM-layout sequence to `out_dir`: rgb/, depth/, rgb.txt, depth.txt, groundtruth.txt,
// camera.yaml, masks/ + masks.txt (255 = a moving object's pixel), static_gt.ply (static surface
// seen by the camera within static_gt_max_range, sampled every static_gt_spacing), objects.txt
// (every moving object's world pose per frame) and scene/ (the meshes, as OBJ, loaded back through
// assimp for rendering). Files are written under temporary names and renamed when complete.
SynthSummary WriteSyntheticSequence(const std::string& out_dir, const SynthOptions& options);

}  // namespace stillmap
