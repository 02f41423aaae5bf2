// The CARMEN reader on good, gzip and malformed input, and the scan sequence built from it.
#include <gtest/gtest.h>
#include <zlib.h>

#include "laser_loop_closure/core/io/carmen_reader.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "../test_util.hpp"

namespace {

const char* kLog =
    "# a comment\n"
    "PARAM robot_frontlaser_offset 0.25 nohost 0\n"
    "PARAM robot_rearlaser_offset -0.25 nohost 0\n"
    "ODOM 0.5 0.6 0.1 0 0 0 10.0 host 10.0\n"
    "FLASER 4 1.0 2.0 3.0 4.0 1.1 1.2 0.3 1.0 1.1 0.2 10.0 host 10.0\n"
    "RLASER 4 5.0 5.0 5.0 5.0 1.1 1.2 0.3 1.0 1.1 0.2 10.01 host 10.01\n"
    "TRUEPOS 7.0 8.0 0.5 1.0 1.1 0.2 10.0 host 10.0\n"
    "NEFF 15\n"
    "VERTEX2 1 0 0 0\n"
    "FLASER 3 1.0 2.0 3.0 2.1 2.2 0.4 2.0 2.1 0.3 11.0 host 11.0\n"
    "ROBOTLASER1 0 -1.570796 3.141593 0.017453 81.83 0.01 0 3 1.5 2.5 3.5 0 0.1 0.2 0.3 0.4 0.5 0.6 0 0 0 0 0 12.0 host 12.0\n";

TEST(CarmenReader, ReadsEveryLineType) {
  llc_test::TempDir dir;
  llc_test::writeText(dir.file("a.log"), kLog);
  const llc::CarmenLog log = llc::readCarmenLog(dir.file("a.log"));
  ASSERT_EQ(log.front.size(), 3u);
  ASSERT_EQ(log.rear.size(), 1u);
  ASSERT_EQ(log.odometry.size(), 1u);
  ASSERT_EQ(log.truth.size(), 1u);
  EXPECT_DOUBLE_EQ(log.front_laser_offset, 0.25);
  EXPECT_DOUBLE_EQ(log.rear_laser_offset, -0.25);
  const llc::CarmenLaser& f = log.front[0];
  EXPECT_EQ(f.ranges, (std::vector<double>{1, 2, 3, 4}));
  EXPECT_DOUBLE_EQ(f.pose.x, 1.1);
  EXPECT_DOUBLE_EQ(f.odometry.theta, 0.2);
  EXPECT_DOUBLE_EQ(f.stamp, 10.0);
  EXPECT_EQ(f.line, 5u);
  EXPECT_NEAR(f.geometry.angle_increment, M_PI / 4, 1e-15);  // even n: pi / n
  EXPECT_NEAR(log.front[1].geometry.angle_increment, M_PI / 2, 1e-15);  // odd n: pi / (n-1)
  const llc::CarmenLaser& r = log.front[2];  // ROBOTLASER1 carries its own geometry
  EXPECT_EQ(r.ranges, (std::vector<double>{1.5, 2.5, 3.5}));
  EXPECT_NEAR(r.geometry.angle_increment, 0.017453, 1e-12);
  EXPECT_NEAR(r.pose.x, 0.1, 1e-12);
  EXPECT_NEAR(r.odometry.theta, 0.6, 1e-12);
  EXPECT_DOUBLE_EQ(r.stamp, 12.0);
  EXPECT_EQ(log.front_truth, (std::vector<long>{0, -1, -1}));
}

TEST(CarmenReader, ScanSequenceMergesRearAndUsesTruth) {
  llc_test::TempDir dir;
  llc_test::writeText(dir.file("a.log"), kLog);
  const llc::ScanSequence seq = llc::loadScanSequence(dir.file("a.log"));
  ASSERT_EQ(seq.scans.size(), 3u);
  EXPECT_EQ(seq.merged_count, 1u);
  EXPECT_TRUE(seq.scans[0].scan.full_circle);
  EXPECT_EQ(seq.scans[0].scan.size(), 8u);
  EXPECT_DOUBLE_EQ(seq.scans[0].truth.x, 7.0);  // TRUEPOS wins over the FLASER pose
  EXPECT_FALSE(seq.scans[1].scan.full_circle);
  EXPECT_DOUBLE_EQ(seq.scans[1].truth.x, 2.1);  // no TRUEPOS: the laser line's pose
  // The rear scanner faces backwards 0.25 m behind the base: its middle beams hit 5.25 m
  // behind the base origin (bearing +-pi).
  bool behind = false;
  for (std::size_t i = 0; i < 8; ++i)
    if (std::abs(std::abs(seq.scans[0].scan.bearings[i]) - M_PI) < 0.5 && seq.scans[0].scan.ranges[i] > 5.0)
      behind = true;
  EXPECT_TRUE(behind);
  llc::ScanSequenceOptions front_only;
  front_only.use_rear = false;
  EXPECT_EQ(llc::loadScanSequence(dir.file("a.log"), front_only).merged_count, 0u);
}

TEST(CarmenReader, EachScanIsNamedByItsRangesAsRecordedWhateverTheScannersOffset) {
  llc_test::TempDir dir;
  llc_test::writeText(dir.file("a.log"), kLog);  // front scanner 0.25 m ahead, a rear scan merged
  llc_test::writeText(dir.file("b.log"), "FLASER 4 1.0 2.0 3.0 4.0 0 0 0 0 0 0 5.0 host 5.0\n"
                                         "FLASER 3 1.0 2.0 3.004 0 0 0 0 0 0 6.0 host 6.0\n");
  const llc::ScanSequence a = llc::loadScanSequence(dir.file("a.log")), b = llc::loadScanSequence(dir.file("b.log"));
  EXPECT_NE(a.scans[0].scan.ranges, b.scans[0].scan.ranges);  // moved and merged in a
  EXPECT_EQ(a.scans[0].recorded_ranges_key, b.scans[0].recorded_ranges_key);
  EXPECT_EQ(a.scans[1].recorded_ranges_key, b.scans[1].recorded_ranges_key);  // 3.004 is 3.00 to 1 cm
  EXPECT_NE(a.scans[0].recorded_ranges_key, a.scans[1].recorded_ranges_key);
  EXPECT_NE(a.scans[0].recorded_ranges_key, 0u);
  EXPECT_NE(llc::recordedRangesKey({1.0, 2.0}), llc::recordedRangesKey({1.0, 2.0, INFINITY}));
  EXPECT_EQ(llc::recordedRangesKey({INFINITY}), llc::recordedRangesKey({NAN}));  // no return, either way
}

TEST(CarmenReader, ReadsGzip) {
  llc_test::TempDir dir;
  gzFile out = gzopen(dir.file("a.log.gz").c_str(), "wb");
  ASSERT_NE(out, nullptr);
  gzputs(out, kLog);
  gzclose(out);
  const llc::CarmenLog log = llc::readCarmenLog(dir.file("a.log.gz"));
  EXPECT_EQ(log.front.size(), 3u);
}

TEST(CarmenReader, TruncatedGzipIsAnError) {
  llc_test::TempDir dir;
  gzFile out = gzopen(dir.file("a.log.gz").c_str(), "wb");
  std::string big;
  for (int i = 0; i < 200; ++i) big += kLog;
  gzputs(out, big.c_str());
  gzclose(out);
  const std::string bytes = llc_test::readText(dir.file("a.log.gz"));
  llc_test::writeText(dir.file("cut.log.gz"), bytes.substr(0, bytes.size() / 2));
  EXPECT_THROW(llc::readCarmenLog(dir.file("cut.log.gz")), llc::CarmenError);
}

void expectLineError(const std::string& body, const std::string& fragment) {
  llc_test::TempDir dir;
  llc_test::writeText(dir.file("bad.log"), body);
  try {
    llc::readCarmenLog(dir.file("bad.log"));
    ADD_FAILURE() << "accepted: " << body;
  } catch (const llc::CarmenError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(dir.file("bad.log") + ":2:"), std::string::npos) << what;
    EXPECT_NE(what.find(fragment), std::string::npos) << what;
  }
}

TEST(CarmenReader, MalformedLinesNameFileAndLine) {
  const std::string ok = "ODOM 0 0 0 0 0 0 1.0 h 1.0\n";
  expectLineError(ok + "FLASER 3 1.0 x 3.0 0 0 0 0 0 0 1 h 1\n", "not a number");
  expectLineError(ok + "FLASER 5 1.0 2.0 3.0 0 0 0 0 0 0 1\n", "expected 5 ranges");
  expectLineError(ok + "FLASER 2 1.0 2.0 0 0 0 0 0 zz 1 h 1\n", "not a number (odometry pose)");
  expectLineError(ok + "FLASER -2 1 2\n", "beam count");
  expectLineError(ok + "FLASER\n", "line ends");
  expectLineError(ok + "ODOM 1 2\n", "line ends");
  expectLineError(ok + "TRUEPOS 1 2 3 4 5 6 nan_time\n", "not a number");
  expectLineError(ok + "ROBOTLASER1 0 -1.57 3.14 0 81 0 0 1 1.0 0 0 0 0 0 0 0 0 0 0 0 0 1 h 1\n", "resolution");
  // More ranges than the count says: without the check, the surplus would be read as the
  // pose and the stamp (here the pose would come out as 3.0, 4.0 and the stamp as 0.0).
  expectLineError(ok + "FLASER 2 1.0 2.0 3.0 4.0 0 0 0 0 0 0 1 h 1\n", "2 more values than a line with 2 beams");
  expectLineError(ok + "ROBOTLASER1 0 -1.57 3.14 0.0175 81 0 0 3 1.5 2.5 3.5 0 0.1 0.2 0.3 0.4 0.5 0.6 0 0 0 0 0 12 7 h 12\n",
                  "1 more values than a line with 3 beams");
}

TEST(CarmenReader, MissingFileIsAnError) {
  EXPECT_THROW(llc::readCarmenLog("/nonexistent/file.log"), llc::CarmenError);
}

}  // namespace
