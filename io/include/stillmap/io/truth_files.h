// The ground truth a synthetic sequence carries beyond its trajectory (stillmap synth writes it):
// masks of the moving pixels (masks.txt + masks/) and the moving objects' poses (objects.txt).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace stillmap {

// The masks of moving pixels listed in SEQUENCE/masks.txt, looked up by timestamp.
class TruthMasks {
 public:
  // Reads SEQUENCE/masks.txt when it exists (none: available() is false). Throws InputError for
  // a malformed list.
  explicit TruthMasks(const std::string& sequence_dir);
  bool available() const { return !times_.empty(); }
  // The mask of the frame at `time` (CV_8UC1, non-zero = moving), or empty when none is listed
  // within 1 ms. Throws InputError for an unreadable mask.
  cv::Mat Get(double time) const;

 private:
  std::vector<double> times_;
  std::vector<std::string> paths_;
};

// One line of objects.txt: a moving object's pose at one frame.
struct ObjectPose {
  double time = 0.0;  // [s]
  std::string id;     // the object's id (people: 100, 101, ...)
  std::string name;   // "person_0"
  Eigen::Isometry3d world_from_object = Eigen::Isometry3d::Identity();  // people: feet on floor
};

// Reads objects.txt ("timestamp object_id name tx ty tz qx qy qz qw" per line, '#' comments).
// Throws InputError naming the file and line for a malformed line (a missing field, a number that
// is not finite, a quaternion far from unit length).
std::vector<ObjectPose> ReadObjectPoses(const std::string& path);

}  // namespace stillmap
