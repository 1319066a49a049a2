#include "stillmap/tracking/matching.h"

#include <opencv2/features2d.hpp>

namespace stillmap {

std::vector<cv::DMatch> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                         const MatchOptions& options) {
  std::vector<cv::DMatch> matches;
  if (query.empty() || train.empty()) return matches;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> forward;
  matcher.knnMatch(query, train, forward, 2);
  std::vector<int> best_query_for_train;
  if (options.mutual) {
    std::vector<std::vector<cv::DMatch>> backward;
    matcher.knnMatch(train, query, backward, 1);
    best_query_for_train.assign(static_cast<size_t>(train.rows), -1);
    for (const auto& candidates : backward) {
      if (!candidates.empty()) {
        best_query_for_train[static_cast<size_t>(candidates[0].queryIdx)] = candidates[0].trainIdx;
      }
    }
  }
  for (const auto& candidates : forward) {
    if (candidates.empty() || candidates[0].distance > static_cast<float>(options.max_distance)) {
      continue;
    }
    if (candidates.size() > 1 && candidates[0].distance >= options.ratio * candidates[1].distance) {
      continue;
    }
    const cv::DMatch& best = candidates[0];
    if (options.mutual &&
        best_query_for_train[static_cast<size_t>(best.trainIdx)] != best.queryIdx) {
      continue;
    }
    matches.push_back(best);
  }
  return matches;
}

}  // namespace stillmap
