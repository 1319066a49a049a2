// The robot's path through the synthetic floor: once round the corridor loop going into every room
// (and round each room's middle), then round the loop again; the camera at a robot's height,
// looking ahead along the path with a slow pan. floor_lost covers the lens twice, once while the
// camera is carried from room A to room B.
#include <cmath>
#include <vector>

#include "floor_plan.h"
#include "scene_geometry.h"

namespace stillmap::synth {
namespace {

constexpr float kSpeed = 0.45f;        // along the path [m/s]
constexpr float kLookAhead = 1.5f;     // the camera looks at the path this far ahead [m]
constexpr float kHeight = 0.9f;        // camera above the floor [m]
constexpr float kPitch = -0.14f;       // looking down [rad]
constexpr float kPanAmplitude = 0.3f;  // [rad]
constexpr float kPanPeriod = 10.0f;    // [s]
constexpr float kRoomInset = 1.3f;  // the path round a room's middle keeps this off its walls [m]
constexpr float kCoverSeconds = 3.0f;  // each time the lens is covered (floor_lost) [s]
// The corridor loop's middle lines.
constexpr float kSouth = 4.83f, kNorth = 9.18f, kWest = 0.8f, kEast = 15.2f;

class FloorPath {
 public:
  FloorPath() {
    To(1.5f, kSouth);
    VisitRoom(FloorRooms()[0], kSouth, nullptr, &carry_from_);
    VisitRoom(FloorRooms()[1], kSouth, &carry_to_, nullptr);
    To(kEast, kSouth);
    To(kEast, kNorth);
    float leave_meeting = 0.0f;
    VisitRoom(FloorRooms()[2], kNorth, nullptr, nullptr);
    leave_meeting = arc_.back();
    cover_at_ = leave_meeting + 3.0f;
    VisitRoom(FloorRooms()[3], kNorth, nullptr, nullptr);
    To(kWest, kNorth);
    To(kWest, kSouth);
    To(kEast, kSouth);  // the second time round
    To(kEast, kNorth);
    To(kWest, kNorth);
    To(kWest, kSouth);
    To(3.5f, kSouth);
  }

  float length() const { return arc_.back(); }
  float carry_from() const { return carry_from_; }
  float carry_to() const { return carry_to_; }
  float cover_at() const { return cover_at_; }

  Eigen::Vector2f At(float s) const {
    s = std::clamp(s, 0.0f, length());
    const size_t i =
        static_cast<size_t>(std::upper_bound(arc_.begin(), arc_.end(), s) - arc_.begin());
    if (i >= points_.size()) return points_.back();
    const float t = (s - arc_[i - 1]) / (arc_[i] - arc_[i - 1]);
    return points_[i - 1] + t * (points_[i] - points_[i - 1]);
  }

 private:
  void To(float x, float y) {
    const Eigen::Vector2f next(x, y);
    if (!points_.empty() && (next - points_.back()).norm() < 1e-4f) return;
    arc_.push_back(points_.empty() ? 0.0f : arc_.back() + (next - points_.back()).norm());
    points_.push_back(next);
  }

  // In through the door, round the room's middle, and out; `entered` and `leaving` get the arc
  // lengths where the round begins and ends.
  void VisitRoom(const FloorRoom& room, float corridor_y, float* entered, float* leaving) {
    const FloorRect& r = room.inside;
    const float door_side = room.south_of_corridor ? r.y1 - kRoomInset : r.y0 + kRoomInset;
    const float far_side = room.south_of_corridor ? r.y0 + kRoomInset : r.y1 - kRoomInset;
    const float x_lo = r.x0 + kRoomInset, x_hi = r.x1 - kRoomInset;
    To(room.door_x, corridor_y);
    To(room.door_x, door_side);
    if (entered != nullptr) *entered = arc_.back();
    To(x_hi, door_side);
    To(x_hi, far_side);
    To(x_lo, far_side);
    To(x_lo, door_side);
    To(room.door_x, door_side);
    if (leaving != nullptr) *leaving = arc_.back();
    To(room.door_x, corridor_y);
  }

  std::vector<Eigen::Vector2f> points_;
  std::vector<float> arc_;
  float carry_from_ = 0.0f, carry_to_ = 0.0f, cover_at_ = 0.0f;
};

const FloorPath& Path() {
  static const FloorPath kPath;
  return kPath;
}

bool Lost(const std::string& scenario) { return scenario == "floor_lost"; }

// When floor_lost's carry begins [s].
float CarryStart() { return Path().carry_from() / kSpeed; }

// Metres along the path at `time`: at the robot's speed, but in floor_lost the stretch from room
// A to room B is crossed in kCoverSeconds, carried with the lens covered.
float PathPosition(const std::string& scenario, float time) {
  const FloorPath& path = Path();
  if (!Lost(scenario) || time < CarryStart()) return kSpeed * time;
  const float carried = time - CarryStart();
  if (carried < kCoverSeconds) {
    return path.carry_from() + (path.carry_to() - path.carry_from()) * carried / kCoverSeconds;
  }
  return path.carry_to() + kSpeed * (carried - kCoverSeconds);
}

}  // namespace

double FloorDuration(const std::string& scenario) {
  const FloorPath& path = Path();
  if (!Lost(scenario)) return path.length() / kSpeed;
  return CarryStart() + kCoverSeconds + (path.length() - path.carry_to()) / kSpeed;
}

bool FloorLensCovered(const std::string& scenario, double time) {
  if (!Lost(scenario)) return false;
  const float t = static_cast<float>(time);
  const float second =
      CarryStart() + kCoverSeconds + (Path().cover_at() - Path().carry_to()) / kSpeed;
  return (t >= CarryStart() && t < CarryStart() + kCoverSeconds) ||
         (t >= second && t < second + kCoverSeconds);
}

Eigen::Isometry3f FloorCameraPose(const std::string& scenario, double time) {
  const FloorPath& path = Path();
  const float t = static_cast<float>(time);
  const float s = PathPosition(scenario, t);
  const Eigen::Vector2f here = path.At(s);
  Eigen::Vector2f ahead = path.At(s + kLookAhead) - here;
  if (ahead.norm() < 1e-3f) ahead = here - path.At(s - kLookAhead);
  const float yaw =
      std::atan2(ahead.y(), ahead.x()) + kPanAmplitude * std::sin(2.0f * kPi * t / kPanPeriod);
  const Eigen::Vector3f position(here.x(), here.y(), kHeight + 0.004f * std::sin(7.0f * t));
  const Eigen::Vector3f look(std::cos(yaw) * std::cos(kPitch), std::sin(yaw) * std::cos(kPitch),
                             std::sin(kPitch));
  return LookAt(position, position + look, 0.0f);
}

}  // namespace stillmap::synth
