// The Localizer on a simulated city mapped by the pipeline: it finds itself with no pose
// prior wherever the odometry's frame is, places every localized scan near its truth, notices
// being carried away and finds itself again; bad maps and scans are refused, not fatal.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "../test_util.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/core/slam/localizer.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"

namespace {

/// A drive mapped by the pipeline from the scans `scan_of` makes of its frames; the map frame
/// laid onto the truth by its keyframes.
struct MappedDrive {
  llc::SlamSession session;
  llc::Pose2 truth_from_map;
  template <class ScanOf>
  MappedDrive(const llc::SimDrive& drive, ScanOf&& scan_of) {
    llc::SlamPipeline slam(llc_test::defaultModel());
    for (std::size_t i = 0; i < drive.frames.size(); ++i) slam.addScan(scan_of(drive, drive.frames[i]), i, &drive.frames[i].odometry);
    session = slam.session();
    std::vector<llc::Pose2> truth;
    for (const llc::Keyframe& k : session.keyframes) truth.push_back(drive.frames[k.scan_index].truth);
    llc::alignedRmsError(session.poses, truth, &truth_from_map);
  }
};

struct CityDrive {
  llc::SimDrive drive = llc_test::simulatedDrive(600.0);
};

/// A 600 m drive mapped once for all tests, both scanners (the drive is made first: bases in order).
struct MappedCity : CityDrive, MappedDrive {
  MappedCity() : MappedDrive(drive, llc_test::frameScan) {}
};

const MappedCity& city() {
  static const MappedCity mapped;
  return mapped;
}

/// Position error of a map-frame pose against a truth pose.
double offBy(const llc::Pose2& map_pose, const llc::Pose2& truth) {
  const llc::Pose2 e = llc::between(truth, llc::compose(city().truth_from_map, map_pose));
  return std::hypot(e.x, e.y);
}

struct Fed {
  std::vector<llc::LocalizationStep> steps;
  std::vector<std::size_t> frames;  ///< the frame each step was
};

/// Feeds frames [begin, end) with their odometry carried by `odometry_frame` (any frame).
void feed(llc::Localizer& localizer, std::size_t begin, std::size_t end, const llc::Pose2& odometry_frame, Fed* fed,
          const llc::Pose2* continue_from = nullptr) {
  const auto& frames = city().drive.frames;
  for (std::size_t i = begin; i < end && i < frames.size(); ++i) {
    llc::Pose2 odometry = llc::compose(odometry_frame, frames[i].odometry);
    if (continue_from)  // carried away: the odometry goes on from where it was, as if not moved
      odometry = llc::compose(*continue_from, llc::between(frames[begin].odometry, frames[i].odometry));
    fed->steps.push_back(localizer.addScan(llc_test::frameScan(city().drive, frames[i]), &odometry));
    fed->frames.push_back(i);
  }
}

TEST(Localizer, FindsItselfWithNoPriorAndTracksNearTheTruth) {
  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session);
  Fed fed;
  feed(localizer, 400, 650, llc::Pose2{1000.0, -500.0, 2.0}, &fed);  // an odometry frame far from the map's
  std::size_t localized = 0, fixes = 0;
  double worst = 0.0;
  for (std::size_t k = 0; k < fed.steps.size(); ++k) {
    const llc::LocalizationStep& step = fed.steps[k];
    fixes += step.fixed;
    if (!step.has_pose) continue;
    ++localized;
    worst = std::max(worst, offBy(step.pose, city().drive.frames[fed.frames[k]].truth));
  }
  EXPECT_GE(fixes, 1u);
  EXPECT_GT(localized, fed.steps.size() / 2) << "fixed late or lost often";
  EXPECT_LT(worst, 0.3) << "a localized pose far from its truth";
  EXPECT_EQ(localizer.state(), llc::LocalizationState::kLocalized);
}

TEST(Localizer, MatchesThePredictionRulesOutAreTakenWhenTheNextAgrees) {
  // A gate so tight that every match is ruled out: a match alone is kept out, but the next
  // keyframe's agrees with it (the prediction, not the map, would be astray), so every second
  // one is taken and the robot stays tracked near its truth.
  llc::LocalizerOptions options;
  options.max_track_chi2 = 1e-12;
  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session, options);
  Fed fed;
  feed(localizer, 400, 650, llc::Pose2{1000.0, -500.0, 2.0}, &fed);
  double worst = 0.0;
  std::size_t localized = 0;
  for (std::size_t k = 0; k < fed.steps.size(); ++k)
    if (fed.steps[k].has_pose) ++localized, worst = std::max(worst, offBy(fed.steps[k].pose, city().drive.frames[fed.frames[k]].truth));
  const llc::LocalizerCounters& c = localizer.counters();
  EXPECT_GT(localized, fed.steps.size() / 2);
  EXPECT_LT(worst, 0.3);
  EXPECT_GT(c.disagreeing_keyframes, 0u);
  EXPECT_GT(c.tracked_keyframes, 0u);
  EXPECT_LE(c.tracked_keyframes, c.disagreeing_keyframes) << "each taken match follows one kept out";
  // At 30 (3 dof, p about 1e-6), on this drive the prediction and the map agree: nothing is
  // kept out.
  options.max_track_chi2 = 30.0;
  llc::Localizer gated(llc_test::defaultModel(), {}, city().session, options);
  Fed plain;
  feed(gated, 400, 650, llc::Pose2{1000.0, -500.0, 2.0}, &plain);
  EXPECT_EQ(gated.counters().disagreeing_keyframes, 0u);
  EXPECT_GT(gated.counters().tracked_keyframes, 10u);
}

TEST(Localizer, TheOdometryFrameChangesNothing) {
  llc::Localizer a(llc_test::defaultModel(), {}, city().session), b(llc_test::defaultModel(), {}, city().session);
  Fed fa, fb;
  feed(a, 400, 520, llc::Pose2{}, &fa);
  feed(b, 400, 520, llc::Pose2{-300.0, 250.0, -1.0}, &fb);
  ASSERT_EQ(fa.steps.size(), fb.steps.size());
  for (std::size_t k = 0; k < fa.steps.size(); ++k) {
    ASSERT_EQ(fa.steps[k].has_pose, fb.steps[k].has_pose) << "step " << k;
    if (!fa.steps[k].has_pose) continue;
    EXPECT_NEAR(fa.steps[k].pose.x, fb.steps[k].pose.x, 1e-3);
    EXPECT_NEAR(fa.steps[k].pose.y, fb.steps[k].pose.y, 1e-3);
  }
}

TEST(Localizer, NoticesBeingCarriedAwayAndFindsItselfAgain) {
  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session);
  Fed fed;
  feed(localizer, 400, 560, llc::Pose2{}, &fed);
  ASSERT_EQ(localizer.state(), llc::LocalizationState::kLocalized);
  const llc::Pose2 last_odometry = city().drive.frames[559].odometry;
  const std::size_t kidnapped_at = fed.steps.size();
  feed(localizer, 150, 330, llc::Pose2{}, &fed, &last_odometry);  // carried 400 scans back, to a mapped street
  std::size_t lost_at = 0;
  for (std::size_t k = kidnapped_at; k < fed.steps.size() && lost_at == 0; ++k)
    if (fed.steps[k].lost) lost_at = k;
  ASSERT_GT(lost_at, 0u) << "never noticed";
  EXPECT_LE(lost_at - kidnapped_at, 20u) << "noticed after more than 2 s of scans";
  EXPECT_FALSE(fed.steps[lost_at].why_lost.empty());
  std::size_t fixed_again = 0;
  for (std::size_t k = lost_at; k < fed.steps.size(); ++k) {
    fixed_again += fed.steps[k].fixed;
    if (fed.steps[k].has_pose) EXPECT_LT(offBy(fed.steps[k].pose, city().drive.frames[fed.frames[k]].truth), 1.0) << "step " << k;
  }
  EXPECT_GE(fixed_again, 1u);
  EXPECT_EQ(localizer.counters().lost_events, 1u);
  EXPECT_EQ(localizer.counters().relocalizations, 1u);
}

/// The same drive mapped by its front scanner alone (180 degrees).
struct FrontOnlyCity : MappedDrive {
  FrontOnlyCity() : MappedDrive(city().drive, llc_test::frontScan) {}
};

const FrontOnlyCity& frontOnlyCity() {
  static const FrontOnlyCity mapped;
  return mapped;
}

/// What a 180-degree scanner at frame `frame`'s place sees turned by `turn` from its heading:
/// the beams of the 360-degree scan within 90 degrees of the new heading, in the turned frame.
llc::Scan turnedHalfView(const llc::SimFrame& frame, double turn, double stamp) {
  const llc::Scan full = llc_test::frameScan(city().drive, frame);
  std::vector<std::pair<double, double>> beams;  // (bearing, range)
  for (std::size_t i = 0; i < full.size(); ++i) {
    const double bearing = llc::normalizeAngle(full.bearings[i] - turn);
    if (std::abs(bearing) <= M_PI / 2) beams.emplace_back(bearing, full.ranges[i]);
  }
  std::sort(beams.begin(), beams.end());
  llc::Scan half;
  for (const auto& [bearing, range] : beams) half.bearings.push_back(bearing), half.ranges.push_back(range);
  half.stamp = stamp;
  return half;
}

/// Turns a 180-degree scanner on the spot at a mapped place, 0.4 rad per keyframe: the steps.
std::vector<llc::LocalizationStep> turnOnTheSpot(llc::Localizer& localizer, std::size_t frame, int keyframes) {
  const llc::SimFrame& at = city().drive.frames[frame];
  std::vector<llc::LocalizationStep> steps;
  for (int k = 0; k < keyframes; ++k) {
    const double turn = 0.4 * k;
    const llc::Pose2 odometry = llc::compose(at.odometry, llc::Pose2{0.0, 0.0, turn});
    steps.push_back(localizer.addScan(turnedHalfView(at, turn, at.stamp + double(k)), &odometry));
  }
  return steps;
}

TEST(Localizer, AHalfCircleScannerTurningOnTheSpotFindsItselfWithoutDriving) {
  // Its keyframes see new walls as it turns: they count as views apart (join/min_new_view), as
  // metres of path do. With that off, the same turn never fixes it: 0 m of path.
  llc::Localizer turning(llc_test::defaultModel(), {}, frontOnlyCity().session);
  const std::vector<llc::LocalizationStep> steps = turnOnTheSpot(turning, 450, 9);
  const llc::Pose2& truth = city().drive.frames[450].truth;
  std::size_t fixes = 0;
  for (std::size_t k = 0; k < steps.size(); ++k) {
    fixes += steps[k].fixed;
    if (!steps[k].has_pose) continue;
    const llc::Pose2 e = llc::between(llc::compose(truth, llc::Pose2{0.0, 0.0, 0.4 * double(k)}),
                                      llc::compose(frontOnlyCity().truth_from_map, steps[k].pose));
    EXPECT_LT(std::hypot(e.x, e.y), 0.3) << "step " << k;
    EXPECT_LT(std::abs(e.theta), 0.05) << "step " << k;
  }
  EXPECT_EQ(fixes, 1u);
  llc::LocalizerOptions off;
  off.join.min_new_view = 0.0;
  llc::Localizer still(llc_test::defaultModel(), {}, frontOnlyCity().session, off);
  for (const llc::LocalizationStep& step : turnOnTheSpot(still, 450, 9)) EXPECT_FALSE(step.has_pose);
}

TEST(Localizer, LetsGoOfItsOwnOldScansAndTracksTheSame) {
  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session);
  Fed fed;
  feed(localizer, 300, 650, llc::Pose2{}, &fed);
  const llc::LocalizerCounters& c = localizer.counters();
  // Only the join's window (30 m of path, about 20 keyframes here) keeps its scans.
  EXPECT_GT(c.scans_released, c.keyframes - 40) << c.keyframes << " keyframes";
  EXPECT_LT(c.scans_released, c.keyframes);
  EXPECT_EQ(localizer.state(), llc::LocalizationState::kLocalized);
  for (std::size_t k = 0; k < fed.steps.size(); ++k)
    if (fed.steps[k].has_pose) EXPECT_LT(offBy(fed.steps[k].pose, city().drive.frames[fed.frames[k]].truth), 0.3) << "step " << k;
}

TEST(LoopDetector, AKeyframeWhoseScanWasLetGoIsRefusedClearly) {
  const llc::SimDrive& drive = city().drive;
  llc::LoopDetector detector(llc_test::defaultModel(), llc::ScanAlignerOptions{});
  for (std::size_t i = 0; i < 3; ++i) detector.add(llc_test::frameScan(drive, drive.frames[10 * i]));
  detector.releasePrepared(1);
  detector.releasePrepared(99);  // unknown: ignored
  EXPECT_FALSE(detector.hasPrepared(1));
  EXPECT_TRUE(detector.hasPrepared(2));
  EXPECT_THROW(detector.prepared(1), std::out_of_range);
  EXPECT_THROW(detector.verify(0, 1, 1.0), std::out_of_range);
  EXPECT_EQ(detector.features(1).size(), detector.features(0).size()) << "its features stay";
  EXPECT_NO_THROW(detector.verify(0, 2, 1.0));
}

TEST(Localizer, ARequestedSearchForgetsTheFix) {
  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session);
  Fed fed;
  feed(localizer, 400, 520, llc::Pose2{}, &fed);
  ASSERT_EQ(localizer.state(), llc::LocalizationState::kLocalized);
  localizer.relocalize("asked to");
  EXPECT_EQ(localizer.state(), llc::LocalizationState::kLost);
  feed(localizer, 520, 600, llc::Pose2{}, &fed);
  EXPECT_EQ(localizer.state(), llc::LocalizationState::kLocalized);
  EXPECT_EQ(localizer.counters().relocalizations, 1u);
}

TEST(Localizer, APoseHintNarrowsTheSearchAndAWrongOneLapses) {
  const llc::Pose2 truth = llc::compose(llc::inverse(city().truth_from_map), city().drive.frames[399].truth);  // in the map
  // Right: the fix comes from the keyframes near the hint, no later than with no hint.
  llc::Localizer hinted(llc_test::defaultModel(), {}, city().session), plain(llc_test::defaultModel(), {}, city().session);
  EXPECT_FALSE(hinted.hint(llc::Pose2{std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0}, 3.0));
  EXPECT_FALSE(hinted.hint(truth, 0.0));
  ASSERT_TRUE(hinted.hint(truth, 3.0));
  EXPECT_TRUE(hinted.hinted());
  Fed with_hint, without;
  feed(hinted, 399, 520, llc::Pose2{50.0, 20.0, 1.0}, &with_hint);  // the hint is where scan 399 is taken
  feed(plain, 399, 520, llc::Pose2{50.0, 20.0, 1.0}, &without);
  auto firstFix = [](const Fed& fed) {
    for (std::size_t k = 0; k < fed.steps.size(); ++k)
      if (fed.steps[k].fixed) return k;
    return fed.steps.size();
  };
  ASSERT_LT(firstFix(with_hint), with_hint.steps.size()) << "a right hint gave no fix";
  EXPECT_LE(firstFix(with_hint), firstFix(without)) << "hinted " << firstFix(with_hint) << ", not " << firstFix(without);
  EXPECT_FALSE(hinted.hinted()) << "a fix ends the hint";
  for (std::size_t k = 0; k < with_hint.steps.size(); ++k)
    if (with_hint.steps[k].has_pose)
      EXPECT_LT(offBy(with_hint.steps[k].pose, city().drive.frames[with_hint.frames[k]].truth), 0.3) << "step " << k;
  // Wrong (60 m away): no fix while it holds, then the whole map is searched and the robot found.
  llc::LocalizerOptions short_hint;
  short_hint.hint_max_travel = 20.0;
  llc::Localizer misled(llc_test::defaultModel(), {}, city().session, short_hint);
  ASSERT_TRUE(misled.hint(llc::compose(truth, llc::Pose2{60.0, 0.0, 0.0}), 3.0));
  Fed fed;
  feed(misled, 399, 600, llc::Pose2{}, &fed);
  const double travel_at_fix = [&] {
    for (std::size_t k = 0; k < fed.steps.size(); ++k)
      if (fed.steps[k].fixed) {
        const llc::Pose2& a = city().drive.frames[399].odometry;
        const llc::Pose2& b = city().drive.frames[fed.frames[k]].odometry;
        EXPECT_LT(offBy(fed.steps[k].pose, city().drive.frames[fed.frames[k]].truth), 0.3) << "fixed where hinted, wrongly";
        return std::hypot(b.x - a.x, b.y - a.y);
      }
    return -1.0;
  }();
  EXPECT_GT(travel_at_fix, short_hint.hint_max_travel) << "fixed while a wrong hint held, or never (-1)";
  EXPECT_EQ(misled.counters().relocalizations, 0u) << "a hint before any fix makes the first fix no relocalisation";
}

TEST(Localizer, LocalizedPosesCarryAUsableCovariance) {
  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session);
  Fed fed;
  feed(localizer, 400, 560, llc::Pose2{7.0, -3.0, 0.5}, &fed);
  std::size_t localized = 0, within_three_sigma = 0;
  for (std::size_t k = 0; k < fed.steps.size(); ++k) {
    const llc::LocalizationStep& step = fed.steps[k];
    if (k > 0) EXPECT_TRUE(step.has_trajectory_pose) << "step " << k;
    if (!step.has_pose) continue;
    ++localized;
    const Eigen::Matrix3d& c = step.covariance;
    ASSERT_TRUE(c.allFinite()) << "step " << k;
    EXPECT_LT((c - c.transpose()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_GT(c(0, 0), 0.0);
    EXPECT_GT(c(1, 1), 0.0);
    EXPECT_GT(c(2, 2), 0.0);
    EXPECT_GE(c.selfadjointView<Eigen::Lower>().eigenvalues().minCoeff(), -1e-12);
    const double off = offBy(step.pose, city().drive.frames[fed.frames[k]].truth);
    within_three_sigma += off <= 3.0 * std::sqrt(c(0, 0) + c(1, 1)) + 0.05;  // the map's own error: a few cm
  }
  ASSERT_GT(localized, 50u);
  EXPECT_GT(double(within_three_sigma), 0.9 * double(localized)) << "a covariance far too sure of itself";
}

TEST(LocalizerFuse, WeighsTheMapMatchAndThePredictionByTheirCovariances) {
  // Equal covariances: half way, and half the covariance.
  llc::Pose2 measured{2.0, 0.0, 0.2};
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  llc::fuse(llc::Pose2{0.0, 0.0, 0.0}, Eigen::Matrix3d::Identity(), &measured, &covariance);
  EXPECT_NEAR(measured.x, 1.0, 1e-12);
  EXPECT_NEAR(measured.theta, 0.1, 1e-12);
  EXPECT_TRUE(covariance.isApprox(0.5 * Eigen::Matrix3d::Identity(), 1e-12));
  // A corridor along x: ICP cannot tell x (variance 100), the odometry can (0.01): the match
  // moves y, not x.
  measured = {1.0, 0.2, 0.0};
  covariance = Eigen::Vector3d(100.0, 1e-4, 1e-4).asDiagonal();
  llc::fuse(llc::Pose2{0.0, 0.0, 0.0}, 0.01 * Eigen::Matrix3d::Identity(), &measured, &covariance);
  EXPECT_NEAR(measured.x, 0.01 / 100.01, 1e-9);
  EXPECT_NEAR(measured.y, 0.2 * 0.01 / 0.0101, 1e-9);
  // Angles wrap: 179 deg and -179 deg meet at 180, not at 0.
  measured = {0.0, 0.0, -179.0 * M_PI / 180.0};
  covariance = Eigen::Matrix3d::Identity();
  llc::fuse(llc::Pose2{0.0, 0.0, 179.0 * M_PI / 180.0}, Eigen::Matrix3d::Identity(), &measured, &covariance);
  EXPECT_NEAR(std::abs(measured.theta), M_PI, 1e-9);
  // No covariance to weigh (none, or not finite): the measurement as it is.
  measured = {3.0, 4.0, 0.5};
  covariance = Eigen::Matrix3d::Identity();
  llc::fuse(llc::Pose2{}, Eigen::Matrix3d::Zero(), &measured, &covariance);
  EXPECT_EQ(measured.x, 3.0);
  llc::fuse(llc::Pose2{}, Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN()), &measured, &covariance);
  EXPECT_EQ(measured.y, 4.0);
  EXPECT_TRUE(covariance.isApprox(Eigen::Matrix3d::Identity()));
}

TEST(LocalizerFuse, InnovationChi2IsTheDifferenceUnderBothCovariances) {
  // Unit covariances: the sum is 2 I, so chi2 = |v|^2 / 2.
  const Eigen::Matrix3d unit = Eigen::Matrix3d::Identity();
  EXPECT_NEAR(llc::innovationChi2({0.0, 0.0, 0.0}, unit, {2.0, 0.0, 0.2}, unit), (4.0 + 0.04) / 2.0, 1e-12);
  // A heading of 0.2 rad against sigmas of 0.01 rad each: (0.2)^2 / 2e-4 = 200, far outside;
  // the same turn with a prediction of 0.2 rad sigma: under 1.
  const Eigen::Matrix3d tight = 1e-4 * unit, loose = 0.04 * unit;
  EXPECT_NEAR(llc::innovationChi2({}, tight, {0.0, 0.0, 0.2}, tight), 200.0, 1e-9);
  EXPECT_LT(llc::innovationChi2({}, loose, {0.0, 0.0, 0.2}, tight), 1.0);
  // Headings wrap: 179 and -179 degrees are 2 degrees apart.
  const double two_degrees = 2.0 * M_PI / 180.0;
  EXPECT_NEAR(llc::innovationChi2({0.0, 0.0, 179.0 * M_PI / 180.0}, tight, {0.0, 0.0, -179.0 * M_PI / 180.0}, tight),
              two_degrees * two_degrees / 2e-4, 1e-6);
  // Nothing to judge by: 0.
  EXPECT_EQ(llc::innovationChi2({}, Eigen::Matrix3d::Zero(), {5.0, 0.0, 0.0}, Eigen::Matrix3d::Zero()), 0.0);
  EXPECT_EQ(llc::innovationChi2({}, Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN()), {5.0, 0.0, 0.0}, unit), 0.0);
}

TEST(LoopDetector, AScanFromOutsideIsSearchedAlikeOnOneThreadOrTwo) {
  const llc::SlamOptions options;
  llc::LoopDetector map(llc_test::defaultModel(), options.aligner, options.loops);
  for (std::size_t k = 0; k < city().session.keyframes.size(); ++k)
    map.addWithFeatures(city().session.features[k], map.aligner().prepare(city().session.keyframes[k].scan));
  const llc::Scan scan = llc_test::frameScan(city().drive, city().drive.frames[451]);
  const auto prepared = map.aligner().prepare(scan);
  const llc::LoopDetectionResult one = map.detectScan(map.describe(scan), *prepared, 7, 20, 0.0, 1);
  const llc::LoopDetectionResult two = map.detectScan(map.describe(scan), *prepared, 7, 20, 0.0, 2);
  ASSERT_EQ(one.aligned.size(), two.aligned.size());
  ASSERT_GT(one.aligned.size(), 1u);
  std::size_t accepted = 0;
  for (std::size_t i = 0; i < one.aligned.size(); ++i) {
    EXPECT_EQ(one.aligned[i].from, two.aligned[i].from);
    EXPECT_EQ(one.aligned[i].to, 7u);
    EXPECT_EQ(one.aligned[i].accepted, two.aligned[i].accepted);
    EXPECT_DOUBLE_EQ(one.aligned[i].pose.x, two.aligned[i].pose.x);
    accepted += one.aligned[i].accepted;
  }
  EXPECT_GE(accepted, 1u) << "a scan of a mapped street finds the map";
  EXPECT_THROW(map.detectScan({1.0, 2.0}, *prepared, 7, 20), std::invalid_argument);
}

TEST(Localizer, BadMapsAndScansAreRefusedNotFatal) {
  EXPECT_THROW(llc::Localizer(llc_test::defaultModel(), {}, llc::SlamSession{}), std::invalid_argument);
  llc::SlamSession broken = city().session;
  broken.poses.pop_back();
  EXPECT_THROW(llc::Localizer(llc_test::defaultModel(), {}, broken), std::invalid_argument);
  llc::LocalizerOptions bad;
  bad.min_track_fit = 0.0;
  EXPECT_THROW(llc::Localizer(llc_test::defaultModel(), {}, city().session, bad), std::invalid_argument);
  for (const double chi2 : {-1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    llc::LocalizerOptions bad_gate;
    bad_gate.max_track_chi2 = chi2;
    EXPECT_NE(bad_gate.validate().find("max_track_chi2"), std::string::npos) << chi2;
  }
  llc::LocalizerOptions off;
  off.max_track_chi2 = 0.0;  // off is allowed
  EXPECT_EQ(off.validate(), "");
  // A share out of range is refused, naming the field.
  using Field = double llc::LocalizerOptions::*;
  for (const auto& [field, name, lowest_bad] : {std::tuple<Field, const char*, double>{&llc::LocalizerOptions::min_inlier_share, "min_inlier_share", 0.0},
                                                std::tuple<Field, const char*, double>{&llc::LocalizerOptions::global_search_below, "global_search_below", -0.1}})
    for (const double value : {lowest_bad, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
      llc::LocalizerOptions bad_share;
      bad_share.*field = value;
      try {
        llc::Localizer(llc_test::defaultModel(), {}, city().session, bad_share);
        ADD_FAILURE() << name << " " << value << " taken";
      } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      }
    }

  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session);
  llc::Scan scan = llc_test::frameScan(city().drive, city().drive.frames[10]);
  scan.ranges[3] = std::numeric_limits<double>::quiet_NaN();
  scan.ranges.pop_back();  // ranges and bearings of different counts
  const llc::Pose2 odometry{0.0, 0.0, 0.0};
  const llc::LocalizationStep step = localizer.addScan(scan, &odometry);
  EXPECT_FALSE(step.skip_reason.empty());
  EXPECT_FALSE(step.has_pose);
  const llc::Pose2 nan_odometry{std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  EXPECT_FALSE(localizer.addScan(llc_test::frameScan(city().drive, city().drive.frames[11]), &nan_odometry).has_pose);
  EXPECT_EQ(localizer.state(), llc::LocalizationState::kLost);
  llc::Scan empty;
  empty.stamp = city().drive.frames[12].stamp;
  localizer.addScan(empty, &odometry);  // no crash; nothing to place
  llc::Scan odd = llc_test::frameScan(city().drive, city().drive.frames[13]);
  odd.ranges[0] = std::numeric_limits<double>::infinity(), odd.ranges[1] = -std::numeric_limits<double>::infinity();
  odd.ranges[2] = -1.0;
  localizer.addScan(odd, &city().drive.frames[13].odometry);
}

TEST(Localizer, ItsOwnInlierShareValidatesTheMapsCandidates) {
  // The search alone (no fix: more keyframes must agree than are fed): a stricter N than the
  // aligner's keeps fewer of the same candidates' loops, a looser one more.
  auto loopsWith = [](double share) {
    llc::LocalizerOptions options;
    options.min_inlier_share = share;
    options.join.min_keyframes = 1000;
    llc::Localizer localizer(llc_test::defaultModel(), {}, city().session, options);
    Fed fed;
    feed(localizer, 400, 460, llc::Pose2{}, &fed);
    EXPECT_EQ(localizer.counters().fixes, 0u);
    return localizer.counters().loops_to_map;
  };
  const std::size_t loose = loopsWith(0.5), usual = loopsWith(0.85), strict = loopsWith(0.999);
  EXPECT_GT(usual, 0u);
  EXPECT_GE(loose, usual);
  EXPECT_GT(usual, strict) << "the option did not reach the map's aligner";
}

TEST(Localizer, ItsCandidatesSkipTheGlobalSearchThatMappingRunsOnPoorFits) {
  // Localisation's threshold can only lower mapping's (the smaller of the two is taken).
  llc::ScanAlignerOptions mapping;
  mapping.global_search_below = 0.7;
  llc::LocalizerOptions localization;
  EXPECT_EQ(localization.global_search_below, 0.0);  // the shipped default: only when no start converged
  localization.min_inlier_share = 0.8;
  llc::ScanAlignerOptions own = llc::mapAlignerOptions(mapping, localization);
  EXPECT_EQ(own.global_search_below, 0.0);
  EXPECT_EQ(own.reverse_below, mapping.reverse_below);
  EXPECT_EQ(own.validation.min_inlier_share, 0.8);
  localization.global_search_below = 0.9;
  EXPECT_EQ(llc::mapAlignerOptions(mapping, localization).global_search_below, 0.7);
  localization.global_search_below = 0.5;
  EXPECT_EQ(llc::mapAlignerOptions(mapping, localization).global_search_below, 0.5);

  // Two places of the city: where a start converged but fits poorly, mapping's aligner goes on
  // to the global search, localisation's stops there (and goes on only when none converged).
  // One place twice: the same loop.
  const llc::ScanAligner mapping_aligner(mapping), localization_aligner(llc::mapAlignerOptions(mapping, {}));
  const auto& frames = city().drive.frames;
  auto prepared = [&](const llc::ScanAligner& aligner, std::size_t frame) {
    return aligner.prepare(llc_test::frameScan(city().drive, frames[frame]));
  };
  std::size_t compared = 0;
  for (const auto& [a, b] : std::vector<std::pair<std::size_t, std::size_t>>{{40, 520}, {120, 330}, {200, 560}, {260, 470}, {60, 250}, {150, 420}}) {
    const llc::ScanAlignmentResult full = mapping_aligner.align(*prepared(mapping_aligner, a), *prepared(mapping_aligner, b));
    const llc::ScanAlignmentResult fast =
        localization_aligner.align(*prepared(localization_aligner, a), *prepared(localization_aligner, b));
    if (full.global.poses.empty() || !fast.global.poses.empty()) continue;  // a good fit early, or no start converged
    ++compared;
    EXPECT_FALSE(fast.icp_poses.empty()) << a << "-" << b;
    EXPECT_LT(fast.icp_poses.size(), full.icp_poses.size()) << a << "-" << b;
  }
  EXPECT_GE(compared, 2u) << "too few pairs where mapping's aligner ran the global search";
  const llc::ScanAlignmentResult full = mapping_aligner.align(*prepared(mapping_aligner, 300), *prepared(mapping_aligner, 301));
  const llc::ScanAlignmentResult fast =
      localization_aligner.align(*prepared(localization_aligner, 300), *prepared(localization_aligner, 301));
  ASSERT_TRUE(full.accepted);
  EXPECT_TRUE(fast.accepted);
  EXPECT_DOUBLE_EQ(full.pose.x, fast.pose.x);
  EXPECT_DOUBLE_EQ(full.pose.theta, fast.pose.theta);
}

TEST(Localizer, TimeGoingBackwardsIsSkippedOrRestartsTheChainAndTheFixIsKept) {
  llc::Localizer localizer(llc_test::defaultModel(), {}, city().session);
  Fed fed;
  feed(localizer, 400, 520, llc::Pose2{}, &fed);
  ASSERT_EQ(localizer.state(), llc::LocalizationState::kLocalized);
  const std::size_t keyframes = localizer.counters().keyframes;
  const auto& second_back = city().drive.frames[510];  // 1 s back: skipped
  const llc::LocalizationStep skipped = localizer.addScan(llc_test::frameScan(city().drive, second_back), &second_back.odometry);
  EXPECT_FALSE(skipped.skip_reason.empty());
  EXPECT_FALSE(skipped.keyframe);
  EXPECT_EQ(localizer.counters().keyframes, keyframes);
  // 7 s back (beyond restart_after_jump_back): a new odometry chain, in the same trajectory frame.
  const auto& far_back = city().drive.frames[450];
  localizer.addScan(llc_test::frameScan(city().drive, far_back), &far_back.odometry);
  feed(localizer, 520, 560, llc::Pose2{}, &fed);
  EXPECT_EQ(localizer.state(), llc::LocalizationState::kLocalized) << "stale scans lost the fix";
  for (std::size_t k = fed.steps.size() - 40; k < fed.steps.size(); ++k)
    if (fed.steps[k].has_pose) EXPECT_LT(offBy(fed.steps[k].pose, city().drive.frames[fed.frames[k]].truth), 0.3);
}

}  // namespace
