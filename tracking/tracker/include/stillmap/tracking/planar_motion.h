// A camera on a ground robot moves in a plane: its height above the floor and its tilt (roll and
// pitch against the floor) are fixed by the mount, only x, y and the heading change (RTAB-Map's
// Reg/Force3DoF, Cartographer's 2-D mode). Tracking does not know this and lets drift into those
// three as well (docs/figures.md, issue 47). With tracking.planar_motion the final poses are put
// back on the plane of motion: always ("on"), or ("auto", the default) only when the tracked poses
// already kept to a plane as a robot's camera does, which a hand-held camera's do not.
//
// The plane is found from the poses alone: the world direction that stays most nearly fixed in the
// camera's frame is the axis the camera turns about, the vertical (the eigenvector of the largest
// eigenvalue of S S^T, S the sum of the camera-to-world rotations); the camera's height along it
// is the median over the poses, and its tilt the mean of that direction seen from the camera. A
// camera that did not turn leaves the vertical undetermined (every direction is then fixed): the
// fit refuses when the headings are too alike.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace stillmap {

struct PlanarMotion {
  Eigen::Vector3d up_in_world = Eigen::Vector3d::UnitZ();   // the axis of the camera's turns
  Eigen::Vector3d up_in_camera = Eigen::Vector3d::UnitZ();  // that axis seen from the camera
  double height_m = 0.0;  // the camera's position along up_in_world (median) [m]
  // How far the poses were from the plane: the standard deviation of their height [m] and the
  // RMS of their tilt against up_in_camera [deg]; and the medians of the two deviations, which
  // a stretch of drifted poses (a segment joined at one place) moves little.
  double height_spread_m = 0.0;
  double tilt_spread_deg = 0.0;
  double height_median_deviation_m = 0.0;
  double tilt_median_deviation_deg = 0.0;
  // The share of the headings' spread: 1 - |mean heading vector| (0: one heading, 1: all ways).
  double heading_spread = 0.0;
};

// The smallest heading spread the fit accepts: below it the vertical is not determined.
constexpr double kMinPlanarHeadingSpread = 0.1;

// Tracked poses whose median deviation from their plane is above this (of their height [m], of
// their tilt [deg]) were more likely carried by hand than by a robot. Medians, so that one drifted
// stretch (a segment joined at one place) does not make a robot's poses look hand-held. The
// height's lies between the synthetic floors' medians (8-20 mm; floor_lost seed 2's tilted
// segment spreads its heights 35 mm, their median 20 mm) and the hand-held rooms' (41 mm and
// more) (docs/figures.md, issue 47).
constexpr double kRobotMaxHeightDeviationM = 0.03;
constexpr double kRobotMaxTiltDeviationDeg = 1.0;

// The tracked poses kept to their plane as a robot's camera does (within the two medians above).
bool KeptToPlane(const PlanarMotion& plane);

// tracking.planar_motion: never, when the tracked poses kept to their plane, or always.
enum class PlanarMotionMode { kOff, kAuto, kOn };
// "off", "auto" or "on", as the configuration writes it.
const char* PlanarMotionModeName(PlanarMotionMode mode);

// The plane of motion of camera-to-world poses; nothing for fewer than three poses or a heading
// spread below kMinPlanarHeadingSpread.
std::optional<PlanarMotion> FitPlanarMotion(
    const std::vector<Eigen::Isometry3d>& world_from_camera);

// The pose on the plane: moved along up_in_world to height_m, and turned the least that makes it
// see up_in_world as up_in_camera (its heading kept).
Eigen::Isometry3d OntoPlane(const PlanarMotion& plane, const Eigen::Isometry3d& world_from_camera);

}  // namespace stillmap
