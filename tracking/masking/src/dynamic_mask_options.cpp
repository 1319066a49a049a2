// DynamicMaskOptions: the outline modes by name and the checks of every option.
#include <fmt/format.h>

#include <string>

#include "stillmap/io/error.h"
#include "stillmap/io/option_names.h"
#include "stillmap/tracking/dynamic_mask.h"

namespace stillmap {

OutlineMode ParseOutlineMode(const std::string& name) {
  if (name == "box") return OutlineMode::kBox;
  if (name == "depth") return OutlineMode::kDepth;
  if (name == "edges") return OutlineMode::kEdges;
  throw InputError(fmt::format("{}: '", OptionKey(&DynamicMaskOptions::outline)) + name +
                   "' is not one of box, depth, edges");
}

const char* OutlineModeName(OutlineMode mode) {
  switch (mode) {
    case OutlineMode::kBox:
      return "box";
    case OutlineMode::kDepth:
      return "depth";
    case OutlineMode::kEdges:
      return "edges";
  }
  return "depth";
}

void DynamicMaskOptions::Validate() const {
  auto check = [](bool ok, const char* what) {
    if (!ok) throw InputError(std::string("masking.") + what);
  };
  check(depth.max_depth_difference_m > 0.0,
        "max_depth_difference_m must be > 0 (paper 002: 0.4 m)");
  check(depth.max_parallax_deg > 0.0 && depth.max_parallax_deg <= 180.0,
        "max_parallax_deg must be in (0, 180] (paper 002: 30)");
  check(flow.dbscan_epsilon_px > 0.0, "flow_dbscan_epsilon_px must be > 0");
  check(flow.min_epipolar_distance_px >= 0.0, "flow_min_epipolar_distance_px must be >= 0");
  check(flow.dbscan_min_points >= 1, "flow_dbscan_min_points must be >= 1");
  check(flow.ransac_threshold_px > 0.0 && flow.ransac_threshold_px <= 100.0,
        "flow_ransac_threshold_px must be in (0, 100]");
  check(flow.max_forward_backward_px > 0.0, "flow_max_forward_backward_px must be > 0");
  // OpenCV's KLT: a window of at least 3 px; its cost grows with the window's area.
  check(flow.klt_window == 0 || (flow.klt_window >= 3 && flow.klt_window <= 101),
        "flow_klt_window must be 0 (by the detector) or 3..101");
  check(flow.klt_levels >= 0 && flow.klt_levels <= 8, "flow_klt_levels must be 0..8");
  check(flow_points == 0 || (flow_points >= 8 && flow_points <= 20000),
        "flow_points must be 0 (by the detector) or 8..20000");
  check(reference_keyframes >= 1 && reference_keyframes <= 50, "reference_keyframes must be 1..50");
  check(reference_spacing_s >= 0.0, "reference_spacing_s must be >= 0");
  check(depth_check_stride >= 1 && depth_check_stride <= 16, "depth_check_stride must be 1..16");
  check(grow_depth_difference_m > 0.0 && grow_depth_difference_m <= depth.max_depth_difference_m,
        "grow_depth_difference_m must be > 0 and <= max_depth_difference_m");
  check(continuity > 0.0 && continuity < 1.0, "continuity must be in (0, 1)");
  check(block_continuity > 0.0 && block_continuity < 1.0, "block_continuity must be in (0, 1)");
  check(grow_noise_sigmas >= 0.0 && grow_noise_sigmas <= 100.0, "grow_noise_sigmas must be 0..100");
  check(seed_noise_factor >= 0.0 && seed_noise_factor <= 100.0, "seed_noise_factor must be 0..100");
  // Steps are counted in one byte per pixel (GeometricMasker::Compute): 255 at most.
  check(max_unknown_steps >= 0 && max_unknown_steps <= 255, "max_unknown_steps must be 0..255");
  check(unclaimed_outline_min_px >= -1,
        "unclaimed_outline_min_px must be >= -1 (0: off; -1: by the detector)");
  check(unclaimed_outline_widen >= 0.0 && unclaimed_outline_widen <= 2.0,
        "unclaimed_outline_widen must be 0..2");
  check(medium_min_moving_share > 0.0 && medium_min_moving_share <= 1.0,
        "medium_min_moving_share must be in (0, 1]");
  check(high_static_share > 0.0 && high_static_share <= 1.0, "high_static_share must be in (0, 1]");
  check(detector_interval >= 1, "detector_interval must be >= 1");
  check(second_opinion_share >= 0.0 && second_opinion_share <= 1.0,
        "second_opinion_share must lie in 0..1");
  check(detection_memory_runs >= 0 && detection_memory_runs <= 100,
        "detection_memory_runs must lie in 0..100");
  check(margin_px >= 0 && margin_px <= 50, "margin_px must be 0..50");
  check(min_region_px >= 0, "min_region_px must be >= 0");
}

}  // namespace stillmap
