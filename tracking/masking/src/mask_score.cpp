// MaskScore: masks against their truth, pixel by pixel.
#include <opencv2/core.hpp>

#include "stillmap/tracking/dynamic_mask.h"

namespace stillmap {

void MaskScore::Add(const cv::Mat& mask, const cv::Mat& truth) {
  CV_Assert(mask.size() == truth.size() && mask.type() == CV_8UC1 && truth.type() == CV_8UC1);
  const cv::Mat m = mask != 0, t = truth != 0;
  const double tp = cv::countNonZero(m & t);
  const double fp = cv::countNonZero(m) - tp;
  const double fn = cv::countNonZero(t) - tp;
  true_positive += tp;
  false_positive += fp;
  false_negative += fn;
  if (tp + fp + fn > 0) {
    iou_sum += tp / (tp + fp + fn);
    ++frames;
  }
}

double MaskScore::Precision() const {
  return true_positive + false_positive > 0 ? true_positive / (true_positive + false_positive)
                                            : 0.0;
}
double MaskScore::Recall() const {
  return true_positive + false_negative > 0 ? true_positive / (true_positive + false_negative)
                                            : 0.0;
}
double MaskScore::Iou() const {
  const double all = true_positive + false_positive + false_negative;
  return all > 0 ? true_positive / all : 0.0;
}
double MaskScore::MeanFrameIou() const {
  return frames > 0 ? iou_sum / static_cast<double>(frames) : 0.0;
}

}  // namespace stillmap
