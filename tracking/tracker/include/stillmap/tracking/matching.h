// Descriptor matching between two sets of ORB features.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace stillmap {

struct MatchOptions {
  float ratio = 0.8f;     // best / second-best Hamming distance must be below this (Lowe)
  int max_distance = 64;  // of 256 bits; ORB-SLAM2's TH_HIGH is 100, TH_LOW 50
  bool mutual = true;     // keep a pair only if each is the other's best
};

// Brute-force Hamming matching of `query` against `train` (rows of 32-byte ORB descriptors).
std::vector<cv::DMatch> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                         const MatchOptions& options = {});

}  // namespace stillmap
