// The reader and the features on every real log in ../shared/data/carmen (skipped when absent).
#include <gtest/gtest.h>

#include <cmath>

#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "../test_util.hpp"

namespace {

struct Expected {
  const char* file;
  std::size_t scans, beams;
};

TEST(RealLogs, EveryLogReadsWithFiniteFeatures) {
  const std::string data = llc_test::sharedDataDir();
  if (data.empty()) GTEST_SKIP() << "../shared/data is absent: real-log test skipped";
  const Expected logs[] = {{"intel-corrected.log.gz", 910, 180},         {"aces-corrected.log.gz", 440, 180},
                           {"csail-corrected.log.gz", 406, 361},         {"freiburg-079-corrected.log.gz", 4791, 360},
                           {"freiburg-101-corrected.log.gz", 292, 360},  {"freiburg-campus-corrected.log.gz", 2008, 360},
                           {"infinite-corridor-corrected.log.gz", 1941, 180}, {"acapulco-corrected.log.gz", 861, 181},
                           {"intel-raw-odometry.log.gz", 2726, 180}};
  llc::FeatureExtractor extractor;
  for (const Expected& e : logs) {
    const llc::ScanSequence seq = llc::loadScanSequence(data + "/carmen/" + e.file);
    ASSERT_EQ(seq.scans.size(), e.scans) << e.file;
    EXPECT_EQ(seq.scans[0].scan.size(), e.beams) << e.file;
    EXPECT_EQ(seq.merged_count, 0u) << e.file;
    for (std::size_t i = 0; i < seq.scans.size(); i += 7) {
      const std::vector<double> f = extractor.extract(seq.scans[i].scan);
      for (double v : f) ASSERT_TRUE(std::isfinite(v)) << e.file << " scan " << i;
      EXPECT_GT(f[17], 0.0) << e.file << " scan " << i << " has no valid beam";
    }
  }
}

}  // namespace
