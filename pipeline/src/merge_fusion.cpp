#include "merge_fusion.h"

#include <algorithm>

#include "stillmap/mapping/revisit_cells.h"
#include "stillmap/pipeline/progress.h"

namespace stillmap {
namespace {

// The order sessions are fused in: by the recording's time of their first keyframe (a later
// session's observation wins), the first given first among equals.
std::vector<size_t> FusionOrder(const std::vector<MergeSession>& sessions,
                                const JoinedSessions& joined) {
  std::vector<size_t> order;
  for (size_t s = 0; s < sessions.size(); ++s) {
    if (joined.included[s]) order.push_back(s);
  }
  std::stable_sort(order.begin(), order.end(), [&sessions](size_t a, size_t b) {
    return sessions[a].record().keyframes.front().time <
           sessions[b].record().keyframes.front().time;
  });
  return order;
}

}  // namespace

// Fuses every joined session's keyframes at their merged poses. Within and across sessions, the
// depth cells an earlier visit saw are left out (RevisitCells): a place seen by two sessions is
// not laid twice a few millimetres apart.

MergeFusion FuseSessions(std::vector<MergeSession>& sessions, const JoinedSessions& joined,
                         const MergeFusionOptions& options) {
  std::vector<int> fusion_order(sessions.size(), -1);
  std::vector<size_t> fused(sessions.size(), 0), redundant(sessions.size(), 0);
  const Camera& camera = sessions[FusionOrder(sessions, joined).front()].record().camera;
  Mapper mapper(camera, options.mapping);
  RevisitCells revisits(camera, options.revisit, options.mapping.back_projection.min_depth,
                        options.mapping.back_projection.max_depth);
  const std::vector<size_t> order = FusionOrder(sessions, joined);
  size_t total = 0;
  for (const size_t s : order) total += sessions[s].record().keyframes.size();
  ProgressLine progress("stillmap merge", total, options.show_progress);
  size_t done = 0;
  // Keyframe ids across sessions: each session's own ids, shifted past the one before by the
  // revisit distance, so that another session's keyframes always count as an earlier visit.
  int id_base = 0;
  for (size_t rank = 0; rank < order.size(); ++rank) {
    MergeSession& session = sessions[order[rank]];
    fusion_order[order[rank]] = static_cast<int>(rank);
    const Camera& session_camera = session.record().camera;
    if (rank > 0) mapper.BeginLaterSession(session_camera);
    revisits.SetCamera(session_camera);
    const std::vector<SessionKeyframe>& keyframes = session.record().keyframes;
    int last_id = 0;
    for (size_t k = 0; k < keyframes.size(); ++k) {
      SessionImages images = session.reader->ReadImages(k);
      MapperFrame frame{keyframes[k].time,
                        images.color,
                        images.depth_m,
                        cv::Mat(),
                        joined.first_from_keyframe[order[rank]][k],
                        false,
                        cv::Mat()};
      // A redundant keyframe's view is not remembered: only fused views leave cells out.
      std::optional<cv::Mat> seen = revisits.Admit(revisits.MakeView(
          id_base + keyframes[k].id, frame.depth_m, cv::Mat(), frame.world_from_camera));
      if (seen) {
        frame.mask = std::move(*seen);
        mapper.Integrate(frame);
        ++fused[order[rank]];
      } else {
        ++redundant[order[rank]];
      }
      last_id = std::max(last_id, keyframes[k].id);
      progress.Update(++done);
    }
    id_base += last_id + options.revisit.keyframes_apart + 1;
  }
  progress.Finish();
  return {mapper.Finish(), std::move(fusion_order), std::move(fused), std::move(redundant),
          revisits.cells_left_out()};
}

}  // namespace stillmap
