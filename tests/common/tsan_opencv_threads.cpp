// Linked into every test program of a ThreadSanitizer build (STILLMAP_TSAN): OpenCV's
// parallel_for_ runs on TBB, which Debian does not build with TSan, so TSan sees no
// happens-before between a loop body on a TBB worker and its caller and reports each as a race.
// OpenCV's loops run on the calling thread instead; the threads stillmap starts itself are still
// checked (RunBuild does the same for the binary).
#include <opencv2/core/utility.hpp>

namespace {

const bool kOpenCvSingleThreaded = [] {
  cv::setNumThreads(1);
  return true;
}();

}  // namespace
