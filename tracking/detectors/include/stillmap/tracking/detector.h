// Semantic prior for dynamic-object rejection (issue 5): detectors on OpenCV's DNN module and
// the motion levels of paper 002 (RTD-SLAM, section III.B): high (people, animals), medium
// (easily moved objects: chairs, books, keyboards, mice...), low (everything else, taken as
// static).
#pragma once

#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace stillmap {

enum class MotionLevel { kLow, kMedium, kHigh };
const char* MotionLevelName(MotionLevel level);

// Class name -> motion level; names not listed are low.
class MotionLevelTable {
 public:
  // Paper 002's levels over the COCO / VOC names the models use.
  static MotionLevelTable Default();
  MotionLevel Level(const std::string& name) const;
  // Sets one class (throws InputError for a level name other than high, medium or low).
  void Set(const std::string& name, const std::string& level);
  const std::map<std::string, MotionLevel>& entries() const { return levels_; }

 private:
  std::map<std::string, MotionLevel> levels_;
};

struct Detection {
  cv::Rect2f box;  // image pixels, clipped to the image
  int class_id = 0;
  std::string name;  // class name from the model's names file
  float score = 0.0f;
  MotionLevel level = MotionLevel::kLow;
  // Per-pixel backends (DeepLab): the object's pixels inside the box, CV_8UC1 of the box's
  // integer size (255 = the object). Empty for box detectors.
  cv::Mat mask;
  // Detector runs since this object was last detected (kept by masking.detection_memory_runs),
  // and the median depth of its box's centre then [m] (0: not known).
  int missed_runs = 0;
  float centre_depth_m = 0.0f;
  int hits = 1;              // detector runs in a row that found it
  bool seen_moving = false;  // geometry has seen part of its outline move, in any run so far
  bool left_static = false;  // a person never seen moving whose outline the depth check confirms
  // Found only by a second, coarser pass (Yolo-Fastest's): masked once a run after it finds it
  // again (hits >= 2), as a still object taken for a person in the very first frame would
  // otherwise never enter a keyframe to be confirmed static against.
  bool tentative = false;
};

class Detector {
 public:
  virtual ~Detector() = default;
  // Objects in a BGR (CV_8UC3) image.
  virtual std::vector<Detection> Detect(const cv::Mat& bgr) = 0;
  virtual std::string name() const = 0;
  // A detector with a second, stronger opinion (MakeSecondOpinionDetector) looks again where the
  // caller asks it to; the others give what Detect gives.
  virtual bool has_second_opinion() const { return false; }
  virtual std::vector<Detection> DetectWithSecondOpinion(const cv::Mat& bgr) { return Detect(bgr); }
};

struct YoloxOptions {
  int input_width = 416;   // letterbox size, multiples of 32 (PROVENANCE.txt: 416x320 runs in
  int input_height = 320;  // 30 ms here against 40 ms at 416x416, same detections)
  double score_threshold = 0.3;
  double nms_threshold = 0.45;  // IoU, per class

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("input_width", self.input_width, "YOLOX letterbox width [px] (a multiple of 32)");
    visit("input_height", self.input_height, "YOLOX letterbox height [px] (a multiple of 32)");
    visit("score_threshold", self.score_threshold, "YOLOX: objectness x class probability");
    visit("nms_threshold", self.nms_threshold, "YOLOX: non-maximum suppression IoU, per class");
  }
};

// YOLOX-Nano (COCO, ONNX) from MODELS_DIR/yolox_nano/{yolox_nano.onnx, coco.names}. Throws
// InputError naming the missing file.
std::unique_ptr<Detector> MakeYoloxDetector(const std::string& models_dir,
                                            const MotionLevelTable& levels,
                                            const YoloxOptions& options = {});

struct DeeplabOptions {
  // Segments smaller than this share of the image are dropped (label noise at object borders).
  double min_segment_share = 0.001;

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("min_segment_share", self.min_segment_share,
          "DeepLab: segments smaller than this share of the image are dropped");
  }
};

struct FastestOptions {
  // Input size: 320x256 keeps a 640x480 frame's shape (the model was trained at 320x320); per
  // image 21 ms on one core here against YOLOX-Nano's 83 ms (docs/figures.md).
  int input_width = 320;
  int input_height = 256;
  // A second, coarse pass for people near the lens: at 320x256 the network misses most people
  // who fill half the frame (its anchors are for smaller objects), at 160x128 it finds them as
  // often as YOLOX-Nano does (docs/figures.md); it adds about 40 % to the first pass's time
  // (BM_FastestDetect/1 against /0). Each pass has its own non-maximum suppression; a coarse box
  // lying mostly on a first-pass box of its class is dropped (the coarse boxes are looser).
  // 0x0: no coarse pass.
  int coarse_input_width = 160;
  int coarse_input_height = 128;
  double score_threshold = 0.3;  // objectness x class probability, as YOLOX's
  double nms_threshold = 0.45;   // IoU, per class, within each pass

  // Every field under its configuration key (io/option_fields.h).
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("fastest_input_width", self.input_width,
          "Yolo-Fastest input width [px] (a multiple of 32)");
    visit("fastest_input_height", self.input_height,
          "Yolo-Fastest input height [px] (a multiple of 32)");
    visit("fastest_coarse_input_width", self.coarse_input_width,
          "Yolo-Fastest coarse pass (people near the lens) width [px] (a multiple of 32; 0: none)");
    visit("fastest_coarse_input_height", self.coarse_input_height,
          "Yolo-Fastest coarse pass height [px] (a multiple of 32; 0: none)");
    visit("fastest_score_threshold", self.score_threshold,
          "Yolo-Fastest: objectness x class probability");
    visit("fastest_nms_threshold", self.nms_threshold,
          "Yolo-Fastest: non-maximum suppression IoU, per class");
  }
};

// Yolo-Fastest 1.1 (COCO, Darknet) from MODELS_DIR/yolo_fastest_1.1/{yolo-fastest-1.1.cfg,
// yolo-fastest-1.1.weights, coco.names}. Throws InputError naming the missing file.
std::unique_ptr<Detector> MakeFastestDetector(const std::string& models_dir,
                                              const MotionLevelTable& levels,
                                              const FastestOptions& options = {});

// DeepLabV3-MobileNetV2 (PASCAL VOC, ONNX patched for OpenCV 4.6) from
// MODELS_DIR/deeplabv3_mnv2_voc/{deeplab_v3_mnv2_voc_opencv46.onnx, voc.names}: per-pixel labels
// at 257x257, resized (nearest) to the image; each connected segment of a non-background class is
// one Detection with its mask. Throws InputError naming the missing file.
std::unique_ptr<Detector> MakeDeeplabDetector(const std::string& models_dir,
                                              const MotionLevelTable& levels,
                                              const DeeplabOptions& options = {});

// Runs two detectors on each image and returns both lists (`both`: YOLOX boxes and DeepLab
// segments).
std::unique_ptr<Detector> MakeCombinedDetector(std::unique_ptr<Detector> first,
                                               std::unique_ptr<Detector> second);

// `first` on every run; on the runs the caller asks for a second opinion (DetectionSchedule),
// `second` too, whose people (high motion level) that no detection of `first` lies on are added
// to `first`'s detections (issue 51: YOLOX-Nano where Yolo-Fastest is weak, people near the lens
// and at the image border, at a fraction of YOLOX's cost). Only people are added: the stronger
// detector's other classes would mask still furniture the first one leaves alone.
std::unique_ptr<Detector> MakeSecondOpinionDetector(std::unique_ptr<Detector> first,
                                                    std::unique_ptr<Detector> second);

// Whether MODELS_DIR holds Yolo-Fastest's three files, and YOLOX-Nano's two.
bool HoldsFastest(const std::string& models_dir);
bool HoldsYolox(const std::string& models_dir);

// "auto" (the default) is "yolo-fastest+yolox" when MODELS_DIR holds both, else "yolo-fastest"
// or "yolox", whichever it holds, else "none"; other names are returned as they are.
std::string ResolveDetectorName(const std::string& name, const std::string& models_dir);

// Every detector's options.
struct DetectorOptions {
  FastestOptions fastest;
  YoloxOptions yolox;
  DeeplabOptions deeplab;
};

// The detector named on the command line: "auto" (see ResolveDetectorName), "none" (or empty:
// nullptr), "yolo-fastest", "yolox", "yolo-fastest+yolox" (Yolo-Fastest with YOLOX as its second
// opinion), "deeplab" or "both" (YOLOX and DeepLab), with its models from
// MODELS_DIR. Throws InputError for an unknown name, a missing models folder or a missing model
// file.
std::unique_ptr<Detector> MakeDetector(const std::string& name, const std::string& models_dir,
                                       const MotionLevelTable& levels,
                                       const DetectorOptions& options);

}  // namespace stillmap
