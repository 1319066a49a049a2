// The map segments never joined to the map (segment_keeper.h), each written apart as a build of
// its own under segments/<k>/: its map files, trajectory.txt, keyframes.txt, session.bin (so that
// `stillmap merge` can join it later) and config.yaml, all in the segment's own frame.
#pragma once

#include <string>
#include <vector>

#include "build_inputs.h"
#include "map_finish.h"
#include "map_outputs.h"
#include "segment_keeper.h"
#include "stillmap/io/output_files.h"
#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"

namespace stillmap {

// What writing a segment apart reads of the build.
struct SegmentOutputContext {
  const BuildInputs& inputs;
  const BuildConfig& config;
  const std::string& sequence_dir;
  const MaskingFigures& masking;
  MapFinishOptions finish;
  MapFileOptions files;
  double depth_unit_m = 0.0;  // of the keyframes' depth PNGs
};

// Writes each segment (each with keyframes kept: TakeLostAgain first) into outputs'
// segments/<id>/ and returns, per segment, a warning naming its time span and where it went (or
// why no map could be made of it: its trajectory and session record are written all the same).
std::vector<std::string> WriteApartSegments(std::vector<ApartSegment> apart,
                                            const SegmentOutputContext& context,
                                            OutputSet& outputs);

// What the user is told of `summary`'s segment, written apart in `path`; `failure` says why no
// map could be made of its keyframes ("" when one was).
std::string ApartSegmentWarning(const SegmentSummary& summary, const std::string& failure,
                                const std::string& path);

// What the user is told of a new map lost again before any of its keyframes was kept for a map
// (TakeLostAgain, segment_keeper.h): its span, and that its frames count as lost.
std::string LostAgainWarning(const SegmentSummary& summary);

}  // namespace stillmap
