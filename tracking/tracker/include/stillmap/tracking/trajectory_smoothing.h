// Every tracked frame's pose carries its own noise: the features it matched, their pixels'
// rounding, the depth behind them. The camera does not jump from frame to frame; its noise does.
// Each frame's position is taken again from the positions of the frames around it, as the value
// at its time of a quadratic fitted to them by least squares (a local polynomial smoother,
// Savitzky and Golay 1964), over a window as long on either side; its rotation the same way,
// from the rotation vectors of those frames' rotations relative to its own. A quadratic follows a
// camera that speeds up or turns faster, so a motion of constant acceleration is kept as it is,
// and frame noise is averaged out. A window never reaches across the start of a run: a frame that
// began one (the first, a relocalized frame, a new segment's first), a gap in time (lost frames)
// or a frame of another segment. A frame with fewer than two frames of its run on either side
// within the window (a run's first and last two) is left as it is.
#pragma once

#include <cstddef>
#include <vector>

#include "stillmap/io/trajectory.h"

namespace stillmap {

struct TrajectorySmoothingOptions {
  // The window on either side of a frame [s] (0: not smoothed). Chosen on the 13 synthetic rooms,
  // TUM teddy, bonn_crowd_a and the four floors (docs/figures.md, sixty-first session): teddy's
  // hand-held camera gained most at 0.2 s for positions and lost rotation accuracy beyond 0.1 s.
  double position_s = 0.2;
  double rotation_s = 0.1;

  void Validate() const;  // throws InputError naming the key

  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("smoothing_s", self.position_s,
          "each tracked frame's position is fitted (a quadratic in time) to the frames within "
          "this on either side, in its run (0: as tracked) [s]");
    visit("rotation_smoothing_s", self.rotation_s,
          "... and its rotation to those within this (0: as tracked) [s]");
  }
};

struct TrajectorySmoothingFigures {
  size_t frames_moved = 0;
  size_t runs = 0;
  double rms_move_m = 0.0;      // of the frames' positions
  double largest_move_m = 0.0;  // of a frame's position
};

// Smooths `poses` (in time order) in place. `run_start[i]`: frame i begins a run (missing:
// not); a gap of more than 1.5 times the median frame interval begins one too.
TrajectorySmoothingFigures SmoothTrajectory(const TrajectorySmoothingOptions& options,
                                            const std::vector<bool>& run_start,
                                            std::vector<StampedPose>* poses);

}  // namespace stillmap
