// The context check of a loop: in a corridor whose doors repeat every 3 m, one scan fits a
// door further along as well as its own place; the scans around it, which reach a side
// corridor, do not. Hand-built point sets, no ray casting: what is asserted is which pose the
// context prefers and that a loop is refused only then.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "laser_loop_closure/core/alignment/context_check.hpp"

namespace {

using llc::ContextCheckOptions;
using llc::ContextScan;
using llc::Point2;
using llc::Points2;
using llc::Pose2;

/// A corridor along x, walls at y = ±1, a door recess 0.3 m deep and 1 m wide every 3 m, and
/// one side corridor 4 m wide at x in [4, 8] going off to y = 5: points every 2 cm.
Points2 corridorWorld() {
  Points2 world;
  auto line = [&](Point2 a, Point2 b) {
    const int steps = int(std::ceil((b - a).norm() / 0.02));
    for (int i = 0; i <= steps; ++i) world.push_back(a + (b - a) * (double(i) / steps));
  };
  for (const double side : {-1.0, 1.0}) {
    double x = -40.0;
    for (int door = -13; door <= 13; ++door) {
      const double start = 3.0 * door + 1.0, end = start + 1.0;  // the recess [start, end]
      const bool side_corridor = side > 0.0 && end > 4.0 && start < 8.0;
      if (side_corridor) continue;
      if (side > 0.0 && x < 4.0 && start > 4.0) {  // the wall up to the side corridor, and past it
        line({x, side}, {4.0, side});
        x = 8.0;
      }
      line({x, side}, {start, side});
      line({start, side}, {start, side * 1.3});
      line({start, side * 1.3}, {end, side * 1.3});
      line({end, side * 1.3}, {end, side});
      x = end;
    }
    line({x, side}, {40.0, side});
  }
  line({4.0, 1.0}, {4.0, 5.0});
  line({8.0, 1.0}, {8.0, 5.0});
  line({4.0, 5.0}, {8.0, 5.0});
  return world;
}

/// What a scanner at (x, 0) "sees": the world's points within 10 m, in its own frame.
Points2 scanAt(const Points2& world, double x) {
  Points2 points;
  for (const Point2& p : world)
    if ((p - Point2(x, 0.0)).norm() < 10.0) points.push_back(p - Point2(x, 0.0));
  return points;
}

struct Contexts {
  std::vector<Points2> scans;  // owns the points the ContextScans point to
  std::vector<ContextScan> old_context, new_context;
};

/// The old keyframe at x = 0 with scans every metre for 8 m each way; the new keyframe, also
/// at x = 0 (a true revisit), with the 8 m it drove before it.
Contexts contextsAtTheOrigin() {
  const Points2 world = corridorWorld();
  Contexts c;
  c.scans.reserve(30);
  for (int x = -8; x <= 8; ++x) {
    c.scans.push_back(scanAt(world, x));
    c.old_context.push_back({&c.scans.back(), Pose2{double(x), 0.0, 0.0}});
  }
  for (int x = 0; x >= -8; --x) {
    c.scans.push_back(scanAt(world, x));
    c.new_context.push_back({&c.scans.back(), Pose2{double(x), 0.0, 0.0}});
  }
  return c;
}

Eigen::Matrix3d alongTheCorridor() { return Eigen::Vector3d(1.0, 1e-4, 1e-5).asDiagonal(); }

TEST(ContextCheck, ALookAlikeDoorFurtherAlongIsRefusedAndTheTruePlaceAccepted) {
  const Contexts c = contextsAtTheOrigin();
  // The single scans alone cannot tell: the one at x = 0 fits the one at x = 3 except where
  // the side corridor shows (the old scan sees it from 4 m, the shifted one from 1 m).
  const ContextCheckOptions options;
  const llc::IcpOptions icp;
  const llc::ContextCheckResult wrong =
      llc::checkLoopContext(c.old_context, c.new_context, Pose2{3.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  ASSERT_TRUE(wrong.checked);
  EXPECT_FALSE(wrong.accepted);
  EXPECT_EQ(wrong.reject_reason.rfind("context: ", 0), 0u) << wrong.reject_reason;
  // The context fits best at the truth, found from the restarts along the corridor.
  EXPECT_NEAR(wrong.alternative.x, 0.0, 0.05);
  EXPECT_NEAR(wrong.alternative.y, 0.0, 0.05);
  EXPECT_GT(wrong.alternative_fit, 0.9);
  EXPECT_GE(wrong.alternative_fit, wrong.fit + options.max_alternative_gain);

  const llc::ContextCheckResult right =
      llc::checkLoopContext(c.old_context, c.new_context, Pose2{0.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  ASSERT_TRUE(right.checked);
  EXPECT_TRUE(right.accepted) << right.reject_reason;
  EXPECT_GT(right.fit, 0.9);
  EXPECT_LT(right.alternative_fit, right.fit);
  EXPECT_EQ(right.old_scans, 17u);
  EXPECT_EQ(right.new_scans, 9u);
}

TEST(ContextCheck, OneThreadOrTwoGiveTheSameResult) {
  const Contexts c = contextsAtTheOrigin();
  ContextCheckOptions options;
  const llc::IcpOptions icp;
  for (const Pose2& loop : {Pose2{3.0, 0.0, 0.0}, Pose2{0.1, 0.05, 0.01}, Pose2{-2.5, 0.1, 0.0}}) {
    options.parallel = true;
    const llc::ContextCheckResult two = llc::checkLoopContext(c.old_context, c.new_context, loop, alongTheCorridor(), options, icp);
    options.parallel = false;
    const llc::ContextCheckResult one = llc::checkLoopContext(c.old_context, c.new_context, loop, alongTheCorridor(), options, icp);
    EXPECT_EQ(two.accepted, one.accepted);
    EXPECT_EQ(two.fit, one.fit);
    EXPECT_EQ(two.alternative_fit, one.alternative_fit);
    EXPECT_EQ(two.alternative.x, one.alternative.x);
    EXPECT_EQ(two.reject_reason, one.reject_reason);
  }
}

TEST(ContextCheck, ANegativeGainRefusesALoopThatAnotherPoseFitsAlmostAsWell) {
  const Contexts c = contextsAtTheOrigin();
  ContextCheckOptions options;
  const llc::IcpOptions icp;
  const llc::ContextCheckResult at_truth =
      llc::checkLoopContext(c.old_context, c.new_context, Pose2{0.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  ASSERT_TRUE(at_truth.checked);
  ASSERT_GT(at_truth.alternative_fit, 0.0);  // some restart ended elsewhere along the corridor
  const double margin = at_truth.fit - at_truth.alternative_fit;  // how much better the truth fits
  ASSERT_GT(margin, 0.0);
  options.max_alternative_gain = -(margin - 0.01);  // asks for less than the truth's lead: accepted
  EXPECT_TRUE(llc::checkLoopContext(c.old_context, c.new_context, Pose2{0.0, 0.0, 0.0}, alongTheCorridor(), options, icp)
                  .accepted);
  options.max_alternative_gain = -(margin + 0.01);  // asks for more: refused as ambiguous
  const llc::ContextCheckResult refused =
      llc::checkLoopContext(c.old_context, c.new_context, Pose2{0.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  EXPECT_FALSE(refused.accepted);
  EXPECT_NE(refused.reject_reason.find("context: fits"), std::string::npos) << refused.reject_reason;
}

TEST(ContextCheck, TheGainLimitDecides) {
  const Contexts c = contextsAtTheOrigin();
  ContextCheckOptions options;
  const llc::IcpOptions icp;
  const llc::ContextCheckResult measured =
      llc::checkLoopContext(c.old_context, c.new_context, Pose2{3.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  ASSERT_TRUE(measured.checked);
  const double gain = measured.alternative_fit - measured.fit;
  ASSERT_GT(gain, 0.0);
  options.max_alternative_gain = gain + 0.01;  // just more than the context shows: accepted
  EXPECT_TRUE(llc::checkLoopContext(c.old_context, c.new_context, Pose2{3.0, 0.0, 0.0}, alongTheCorridor(), options, icp)
                  .accepted);
  options.max_alternative_gain = gain - 0.01;
  EXPECT_FALSE(llc::checkLoopContext(c.old_context, c.new_context, Pose2{3.0, 0.0, 0.0}, alongTheCorridor(), options, icp)
                   .accepted);
}

TEST(ContextCheck, TooSmallOrEmptyContextsAreAcceptedUnchecked) {
  const Contexts c = contextsAtTheOrigin();
  const ContextCheckOptions options;  // min_scans 3
  const llc::IcpOptions icp;
  const std::vector<ContextScan> two(c.new_context.begin(), c.new_context.begin() + 2);
  llc::ContextCheckResult result =
      llc::checkLoopContext(c.old_context, two, Pose2{3.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  EXPECT_FALSE(result.checked);
  EXPECT_TRUE(result.accepted);
  // Scans without points, or with points that are not finite, are no context either.
  const Points2 none, broken(50, Point2(std::nan(""), 1.0));
  const std::vector<ContextScan> empty{{&none, Pose2{}}, {&broken, Pose2{}}, {nullptr, Pose2{}}};
  result = llc::checkLoopContext(empty, c.new_context, Pose2{3.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  EXPECT_FALSE(result.checked);
  EXPECT_TRUE(result.accepted);
  EXPECT_TRUE(llc::contextCloud(empty, 0.05).empty());
}

TEST(ContextCheck, CloudsAreThinnedToOnePointPerCell) {
  const Points2 points{{0.01, 0.01}, {0.02, 0.03}, {0.06, 0.01}, {-0.01, 0.01}};
  const std::vector<ContextScan> twice{{&points, Pose2{}}, {&points, Pose2{}}};
  EXPECT_EQ(llc::contextCloud(twice, 0.0).size(), 8u);
  EXPECT_EQ(llc::contextCloud(twice, 0.05).size(), 3u);  // cells (0,0), (1,0), (-1,0)
  // Placed by its pose: a scan at (1, 0) turned by 90 degrees.
  const std::vector<ContextScan> moved{{&points, Pose2{1.0, 0.0, M_PI / 2}}};
  const Points2 cloud = llc::contextCloud(moved, 0.0);
  EXPECT_NEAR(cloud[2].x(), 1.0 - 0.01, 1e-12);
  EXPECT_NEAR(cloud[2].y(), 0.06, 1e-12);
  // Normals come along, turned with their scan; one scan without them: none at all.
  const Points2 normals{{1.0, 0.0}, {0.0, 1.0}, {1.0, 0.0}, {0.0, -1.0}};
  Points2 moved_normals;
  llc::contextCloud({{&points, Pose2{1.0, 0.0, M_PI / 2}, &normals}}, 0.0, &moved_normals);
  ASSERT_EQ(moved_normals.size(), 4u);
  EXPECT_NEAR(moved_normals[0].x(), 0.0, 1e-12);
  EXPECT_NEAR(moved_normals[0].y(), 1.0, 1e-12);
  EXPECT_NEAR(moved_normals[1].x(), -1.0, 1e-12);
  llc::contextCloud({{&points, Pose2{}, &normals}, {&points, Pose2{}, nullptr}}, 0.0, &moved_normals);
  EXPECT_TRUE(moved_normals.empty());
  EXPECT_THROW(llc::IcpTarget(points, Points2(3)), std::invalid_argument);
}

TEST(ContextCheck, TheScansOwnNormalsGiveTheSameVerdictAsNormalsEstimatedOnTheMergedPoints) {
  Contexts c = contextsAtTheOrigin();
  const llc::IcpOptions icp;
  std::vector<Points2> normals;
  normals.reserve(c.old_context.size());
  for (ContextScan& scan : c.old_context) {
    normals.push_back(llc::IcpTarget(*scan.points, icp).normals);
    scan.normals = &normals.back();
  }
  const ContextCheckOptions options;
  const llc::ContextCheckResult wrong =
      llc::checkLoopContext(c.old_context, c.new_context, Pose2{3.0, 0.0, 0.0}, alongTheCorridor(), options, icp);
  EXPECT_FALSE(wrong.accepted);
  EXPECT_NEAR(wrong.alternative.x, 0.0, 0.05);
  EXPECT_TRUE(llc::checkLoopContext(c.old_context, c.new_context, Pose2{}, alongTheCorridor(), options, icp).accepted);
}

TEST(ContextCheck, FitCountsTheShareOfPointsNearTheOtherCloud) {
  const llc::KdTree2 target(Points2{{0.0, 0.0}, {1.0, 0.0}});
  const Points2 source{{0.0, 0.05}, {1.0, 0.2}, {5.0, 5.0}, {1.05, 0.0}};
  ContextCheckOptions options;  // fit_distance 0.1
  EXPECT_DOUBLE_EQ(llc::contextFit(source, target, Pose2{}, options), 0.5);
  EXPECT_DOUBLE_EQ(llc::contextFit(source, target, Pose2{0.0, -0.2, 0.0}, options), 0.25);  // only (1, 0.2) lands
  EXPECT_DOUBLE_EQ(llc::contextFit({}, target, Pose2{}, options), 0.0);
}

TEST(ContextCheck, OptionsAreValidated) {
  EXPECT_EQ(ContextCheckOptions{}.validate(), "");
  auto refused = [](auto change, const std::string& needle) {
    ContextCheckOptions options;
    change(options);
    EXPECT_NE(options.validate().find(needle), std::string::npos) << options.validate();
  };
  refused([](ContextCheckOptions& o) { o.distance = 0.0; }, "distance");
  refused([](ContextCheckOptions& o) { o.spacing = std::nan(""); }, "spacing");
  refused([](ContextCheckOptions& o) { o.min_scans = 0; }, "min_scans");
  refused([](ContextCheckOptions& o) { o.search_shift = -1.0; }, "search_shift");
  refused([](ContextCheckOptions& o) { o.search_restarts = 0; }, "search_restarts");
  refused([](ContextCheckOptions& o) { o.fit_distance = std::numeric_limits<double>::infinity(); }, "fit_distance");
  refused([](ContextCheckOptions& o) { o.max_alternative_gain = 1.5; }, "max_alternative_gain");
  refused([](ContextCheckOptions& o) { o.max_alternative_gain = -1.5; }, "max_alternative_gain");
  refused([](ContextCheckOptions& o) { o.alternative_distance = 0.0; }, "alternative_distance");
  refused([](ContextCheckOptions& o) { o.max_points = 3; }, "max_points");
  refused([](ContextCheckOptions& o) { o.cell = -0.1; }, "cell");
}

}  // namespace
