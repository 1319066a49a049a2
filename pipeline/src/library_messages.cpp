#include "stillmap/pipeline/library_messages.h"

#include <glog/logging.h>
#include <pcl/console/print.h>

#include <opencv2/core/utils/logger.hpp>

namespace stillmap {

void SetLibraryMessages(bool verbose) {
  pcl::console::setVerbosityLevel(verbose ? pcl::console::L_INFO : pcl::console::L_ALWAYS);
  cv::utils::logging::setLogLevel(verbose ? cv::utils::logging::LOG_LEVEL_INFO
                                          : cv::utils::logging::LOG_LEVEL_SILENT);
  FLAGS_minloglevel = verbose ? google::GLOG_INFO : google::GLOG_FATAL;
}

}  // namespace stillmap
