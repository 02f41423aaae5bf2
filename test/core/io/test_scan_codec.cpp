// packScan / unpackScan: a simulated 360-degree scan's points round-trip within half a step,
// no return stays no return, the packing is a fraction of the float32 message and finds the
// scanners the beams came from,
// and anything that is not a packed scan (truncated, corrupt, random) is refused, never thrown.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "../test_util.hpp"
#include "laser_loop_closure/core/io/range_coder.hpp"
#include "laser_loop_closure/core/io/scan_codec.hpp"

namespace {

TEST(RangeCoder, RoundTripsBitsAndIntegersAndSpendsLittleOnWhatItPredicts) {
  std::mt19937_64 random(11);
  std::vector<std::int64_t> values = {0, 1, -1, 2, -2, 3, 1000, -1000, (std::int64_t(1) << 62) - 1, -((std::int64_t(1) << 62) - 1)};
  for (int k = 0; k < 5000; ++k) {
    const int bits = 1 + int(random() % 61);  // magnitudes below 2^61
    values.push_back(std::int64_t(random() >> (64 - bits)) * (random() % 2 ? 1 : -1));
  }
  std::vector<bool> bits;
  for (int k = 0; k < 5000; ++k) bits.push_back(random() % 7 == 0);
  llc::RangeEncoder encoder;
  llc::IntegerModel integers;
  llc::BitModel skewed;
  for (std::size_t k = 0; k < values.size(); ++k) {
    integers.encode(encoder, values[k]);
    encoder.encode(skewed, bits[k % bits.size()]);
    encoder.encodeDirect(k % 3 == 0);
  }
  const std::vector<std::uint8_t> coded = encoder.finish();
  llc::RangeDecoder decoder(coded.data(), coded.size());
  llc::IntegerModel integers_back;
  llc::BitModel skewed_back;
  for (std::size_t k = 0; k < values.size(); ++k) {
    std::int64_t value = 0;
    ASSERT_TRUE(integers_back.decode(decoder, &value)) << k;
    ASSERT_EQ(value, values[k]) << k;
    ASSERT_EQ(decoder.decode(skewed_back), bits[k % bits.size()]) << k;
    ASSERT_EQ(decoder.decodeDirect(), k % 3 == 0) << k;
  }
  EXPECT_FALSE(decoder.overrun());
  EXPECT_EQ(decoder.consumed(), coded.size());  // every byte written is read, none beyond
  // 10,000 zeros in about their entropy under the adapting model (under 50 bytes), where a
  // byte-aligned code needs a bit each (1,250 bytes).
  llc::RangeEncoder zeros;
  llc::IntegerModel zero_model;
  for (int k = 0; k < 10000; ++k) zero_model.encode(zeros, 0);
  const std::vector<std::uint8_t> few = zeros.finish();
  EXPECT_LT(few.size(), 50u);
  // Cut short, the decoder reads zeros past the end and says so.
  llc::RangeDecoder cut(coded.data(), coded.size() / 2);
  llc::IntegerModel cut_integers;
  llc::BitModel cut_skewed;
  std::int64_t value = 0;
  for (std::size_t k = 0; k < values.size() && !cut.overrun(); ++k) {
    if (!cut_integers.decode(cut, &value)) break;
    cut.decode(cut_skewed);
    cut.decodeDirect();
  }
  EXPECT_TRUE(cut.overrun());
  llc::RangeEncoder too_large;
  EXPECT_THROW(integers.encode(too_large, std::int64_t(1) << 62), std::invalid_argument);
}

llc::Scan simulatedScan() {
  const llc::SimDrive drive = llc_test::simulatedDrive(60.0);
  return llc_test::frameScan(drive, drive.frames[drive.frames.size() / 2]);
}

/// Every return of `original` (beams 0, stride, 2 stride, ...) has a return of `back` within
/// half a range step and half a bearing step (times its range from a scanner that is at most
/// 2 m from the base) of it, as many no-returns at the same bearings, and back's bearings
/// increase. Brute force: a reference that needs no knowledge of the packing.
void expectSamePoints(const llc::Scan& original, const llc::Scan& back, const llc::ScanPackOptions& options) {
  std::vector<std::size_t> kept;
  for (std::size_t k = 0; k < original.size(); k += options.beam_stride) kept.push_back(k);
  ASSERT_EQ(back.size(), kept.size());
  for (std::size_t k = 1; k < back.size(); ++k) EXPECT_LE(back.bearings[k - 1], back.bearings[k]) << k;
  std::size_t returns = 0, no_returns = 0;
  for (const std::size_t k : kept) {
    const double r = original.ranges[k], b = original.bearings[k];
    if (!(std::isfinite(r) && r > 0.0)) {
      ++no_returns;
      continue;
    }
    ++returns;
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < back.size(); ++j)
      if (std::isfinite(back.ranges[j]))
        nearest = std::min(nearest, std::hypot(back.ranges[j] * std::cos(back.bearings[j]) - r * std::cos(b),
                                               back.ranges[j] * std::sin(back.bearings[j]) - r * std::sin(b)));
    EXPECT_LE(nearest, 0.5 * options.range_step + 0.5 * options.bearing_step * (r + 2.0) + 1e-9) << k << " at " << r << " m";
  }
  EXPECT_EQ(std::size_t(std::count_if(back.ranges.begin(), back.ranges.end(), [](double r) { return std::isinf(r) && r > 0; })),
            no_returns);
  EXPECT_EQ(returns + no_returns, back.size());
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
  EXPECT_EQ(back.full_circle, scan.full_circle);
  EXPECT_EQ(back.stamp, 12.5);  // the caller's: the packing has none
  expectSamePoints(scan, back, options);
  // What a keyframe message saves: float32 ranges and bearings take 8 bytes a beam.
  const double bytes_per_beam = double(packed.size()) / double(scan.size());
  std::cout << scan.size() << " beams: " << packed.size() << " bytes packed (" << bytes_per_beam << " per beam, float32: 8)\n";
  EXPECT_LT(bytes_per_beam, 1.12);  // LSC3 took 1.20, LSC2 (varints deflated by zlib) 1.56
  // As a back end keeps its map's scans (map_scan_step 0.5 mm): 10 times finer.
  llc::ScanPackOptions fine;
  fine.range_step = 0.0005, fine.bearing_step = 0.0005 / 50.0;
  const std::size_t fine_bytes = llc::packScan(scan, fine).size();
  std::cout << "at map_scan_step 0.5 mm: " << fine_bytes << " bytes\n";
  EXPECT_LT(fine_bytes, 1120u);  // LSC3: 1,154, LSC2: 1,566
}

TEST(ScanCodec, FindsTheScannersItsBeamsCameFrom) {
  // The simulated car's scanners sit 1.5 m ahead of and 1 m behind its base: seen from the base
  // origin their bearings do not step evenly, seen from the scanners they do. Packing from the
  // scanners' origins takes far fewer bytes than from the base origin alone (the same scan
  // with every bearing moved by a different random part of a step, which no origin explains).
  const llc::Scan scan = simulatedScan();
  llc::Scan shuffled = scan;
  std::mt19937 random(3);
  std::uniform_real_distribution<double> jitter(-0.3e-2, 0.3e-2);
  for (double& b : shuffled.bearings) b += jitter(random);
  const std::size_t from_scanners = llc::packScan(scan).size(), unexplained = llc::packScan(shuffled).size();
  std::cout << "from the scanners' origins: " << from_scanners << " bytes; bearings no origin explains: " << unexplained << "\n";
  EXPECT_LT(double(from_scanners), 0.8 * double(unexplained));
  // A scanner at the base origin (no mount offset), and one far off it: both round-trip.
  for (const double mount : {0.0, 4.0}) {
    llc::Scan one;
    for (int k = 0; k < 181; ++k) {
      const double phi = -M_PI / 2 + k * M_PI / 180.0, rho = 3.0 + 2.0 * std::sin(0.1 * k) + (k % 17 == 0 ? 10.0 : 0.0);
      const double x = mount + rho * std::cos(phi), y = rho * std::sin(phi);
      one.ranges.push_back(k % 29 == 0 ? std::numeric_limits<double>::infinity() : std::hypot(x, y));
      one.bearings.push_back(k % 29 == 0 ? phi : std::atan2(y, x));
    }
    llc::Scan back;
    std::string error;
    ASSERT_TRUE(llc::unpackScan(llc::packScan(one), &back, &error)) << error;
    expectSamePoints(one, back, llc::ScanPackOptions{});
  }
}

/// A scanner 1.5 m ahead of the base, 48 beams 4 degrees apart, one no return in 29.
llc::Scan lsc3SampleScan() {
  llc::Scan one;
  for (int k = 0; k < 48; ++k) {
    const double phi = -M_PI / 2 + k * M_PI / 180.0 * 4, rho = 3.0 + 2.0 * std::sin(0.4 * k) + (k % 17 == 0 ? 10.0 : 0.0);
    const double x = 1.5 + rho * std::cos(phi), y = rho * std::sin(phi);
    one.ranges.push_back(k % 29 == 0 ? std::numeric_limits<double>::infinity() : std::hypot(x, y));
    one.bearings.push_back(k % 29 == 0 ? phi : std::atan2(y, x));
  }
  return one;
}

TEST(ScanCodec, ReadsTheLsc3OfVersion020) {
  // lsc3SampleScan() as version 0.20.0's packScan wrote it: its range predictor counted every
  // miss in full, LSC4's caps them; read with the wrong rule, its ranges come back wrong.
  const std::vector<std::uint8_t> lsc3 = {
      0x4c, 0x53, 0x43, 0x33, 0x30, 0x00, 0x00, 0x00, 0x0a, 0xd7, 0xa3, 0x3b, 0x17, 0xb7, 0xd1, 0x38,
      0x00, 0x00, 0x44, 0xc5, 0x4c, 0x3d, 0xff, 0x81, 0xfb, 0x62, 0x1b, 0x95, 0x60, 0x28, 0xbb, 0x6a,
      0x2f, 0xff, 0x0b, 0x38, 0x64, 0x03, 0x0c, 0x71, 0x23, 0x5e, 0xe3, 0x0c, 0xfa, 0x72, 0xd9, 0xf5,
      0xb0, 0x82, 0x00, 0x3d, 0x7d, 0x3f, 0x19, 0xf1, 0x7c, 0xb5, 0xb6, 0x46, 0xf9, 0x15, 0xc0, 0xc6,
      0xb5, 0x82, 0x93, 0xe8, 0x85, 0x57, 0x81, 0x11, 0xe9, 0x0e, 0x59, 0xc3, 0x87, 0x05, 0xf5, 0x2c,
      0x1b, 0x17, 0xce, 0xb9, 0xeb, 0x45, 0x3a, 0x4b, 0xee, 0xea, 0x20, 0xe5, 0x96, 0x5c, 0xcc, 0x94,
      0xc0, 0xfc, 0x36, 0x7e, 0xee, 0xcb, 0xa8, 0xbc, 0x51, 0x61, 0x83, 0xdb, 0x18, 0x5f, 0x75, 0x66,
      0xd8, 0x91, 0xee, 0xde, 0xb0, 0x52, 0xaa, 0x5a, 0xca, 0x1f, 0x99, 0xee, 0x6e, 0x47, 0xad, 0xea,
      0x79, 0x38, 0x42, 0x0b, 0x6d, 0xe3, 0x03, 0x7d, 0x3a, 0xc9, 0x22, 0x10, 0x44, 0xce, 0x63, 0x24,
      0x9b, 0x16, 0x15, 0x82, 0x16, 0x5b, 0x7f, 0x9d, 0xd5, 0x99, 0x36, 0xd5, 0xed, 0x0e, 0x15, 0xdf,
      0x77, 0x22, 0x18, 0x36, 0xb9, 0x4e, 0x30, 0xb2, 0x9f, 0x7f, 0xf8, 0x36, 0x51, 0xae, 0x3b, 0x7e,
      0x32, 0x00};
  llc::Scan back;
  std::string error;
  ASSERT_TRUE(llc::unpackScan(lsc3, &back, &error)) << error;
  expectSamePoints(lsc3SampleScan(), back, llc::ScanPackOptions{});
  const std::vector<std::uint8_t> lsc4 = llc::packScan(lsc3SampleScan());
  EXPECT_EQ(lsc4[3], '4');
  ASSERT_TRUE(llc::unpackScan(lsc4, &back, &error)) << error;
  expectSamePoints(lsc3SampleScan(), back, llc::ScanPackOptions{});
  std::vector<std::uint8_t> misread = lsc3;
  misread[3] = '4';  // the same bytes read by LSC4's rule
  if (llc::unpackScan(misread, &back, &error)) {
    double worst = 0.0;
    const llc::Scan original = lsc3SampleScan();
    for (std::size_t k = 0; k < back.size(); ++k)
      if (std::isfinite(back.ranges[k])) worst = std::max(worst, std::abs(back.ranges[k] - original.ranges[k]));
    EXPECT_GT(worst, 0.05);  // the test above can fail: the two rules differ on this scan
  }
}

TEST(ScanCodec, AStrideKeepsEveryNthBeamAndAboutThatShareOfTheBytes) {
  const llc::Scan scan = simulatedScan();
  std::size_t fewer = llc::packScan(scan).size();
  const std::size_t full = fewer;
  for (const std::size_t stride : {2u, 3u}) {
    llc::ScanPackOptions options;
    options.beam_stride = stride;
    llc::Scan back;
    std::string error;
    ASSERT_TRUE(llc::unpackScan(llc::packScan(scan, options), &back, &error)) << error;
    expectSamePoints(scan, back, options);
    const std::size_t bytes = llc::packScan(scan, options).size();
    std::cout << "every " << stride << " beams: " << bytes << " bytes of " << full << "\n";
    EXPECT_LT(bytes, fewer) << stride;
    if (stride == 2) {
      EXPECT_LT(double(bytes), 0.65 * double(full));
    }  // neighbours further apart differ more: not quite half
    fewer = bytes;
  }
  llc::ScanPackOptions zero;
  zero.beam_stride = 0;
  EXPECT_THROW(llc::packScan(scan, zero), std::invalid_argument);
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
  std::vector<std::uint8_t> old_packing = packed;
  old_packing[3] = '1';
  EXPECT_FALSE(llc::unpackScan(old_packing, &scan, &error));
  EXPECT_NE(error.find("0.13.0"), std::string::npos) << error;
  old_packing[3] = '2';
  EXPECT_FALSE(llc::unpackScan(old_packing, &scan, &error));
  EXPECT_NE(error.find("LSC2"), std::string::npos) << error;
  std::vector<std::uint8_t> longer = packed;
  longer.push_back(0);
  EXPECT_FALSE(llc::unpackScan(longer, &scan, &error));
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
  // What a robot sends at worst: no beams, or no return at all: packed and read back, not refused.
  for (const llc::Scan& odd : {llc::Scan{}, llc_test::ringScan(std::vector<double>(90, std::numeric_limits<double>::infinity()))}) {
    llc::Scan back;
    ASSERT_TRUE(llc::unpackScan(llc::packScan(odd), &back, &error)) << error;
    EXPECT_EQ(back.size(), odd.size());
    for (const double r : back.ranges) EXPECT_TRUE(std::isinf(r));
  }
  llc::Scan bad;
  bad.ranges = {1.0, 2.0};
  bad.bearings = {0.0};
  EXPECT_THROW(llc::packScan(bad), std::invalid_argument);
  bad.bearings = {0.0, std::numeric_limits<double>::quiet_NaN()};
  EXPECT_THROW(llc::packScan(bad), std::invalid_argument);
}

}  // namespace
