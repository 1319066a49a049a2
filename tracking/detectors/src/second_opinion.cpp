// A fast detector with a stronger one as its second opinion (issue 51): see detector.h.
#include <algorithm>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "stillmap/tracking/detector.h"

namespace stillmap {
namespace {

// The detection of `detections` of `person`'s class that `person` lies on (half of the smaller
// box or more shared: the detectors frame the same person differently, so IoU alone would miss a
// tight box inside a loose one), or null.
Detection* LiesOn(const Detection& person, std::vector<Detection>* detections) {
  for (Detection& other : *detections) {
    if (other.class_id != person.class_id) continue;
    const float shared = (other.box & person.box).area();
    if (shared >= 0.5f * std::min(other.box.area(), person.box.area())) return &other;
  }
  return nullptr;
}

class SecondOpinionDetector : public Detector {
 public:
  SecondOpinionDetector(std::unique_ptr<Detector> first, std::unique_ptr<Detector> second)
      : first_(std::move(first)), second_(std::move(second)) {}
  std::string name() const override { return first_->name() + "+" + second_->name(); }
  std::vector<Detection> Detect(const cv::Mat& bgr) override { return first_->Detect(bgr); }
  bool has_second_opinion() const override { return true; }
  std::vector<Detection> DetectWithSecondOpinion(const cv::Mat& bgr) override {
    std::vector<Detection> detections = first_->Detect(bgr);
    const size_t first_count = detections.size();
    for (Detection& person : second_->Detect(bgr)) {
      if (person.level != MotionLevel::kHigh) continue;
      // Where both found the person, the box that holds both: a fast detector's box on someone
      // near the lens often holds only part of them.
      Detection* same = LiesOn(person, &detections);
      if (same != nullptr && same < detections.data() + first_count) {
        same->box |= person.box;
        same->score = std::max(same->score, person.score);
        same->tentative = false;
      } else if (same == nullptr) {
        detections.push_back(std::move(person));
      }
    }
    return detections;
  }

 private:
  std::unique_ptr<Detector> first_;
  std::unique_ptr<Detector> second_;
};

}  // namespace

std::unique_ptr<Detector> MakeSecondOpinionDetector(std::unique_ptr<Detector> first,
                                                    std::unique_ptr<Detector> second) {
  return std::make_unique<SecondOpinionDetector>(std::move(first), std::move(second));
}

}  // namespace stillmap
