// packScan / unpackScan: a simulated 360-degree scan round-trips within half a step of each
// range and bearing, no return stays no return, the packing is a fraction of the float32 message,
// and anything that is not a packed scan (truncated, corrupt, random) is refused, never thrown.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "../test_util.hpp"
#include "laser_loop_closure/core/io/scan_codec.hpp"

namespace {

llc::Scan simulatedScan() {
  const llc::SimDrive drive = llc_test::simulatedDrive(60.0);
  return llc_test::frameScan(drive, drive.frames[drive.frames.size() / 2]);
}

TEST(ScanCodec, RoundTripsWithinHalfAStep) {
  llc::Scan scan = simulatedScan();
  ASSERT_GT(scan.size(), 500u);
  scan.ranges[3] = std::numeric_limits<double>::quiet_NaN();  // not a return
  scan.ranges[4] = -1.0;
  scan.ranges[5] = std::numeric_limits<double>::infinity();
  const llc::ScanPackOptions options;
  const std::vector<std::uint8_t> packed = llc::packScan(scan, options);
  llc::Scan back;
  back.stamp = 12.5;
  std::string error;
  ASSERT_TRUE(llc::unpackScan(packed, &back, &error)) << error;
  ASSERT_EQ(back.size(), scan.size());
  EXPECT_EQ(back.full_circle, scan.full_circle);
  EXPECT_EQ(back.stamp, 12.5);  // the caller's: the packing has none
  std::size_t returns = 0;
  for (std::size_t k = 0; k < scan.size(); ++k) {
    EXPECT_NEAR(back.bearings[k], scan.bearings[k], 0.5 * options.bearing_step + 1e-12) << k;
    if (std::isfinite(scan.ranges[k]) && scan.ranges[k] > 0.0) {
      EXPECT_NEAR(back.ranges[k], scan.ranges[k], 0.5 * options.range_step + 1e-12) << k;
      ++returns;
    } else {
      EXPECT_TRUE(std::isinf(back.ranges[k]) && back.ranges[k] > 0) << k;
    }
  }
  EXPECT_GT(returns, 300u);
  // What a keyframe message saves: float32 ranges and bearings take 8 bytes a beam.
  const double bytes_per_beam = double(packed.size()) / double(scan.size());
  std::cout << scan.size() << " beams: " << packed.size() << " bytes packed (" << bytes_per_beam << " per beam, float32: 8)\n";
  EXPECT_LT(bytes_per_beam, 3.0);
}

TEST(ScanCodec, AnythingElseIsRefusedNotThrown) {
  const std::vector<std::uint8_t> packed = llc::packScan(simulatedScan());
  llc::Scan scan;
  std::string error;
  EXPECT_FALSE(llc::unpackScan({}, &scan, &error));
  EXPECT_FALSE(llc::unpackScan(std::vector<std::uint8_t>(packed.begin(), packed.begin() + long(packed.size() / 2)), &scan, &error));
  EXPECT_NE(error.find("packed scan"), std::string::npos) << error;
  std::vector<std::uint8_t> wrong_magic = packed;
  wrong_magic[0] = 'X';
  EXPECT_FALSE(llc::unpackScan(wrong_magic, &scan, &error));
  std::vector<std::uint8_t> more_beams = packed;
  more_beams[4] = 0xff, more_beams[5] = 0xff, more_beams[6] = 0xff, more_beams[7] = 0x7f;
  EXPECT_FALSE(llc::unpackScan(more_beams, &scan, &error));
  // Flipped bytes and random bytes: refused or read, never thrown, never a crash.
  std::mt19937 random(7);
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<std::uint8_t> mutated = packed;
    for (int flips = 0; flips < 1 + trial % 4; ++flips) mutated[random() % mutated.size()] ^= std::uint8_t(1 + random() % 255);
    if (trial % 5 == 0) mutated.resize(random() % (mutated.size() + 1));
    EXPECT_NO_THROW(llc::unpackScan(mutated, &scan, &error));
  }
  llc::Scan bad;
  bad.ranges = {1.0, 2.0};
  bad.bearings = {0.0};
  EXPECT_THROW(llc::packScan(bad), std::invalid_argument);
  bad.bearings = {0.0, std::numeric_limits<double>::quiet_NaN()};
  EXPECT_THROW(llc::packScan(bad), std::invalid_argument);
}

}  // namespace
