// The context check wired into the front end: every shape-validated loop of a drive is
// checked against the keyframes its own odometry chain puts around it, what the detector asks
// its KeyframeContext source, and a refusal named as its own stage.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <vector>

#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/slam/slam_evaluation.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "../test_util.hpp"

namespace {

using llc_test::defaultModel;
using llc_test::frameScan;
using llc_test::simulatedDrive;

TEST(LoopContext, EveryShapeValidatedLoopOfADriveIsCheckedAndNoneOfItsTrueLoopsIsLost) {
  const llc::SimDrive drive = simulatedDrive(500.0);
  struct Run {
    llc::SlamCounters counters;
    llc::LoopTruthCheck loops;
    std::size_t validated = 0;  ///< loops the aligner accepted before the context check, summed over the steps
  };
  auto run = [&](bool context) {
    llc::SlamOptions options;
    options.loops.context.enabled = context;
    llc::SlamPipeline slam(defaultModel(), options);
    std::vector<llc::Pose2> truth;
    Run r;
    for (std::size_t i = 0; i < drive.frames.size(); ++i) {
      const llc::SlamStepResult step = slam.addScan(frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
      for (const llc::LoopClosure& loop : step.loops.aligned)
        r.validated += loop.accepted || loop.refusal == llc::LoopRefusal::kContext;
      if (step.keyframe) truth.push_back(drive.frames[i].truth);
    }
    r.counters = slam.counters();
    r.loops = llc::checkLoopsAgainstTruth(truth, std::vector<bool>(truth.size(), true), slam.loops());
    return r;
  };
  const Run off = run(false), on = run(true);
  ASSERT_GT(off.loops.closed, 5u) << "the drive must close loops";
  EXPECT_EQ(off.counters.context_checked + off.counters.context_unchecked, 0u);
  // One chain from the start: every validated loop has a context of keyframes to check.
  EXPECT_EQ(on.counters.context_checked, on.validated);
  EXPECT_EQ(on.counters.context_unchecked, 0u);
  EXPECT_LE(on.counters.refused_by_context, on.counters.context_checked);
  EXPECT_GT(on.counters.seconds_context, 0.0);
  // The city's streets are not a corridor of look-alike doors: nothing true is refused.
  EXPECT_EQ(on.loops.wrong_loops, 0u);
  EXPECT_GE(on.loops.closed + 1, off.loops.closed);
  std::cout << "revisit keyframes closed " << on.loops.closed << " (unchecked " << off.loops.closed << "), checked "
            << on.counters.context_checked << ", refused " << on.counters.refused_by_context << "\n";
}

TEST(LoopContext, TheDetectorAsksForBothKeyframesContextsAndNothingNewerThanTheGapAllows) {
  const llc::SimDrive drive = simulatedDrive(500.0);
  llc::SlamPipeline slam(defaultModel());
  // Drive until the first loop is found, then ask the detector again with a recording source.
  std::size_t keyframe = 0;
  bool found = false;
  for (std::size_t i = 0; i < drive.frames.size() && !found; ++i) {
    const llc::SlamStepResult step = slam.addScan(frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
    for (const llc::LoopClosure& loop : step.loops.aligned) found = found || loop.accepted;
    keyframe = step.keyframe_index;
  }
  ASSERT_TRUE(found);
  const llc::LoopDetector& detector = slam.detector();
  struct Asked {
    std::size_t index, before;
    double distance, spacing;
  };
  std::vector<Asked> asked;
  const llc::KeyframeContext recording = [&](std::size_t index, std::size_t before, double distance, double spacing) {
    asked.push_back({index, before, distance, spacing});
    return std::vector<llc::ContextKeyframe>{{index, llc::Pose2{}}};  // too small: accepted unchecked
  };
  const llc::LoopDetectionResult result = detector.detect(keyframe, {}, {}, recording);
  ASSERT_FALSE(result.aligned.empty());
  const std::size_t validated = std::size_t(std::count_if(result.aligned.begin(), result.aligned.end(),
                                                          [](const llc::LoopClosure& l) { return l.accepted; }));
  ASSERT_GT(validated, 0u);
  EXPECT_EQ(result.context_unchecked, validated);
  EXPECT_EQ(result.context_checked, 0u);
  ASSERT_EQ(asked.size(), 2 * validated);
  const llc::ContextCheckOptions options;
  for (std::size_t k = 0; k < asked.size(); k += 2) {
    EXPECT_LT(asked[k].index, result.compared);  // the old keyframe, its context older than the gap
    EXPECT_EQ(asked[k].before, result.compared);
    EXPECT_EQ(asked[k + 1].index, keyframe);     // the new one, nothing newer than itself
    EXPECT_EQ(asked[k + 1].before, keyframe + 1);
    EXPECT_EQ(asked[k].distance, options.distance);
    EXPECT_EQ(asked[k].spacing, options.spacing);
  }
}

}  // namespace
