// Nearby candidates (loops/nearby_candidates): keyframes the map puts near a new one, aligned
// when the classifier's candidates gave no loop. The detector's side (what it asks, what it
// aligns, what it never aligns twice) and the back end's (nearest first, only where the map
// knows the relative position well enough).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"
#include "laser_loop_closure/core/slam/slam_evaluation.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "../test_util.hpp"

namespace {

using llc_test::defaultModel;
using llc_test::frameScan;
using llc_test::simulatedDrive;


/// A NearbyKeyframes source that offers `offered` and records what it was asked.
struct RecordingSource {
  std::vector<std::size_t> offered;
  std::size_t calls = 0, index = 0, before = 0, count = 0;
  double max_distance = 0.0, max_std = 0.0;
  llc::NearbyKeyframes source() {
    return [this](std::size_t i, std::size_t b, double distance, double std, std::size_t c) {
      ++calls, index = i, before = b, max_distance = distance, max_std = std, count = c;
      std::vector<llc::NearbyKeyframe> nearby;
      for (std::size_t k : offered) nearby.push_back({k, false, llc::Pose2{}});  // no pose: searched as before
      return nearby;
    };
  }
};

}  // namespace

TEST(NearbyCandidates, TheMapsNearbyKeyframesAreAlignedWhenTheClassifierOffersNone) {
  const llc::SimDrive drive = simulatedDrive(80.0);
  llc::LoopDetectorOptions options;
  options.min_keyframe_gap = 5;
  options.score_threshold = 1.0;  // the classifier offers nothing short of identical features
  options.nearby_candidates = 2;
  llc::LoopDetector detector(defaultModel(), llc::ScanAlignerOptions{}, options);
  for (std::size_t i = 0; i < drive.frames.size(); i += 3) detector.add(frameScan(drive, drive.frames[i]));
  // Near the first place (one frame on), turned by 2 rad.
  const std::size_t query = detector.add(llc::rotateScan(frameScan(drive, drive.frames[1]), 2.0));
  const std::size_t compared = query - options.min_keyframe_gap;

  RecordingSource map;
  map.offered = {query - 1, compared, 0, 1};  // two too recent to be loops, then the nearest
  const llc::LoopDetectionResult result = detector.detect(query, {}, map.source());
  ASSERT_EQ(result.candidates, 0u) << "the test needs a classifier that offers no candidate";
  EXPECT_EQ(map.calls, 1u);
  EXPECT_EQ(map.index, query);
  EXPECT_EQ(map.before, compared);
  EXPECT_EQ(map.max_distance, options.nearby_distance);
  EXPECT_EQ(map.max_std, options.nearby_max_std);
  EXPECT_GE(map.count, options.nearby_candidates);
  // The recent ones are never aligned; the first nearby one is, and it is the truth.
  ASSERT_EQ(result.aligned.size(), 1u) << "stop_at_first_accepted";
  EXPECT_EQ(result.nearby, 1u);
  const llc::LoopClosure& loop = result.aligned.front();
  EXPECT_EQ(loop.from, 0u);
  EXPECT_EQ(loop.to, query);
  ASSERT_TRUE(loop.accepted) << loop.reject_reason;
  EXPECT_EQ(loop.score, detector.pairScore(0, query));
  const llc::Pose2 truth = llc::between(drive.frames[0].truth, llc::compose(drive.frames[1].truth, llc::Pose2{0.0, 0.0, 2.0}));
  const llc::Pose2 error = llc::between(truth, loop.pose);
  EXPECT_LT(std::hypot(error.x, error.y), 0.1);
  EXPECT_LT(std::abs(error.theta), 0.01);

  // The place gate is asked about nearby keyframes as about the classifier's: what it refuses
  // frees the slot for the next one.
  const llc::LoopDetectionResult gated = detector.detect(
      query, [](std::size_t from, std::size_t) {
        return from == 0 ? llc::LoopVerdict{llc::LoopRefusal::kPlaceGate, "not here"} : llc::LoopVerdict{};
      },
      map.source());
  ASSERT_EQ(gated.not_aligned.size(), 1u);
  EXPECT_EQ(gated.not_aligned.front().from, 0u);
  ASSERT_EQ(gated.aligned.size(), 1u);
  EXPECT_EQ(gated.aligned.front().from, 1u);
  EXPECT_EQ(gated.nearby, 1u);

  // Without stop_at_first_accepted, at most nearby_candidates are aligned.
  llc::LoopDetectorOptions every = options;
  every.stop_at_first_accepted = false;
  every.nearby_candidates = 1;
  llc::LoopDetector one(defaultModel(), llc::ScanAlignerOptions{}, every);
  for (std::size_t i = 0; i < drive.frames.size(); i += 3) one.add(frameScan(drive, drive.frames[i]));
  one.add(llc::rotateScan(frameScan(drive, drive.frames[1]), 2.0));
  EXPECT_EQ(one.detect(query, {}, map.source()).aligned.size(), 1u);

  // nearby_candidates 0: the classifier alone, the source is not asked.
  llc::LoopDetectorOptions off = options;
  off.nearby_candidates = 0;
  llc::LoopDetector paper(defaultModel(), llc::ScanAlignerOptions{}, off);
  for (std::size_t i = 0; i < drive.frames.size(); i += 3) paper.add(frameScan(drive, drive.frames[i]));
  paper.add(llc::rotateScan(frameScan(drive, drive.frames[1]), 2.0));
  RecordingSource unasked;
  unasked.offered = {0};
  EXPECT_TRUE(paper.detect(query, {}, unasked.source()).aligned.empty());
  EXPECT_EQ(unasked.calls, 0u);
}


TEST(NearbyCandidates, ANearbyKeyframeWhoseMapPoseFitsNothingIsRefusedWithoutTheSearch) {
  const llc::SimDrive drive = simulatedDrive(80.0);
  llc::LoopDetectorOptions options;
  options.min_keyframe_gap = 5;
  options.score_threshold = 1.0;  // the classifier offers nothing
  options.nearby_candidates = 1;
  const llc::Pose2 truth = llc::between(drive.frames[0].truth, llc::compose(drive.frames[1].truth, llc::Pose2{0.0, 0.0, 2.0}));
  for (const double min_fit : {0.3, 0.0}) {
    options.nearby_min_predicted_fit = min_fit;
    llc::LoopDetector detector(defaultModel(), llc::ScanAlignerOptions{}, options);
    for (std::size_t i = 0; i < drive.frames.size(); i += 3) detector.add(frameScan(drive, drive.frames[i]));
    const std::size_t query = detector.add(llc::rotateScan(frameScan(drive, drive.frames[1]), 2.0));
    auto offering = [](llc::Pose2 pose) -> llc::NearbyKeyframes {
      return [pose](std::size_t, std::size_t, double, double, std::size_t) {
        return std::vector<llc::NearbyKeyframe>{{0, true, pose}};
      };
    };
    // Where the map puts it right (0.3 m and 0.05 rad off): ICP fits, the pair is searched
    // as any candidate and the loop found.
    const llc::LoopDetectionResult right = detector.detect(query, {}, offering(llc::compose(truth, llc::Pose2{0.3, 0.0, 0.05})));
    ASSERT_EQ(right.aligned.size(), 1u);
    EXPECT_TRUE(right.aligned.front().accepted) << right.aligned.front().reject_reason;
    // Where it fits nothing (turned half round, 6 m off): refused by the cheap ICP alone,
    // unless the prefilter is off (then the search with no guess finds the truth).
    const llc::LoopDetectionResult wrong = detector.detect(query, {}, offering(llc::compose(truth, llc::Pose2{6.0, 0.0, 3.0})));
    ASSERT_EQ(wrong.aligned.size(), 1u);
    EXPECT_EQ(wrong.nearby, 1u);
    const llc::LoopClosure& loop = wrong.aligned.front();
    if (min_fit > 0.0) {
      EXPECT_FALSE(loop.accepted);
      EXPECT_NE(loop.reject_reason.find("nearby_min_predicted_fit"), std::string::npos) << loop.reject_reason;
      EXPECT_EQ(loop.refusal, llc::LoopRefusal::kValidation);
    } else {
      ASSERT_TRUE(loop.accepted) << loop.reject_reason;
      const llc::Pose2 error = llc::between(truth, loop.pose);
      EXPECT_LT(std::hypot(error.x, error.y), 0.1);
    }
  }
  llc::LoopDetectorOptions bad;
  for (const double value : {-0.1, 1.5, std::nan("")}) {
    bad.nearby_min_predicted_fit = value;
    EXPECT_NE(bad.validate().find("nearby_min_predicted_fit"), std::string::npos) << value;
  }
}

TEST(NearbyCandidates, AreNotAskedForOnceTheClassifiersGaveALoopAndNeverAlignedTwice) {
  const llc::SimDrive drive = simulatedDrive(80.0);
  llc::LoopDetectorOptions options;
  options.min_keyframe_gap = 5;
  llc::LoopDetector detector(defaultModel(), llc::ScanAlignerOptions{}, options);
  for (std::size_t i = 0; i < drive.frames.size(); i += 3) detector.add(frameScan(drive, drive.frames[i]));
  const std::size_t query = detector.add(llc::rotateScan(frameScan(drive, drive.frames[0]), 2.0));
  RecordingSource map;
  map.offered = {0};
  const llc::LoopDetectionResult found = detector.detect(query, {}, map.source());
  ASSERT_FALSE(found.aligned.empty());
  ASSERT_TRUE(found.aligned.back().accepted) << "the classifier finds this place (LoopDetector tests)";
  EXPECT_EQ(map.calls, 0u);
  EXPECT_EQ(found.nearby, 0u);

  // Every candidate refused by the check: the source is asked, and a keyframe it offers that
  // the check has already refused is not asked about (nor aligned) again.
  std::vector<std::size_t> asked;
  const auto refuse_all = [&](std::size_t from, std::size_t) {
    asked.push_back(from);
    return llc::LoopVerdict{llc::LoopRefusal::kPlaceGate, "not here"};
  };
  const llc::LoopDetectionResult refused = detector.detect(query, refuse_all, {});
  ASSERT_FALSE(refused.not_aligned.empty());
  map.offered.clear();
  for (const llc::LoopClosure& loop : refused.not_aligned) map.offered.push_back(loop.from);
  asked.clear();
  const llc::LoopDetectionResult again = detector.detect(query, refuse_all, map.source());
  EXPECT_EQ(map.calls, 1u);
  EXPECT_TRUE(again.aligned.empty());
  EXPECT_EQ(again.not_aligned.size(), refused.not_aligned.size());
  EXPECT_EQ(std::set<std::size_t>(asked.begin(), asked.end()).size(), asked.size()) << "a keyframe checked twice";
}

TEST(NearbyCandidates, OptionsAreValidated) {
  llc::LoopDetectorOptions options;
  EXPECT_EQ(options.validate(), "");
  options.nearby_distance = 0.0;
  EXPECT_NE(options.validate().find("nearby_distance"), std::string::npos);
  options = {};
  options.nearby_max_std = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(options.validate().find("nearby_max_std"), std::string::npos);
  options = {};
  options.nearby_candidates = 0;  // off is allowed
  EXPECT_EQ(options.validate(), "");
}

TEST(NearbyCandidates, TheBackEndOffersTheNearestOlderKeyframesWhoseRelativePositionItKnows) {
  // Out along x in 1 m steps (keyframes 0..5 at x = 0..5), then back (6..9 at x = 4..1);
  // each step adds 0.01 m of standard deviation per axis and almost none in heading, so the
  // relative position of keyframes n steps apart is known to 0.01 sqrt(n) m.
  llc::SlamBackEnd back;
  const Eigen::Matrix3d step = Eigen::Vector3d(1e-4, 1e-4, 1e-12).asDiagonal();
  back.addKeyframe(llc::Keyframe{}, llc::Pose2{}, step);
  for (int k = 1; k <= 5; ++k) back.addKeyframe(llc::Keyframe{}, llc::Pose2{1.0, 0.0, 0.0}, step);
  for (int k = 6; k <= 9; ++k) back.addKeyframe(llc::Keyframe{}, llc::Pose2{-1.0, 0.0, 0.0}, step);
  ASSERT_NEAR(back.poses()[9].x, 1.0, 1e-9);
  const double any = 1e3;
  // Older than 5: keyframe 1 (0 m), then 0 and 2 (1 m, the older first), then 3 (2 m).
  auto indices = [&](std::size_t index, std::size_t before, double distance, double std, std::size_t count) {
    std::vector<std::size_t> found;
    for (const llc::NearbyKeyframe& near : back.nearbyKeyframes(index, before, distance, std, count)) {
      EXPECT_TRUE(near.has_pose);
      // Keyframe 9 (x = 1) in the frame of keyframe k (x = k for k <= 5).
      EXPECT_NEAR(near.pose.x, 1.0 - double(near.keyframe), 1e-6) << near.keyframe;
      EXPECT_NEAR(near.pose.y, 0.0, 1e-6);
      found.push_back(near.keyframe);
    }
    return found;
  };
  EXPECT_EQ(indices(9, 5, 10.0, any, 4), (std::vector<std::size_t>{1, 0, 2, 3}));
  EXPECT_EQ(indices(9, 5, 10.0, any, 1), (std::vector<std::size_t>{1}));
  EXPECT_EQ(indices(9, 5, 1.5, any, 10), (std::vector<std::size_t>{1, 0, 2}));
  EXPECT_EQ(indices(9, 1, 10.0, any, 10), (std::vector<std::size_t>{0}));
  EXPECT_TRUE(indices(9, 0, 10.0, any, 10).empty());
  // Keyframe 3 is 6 steps from 9 (0.0245 m), 4 is 5 (0.0224 m), 1 is 8 (0.028 m).
  EXPECT_EQ(indices(9, 5, 10.0, 0.0255, 10), (std::vector<std::size_t>{3, 4}));
  EXPECT_TRUE(back.nearbyKeyframes(9, 5, 10.0, 0.02, 10).empty());
  EXPECT_THROW(back.nearbyKeyframes(10, 5, 10.0, any, 1), std::out_of_range);
  EXPECT_THROW(llc::SlamBackEnd().nearbyKeyframes(0, 0, 10.0, any, 1), std::out_of_range);
}

TEST(NearbyCandidates, CloseMoreRevisitsOfASimulatedDriveAndNoneWrongly) {
  const llc::SimDrive drive = simulatedDrive(500.0);
  struct Run {
    llc::SlamCounters counters;
    llc::LoopTruthCheck loops;
    std::size_t nearby_aligned = 0;  ///< summed over the steps' detection results
  };
  auto run = [&](std::size_t nearby_candidates) {
    llc::SlamOptions options;
    options.loops.nearby_candidates = nearby_candidates;
    llc::SlamPipeline slam(defaultModel(), options);
    std::vector<llc::Pose2> truth;
    Run r;
    for (std::size_t i = 0; i < drive.frames.size(); ++i) {
      const llc::SlamStepResult step = slam.addScan(frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
      r.nearby_aligned += step.loops.nearby;
      if (step.keyframe) truth.push_back(drive.frames[i].truth);
    }
    r.counters = slam.counters();
    r.loops = llc::checkLoopsAgainstTruth(truth, std::vector<bool>(truth.size(), true), slam.loops());
    return r;
  };
  const Run off = run(0), on = run(2);
  ASSERT_GT(off.loops.closed, 5u) << "the drive must close loops";
  EXPECT_EQ(off.counters.nearby_aligned, 0u);
  EXPECT_GT(on.counters.nearby_aligned, 0u);
  EXPECT_EQ(on.counters.nearby_aligned, on.nearby_aligned);
  EXPECT_GT(on.counters.nearby_found, 0u);
  EXPECT_LE(on.counters.nearby_found, on.counters.nearby_aligned);
  EXPECT_GE(on.loops.closed, off.loops.closed);
  EXPECT_EQ(on.loops.wrong_loops, 0u);
  std::cout << "revisit keyframes closed " << on.loops.closed << " (classifier alone " << off.loops.closed << "), nearby aligned "
            << on.counters.nearby_aligned << ", found " << on.counters.nearby_found << "\n";
}
