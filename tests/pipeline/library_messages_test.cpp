// The libraries' own messages reach stderr only when asked for (--verbose): each library's
// warning, printed through its own logging call, is captured from stderr.
#include "stillmap/pipeline/library_messages.h"

#include <glog/logging.h>
#include <gtest/gtest.h>
#include <pcl/console/print.h>

#include <opencv2/core/utils/logger.hpp>
#include <string>

namespace stillmap {
namespace {

std::string LibraryWarnings() {
  ::testing::internal::CaptureStderr();
  PCL_WARN("pcl probe\n");
  CV_LOG_WARNING(nullptr, "opencv probe");
  LOG(WARNING) << "glog probe";
  return ::testing::internal::GetCapturedStderr();
}

TEST(LibraryMessagesTest, OffUnlessVerbose) {
  SetLibraryMessages(false);
  EXPECT_EQ(LibraryWarnings(), "");
  SetLibraryMessages(true);
  const std::string verbose = LibraryWarnings();
  for (const char* probe : {"pcl probe", "opencv probe", "glog probe"}) {
    EXPECT_NE(verbose.find(probe), std::string::npos) << probe << " missing from: " << verbose;
  }
  SetLibraryMessages(false);
}

}  // namespace
}  // namespace stillmap
