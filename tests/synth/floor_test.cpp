// The synthetic floor (issue 47) against what it promises, checked on the scene itself: its
// area, rooms and corridor loop, a camera that never passes through a wall or a piece of
// furniture and goes round the loop twice and into every room, the people, and floor_lost's
// covered lens.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "floor_plan.h"
#include "stillmap/synth/synthetic.h"
#include "synthetic_scene.h"

namespace stillmap {
namespace {

using synth::FloorRooms;

// The point of triangle abc closest to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3f ClosestOnTriangle(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                                  const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  const Eigen::Vector3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  }
  const float denominator = 1.0f / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

float DistanceToStatics(const synth::Scene& scene, const Eigen::Vector3f& p) {
  float best = std::numeric_limits<float>::max();
  for (const synth::StaticObject& object : scene.statics) {
    for (const auto& f : object.mesh.faces) {
      const Eigen::Vector3f q = ClosestOnTriangle(
          p, object.mesh.vertices[f[0]], object.mesh.vertices[f[1]], object.mesh.vertices[f[2]]);
      best = std::min(best, (q - p).norm());
    }
  }
  return best;
}

bool Inside(const synth::FloorRect& r, const Eigen::Vector3f& p) {
  return p.x() > r.x0 && p.x() < r.x1 && p.y() > r.y0 && p.y() < r.y1;
}

TEST(FloorTest, IsABuildingOfFourDifferentlyFurnishedRoomsOffACorridorLoop) {
  const synth::Scene scene = synth::BuildScene("floor", 1);
  double floor_area = 0.0;
  std::map<std::string, std::set<std::string>> furniture;  // per room: its kinds of furniture
  for (const synth::StaticObject& object : scene.statics) {
    const std::string& name = object.name;
    if (name.find("_floor") != std::string::npos) floor_area += object.mesh.Area();
    for (const synth::FloorRoom& room : FloorRooms()) {
      const std::string prefix = std::string(room.name) + "_";
      if (name.rfind(prefix, 0) != 0) continue;
      const std::string kind =
          name.substr(prefix.size(), name.find('_', prefix.size()) - prefix.size());
      static const std::set<std::string> kStructure{"south", "north",   "east",  "west",
                                                    "floor", "ceiling", "light", "door"};
      if (kStructure.count(kind) == 0) furniture[room.name].insert(kind);
    }
  }
  EXPECT_GE(floor_area, 150.0);
  ASSERT_EQ(furniture.size(), 4u);
  for (const auto& [room, kinds] : furniture) {
    EXPECT_GE(kinds.size(), 3u) << room;
    for (const auto& [other, other_kinds] : furniture) {
      if (other != room) {
        EXPECT_NE(kinds, other_kinds) << room << " is furnished as " << other;
      }
    }
  }
  // The corridor loop's middle line, half-way between the core and the rooms' walls.
  const synth::FloorRect& core = synth::kFloorCore;
  const float west = core.x0 / 2, east = (core.x1 + synth::kFloorBuilding.x1) / 2;
  const float south = (core.y0 + synth::kCorridorSouthWall) / 2;
  const float north = (core.y1 + synth::kCorridorNorthWall) / 2;
  EXPECT_GE(2.0f * ((east - west) + (north - south)), 30.0f);
  EXPECT_GE(scene.movers.size(), 6u);
  // Masks are the pixels of moving objects: every static id lies below the first moving one.
  EXPECT_LT(scene.statics.back().id, scene.first_dynamic_id);
  EXPECT_EQ(scene.movers.front().id, scene.first_dynamic_id);
}

TEST(FloorTest, TheRobotGoesRoundTheLoopTwiceAndIntoEveryRoomThroughNoWall) {
  const synth::Scene scene = synth::BuildScene("floor", 1);
  const double duration = synth::FloorDuration("floor");
  EXPECT_GE(duration, 300.0);
  const Eigen::Vector2f middle(8.0f, 7.0f);  // inside the core
  double turned = 0.0;                       // round the core [rad]
  std::map<std::string, double> seconds_in;  // per room
  Eigen::Vector3f last = synth::FloorCameraPose("floor", 0.0).translation();
  for (double t = 0.0; t <= duration; t += 0.25) {
    const Eigen::Isometry3f pose = synth::FloorCameraPose("floor", t);
    const Eigen::Vector3f p = pose.translation();
    EXPECT_NEAR(p.z(), 0.9f, 0.01f) << "t = " << t;
    EXPECT_LE((p - last).norm(), 0.5f * 0.25f + 1e-3f) << "t = " << t;  // a robot's speed
    if (std::fmod(t, 1.0) == 0.0) {
      EXPECT_GE(DistanceToStatics(scene, p), 0.15f) << "t = " << t << " at " << p.transpose();
    }
    const Eigen::Vector2f a = last.head<2>() - middle, b = p.head<2>() - middle;
    turned += std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
    for (const synth::FloorRoom& room : FloorRooms()) {
      if (Inside(room.inside, p)) seconds_in[room.name] += 0.25;
    }
    last = p;
  }
  EXPECT_GE(std::abs(turned), 2 * 2 * M_PI - 0.3);
  for (const synth::FloorRoom& room : FloorRooms()) EXPECT_GE(seconds_in[room.name], 20.0);
}

TEST(FloorTest, OnePersonPassesCloseBeforeTheLensAndOneStandsStillInView) {
  const synth::Scene scene = synth::BuildScene("floor", 1);
  double closest = 10.0, longest_still_in_view = 0.0;
  for (const synth::MovingObject& person : scene.movers) {
    if (person.motion == synth::Motion::kSit) continue;
    double still_in_view = 0.0;
    Eigen::Vector3f last = synth::BodyPose(scene, person, 0.0).translation();
    for (double t = 0.0; t <= synth::FloorDuration("floor"); t += 0.5) {
      const Eigen::Vector3f at = synth::BodyPose(scene, person, t).translation();
      const Eigen::Vector3f chest =
          synth::FloorCameraPose("floor", t).inverse() * (at + Eigen::Vector3f(0, 0, 1.2f));
      const bool in_view =
          chest.z() > 0.4f && chest.z() < 5.0f && std::abs(chest.x() / chest.z()) < 0.6f;
      if (in_view) closest = std::min(closest, static_cast<double>(chest.norm()));
      still_in_view = (at - last).norm() < 1e-4f && in_view ? still_in_view + 0.5 : 0.0;
      longest_still_in_view = std::max(longest_still_in_view, still_in_view);
      last = at;
    }
  }
  EXPECT_LT(closest, 0.8);
  EXPECT_GE(longest_still_in_view, 5.0);
}

TEST(FloorTest, FloorLostCoversTheLensTwiceOnceWhileCarriedFromRoomToRoom) {
  const double duration = synth::FloorDuration("floor_lost");
  EXPECT_GE(duration, 300.0);
  std::vector<std::pair<double, double>> covers;  // [from, to) at the frame rate
  for (size_t i = 0; i < static_cast<size_t>(duration * 30.0); ++i) {
    const double t = static_cast<double>(i) / 30.0;
    if (!synth::FloorLensCovered("floor_lost", t)) continue;
    if (covers.empty() || t - covers.back().second > 0.05) covers.push_back({t, t});
    covers.back().second = t + 1.0 / 30.0;
  }
  ASSERT_EQ(covers.size(), 2u);
  for (const auto& [from, to] : covers) EXPECT_NEAR(to - from, 3.0, 0.04);
  const Eigen::Vector3f before =
      synth::FloorCameraPose("floor_lost", covers[0].first).translation();
  const Eigen::Vector3f after =
      synth::FloorCameraPose("floor_lost", covers[0].second).translation();
  EXPECT_TRUE(Inside(FloorRooms()[0].inside, before)) << before.transpose();
  EXPECT_TRUE(Inside(FloorRooms()[1].inside, after)) << after.transpose();
  EXPECT_FALSE(synth::FloorLensCovered("floor", covers[0].first + 1.0));
}

TEST(FloorTest, DefaultsAreTheWholePathAndACentimetreTruth) {
  SynthOptions options;
  options.scenario = "floor";
  const SynthOptions floor = options.WithScenarioDefaults();
  EXPECT_EQ(floor.frames, static_cast<size_t>(synth::FloorDuration("floor") * 30.0));
  EXPECT_DOUBLE_EQ(floor.static_gt_spacing, 0.01);
  options.scenario = "walking_xyz";
  EXPECT_EQ(options.WithScenarioDefaults().frames, 300u);
  EXPECT_DOUBLE_EQ(options.WithScenarioDefaults().static_gt_spacing, 0.005);
}

}  // namespace
}  // namespace stillmap
