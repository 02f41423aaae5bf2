// Alignment with no initial guess: rigid fits, k-d tree, ICP, CRF-match, shape validation and
// the whole ScanAligner, on scans ray-cast in a small synthetic room.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <functional>
#include <limits>

#include "laser_loop_closure/core/alignment/crf_training.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "../synthetic_room.hpp"
#include "../test_util.hpp"

namespace {

using llc::Point2;
using llc::Points2;
using llc::Pose2;

using llc_test::corridor;
using llc_test::room;
using llc_test::scanAt;

void expectPoseNear(const Pose2& actual, const Pose2& expected, double metres, double radians) {
  EXPECT_NEAR(actual.x, expected.x, metres);
  EXPECT_NEAR(actual.y, expected.y, metres);
  EXPECT_NEAR(llc::normalizeAngle(actual.theta - expected.theta), 0.0, radians);
}

TEST(RigidFit, RecoversAnExactTransformAndRefusesDegenerateInput) {
  const Pose2 truth{1.5, -0.7, 2.4};
  std::vector<llc::Correspondence2> cs;
  for (int i = 0; i < 5; ++i) {
    const Point2 s(i * 0.7 - 1.0, std::sin(i));
    cs.push_back({s, llc::transformPoint(truth, s), 1.0 + i});
  }
  Pose2 fitted;
  ASSERT_TRUE(llc::fitRigid(cs, &fitted));
  expectPoseNear(fitted, truth, 1e-12, 1e-12);
  // All source points at one place: rotation undetermined. No weight: nothing to fit.
  std::vector<llc::Correspondence2> same(3, llc::Correspondence2{Point2(1, 1), Point2(2, 2), 1.0});
  EXPECT_FALSE(llc::fitRigid(same, &fitted));
  for (auto& c : cs) c.weight = 0.0;
  EXPECT_FALSE(llc::fitRigid(cs, &fitted));
  EXPECT_FALSE(llc::fitRigid({}, &fitted));
}

TEST(RigidFit, RobustFitIgnoresThirtyPercentOutliers) {
  const Pose2 truth{-2.0, 0.5, -1.1};
  llc::Random random(7);
  std::vector<llc::Correspondence2> cs;
  for (int i = 0; i < 70; ++i) {
    const Point2 s(random.uniform(-5, 5), random.uniform(-5, 5));
    cs.push_back({s, llc::transformPoint(truth, s), 1.0});
  }
  for (int i = 0; i < 30; ++i)
    cs.push_back({Point2(random.uniform(-5, 5), random.uniform(-5, 5)),
                  Point2(random.uniform(-5, 5), random.uniform(-5, 5)), 1.0});
  const llc::RobustFitResult fit = llc::fitRigidRobust(cs, llc::RobustFitOptions{});
  ASSERT_TRUE(fit.ok);
  expectPoseNear(fit.pose, truth, 1e-9, 1e-9);
  EXPECT_GE(fit.inlier_count, 70u);
  for (int i = 0; i < 70; ++i) EXPECT_TRUE(fit.inlier[std::size_t(i)]);
}

TEST(KdTree, NearestMatchesBruteForce) {
  llc::Random random(3);
  Points2 points;
  for (int i = 0; i < 500; ++i) points.emplace_back(random.uniform(-10, 10), random.uniform(-10, 10));
  const llc::KdTree2 tree(points);
  for (int q = 0; q < 200; ++q) {
    const Point2 query(random.uniform(-12, 12), random.uniform(-12, 12));
    double best = std::numeric_limits<double>::infinity();
    for (const Point2& p : points) best = std::min(best, (p - query).squaredNorm());
    std::size_t index;
    double distance;
    ASSERT_TRUE(tree.nearest(query, &index, &distance));
    EXPECT_DOUBLE_EQ(distance, best);
    EXPECT_DOUBLE_EQ((points[index] - query).squaredNorm(), best);
    // With a bound: the same point when it lies within (the bound is inclusive), else none.
    std::size_t bounded_index = 99999;
    double bounded = -1.0;
    EXPECT_TRUE(tree.nearest(query, &bounded_index, &bounded, best));
    EXPECT_EQ(bounded_index, index);
    EXPECT_FALSE(tree.nearest(query, &bounded_index, &bounded, 0.999 * best));
  }
  const llc::KdTree2 empty(Points2{});
  std::size_t index;
  double distance;
  EXPECT_FALSE(empty.nearest(Point2(0, 0), &index, &distance));
}

TEST(Normals, OfAWallArePerpendicularToIt) {
  Points2 wall;
  for (int i = 0; i < 20; ++i) wall.emplace_back(0.1 * i, 2.0 + 0.1 * i);  // along (1, 1)
  const Points2 normals = llc::estimateNormals(llc::KdTree2(wall), 6, 0.6);
  for (const Point2& n : normals) {
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    EXPECT_NEAR(n.dot(Point2(1, 1).normalized()), 0.0, 1e-9);
  }
}

TEST(ShapeValidation, CountsNearestNeighbourPairsWithinD) {
  Points2 target, source;
  for (int i = 0; i < 10; ++i) target.emplace_back(double(i), 0.0);
  // Nine source points 0.5 m from the line of targets, one 3 m away: share 0.9.
  for (int i = 0; i < 9; ++i) source.emplace_back(double(i), 0.5);
  source.emplace_back(20.0, 3.0);
  const llc::KdTree2 tree(target);
  llc::ShapeValidationOptions options;  // d = 1 m, N = 90%
  llc::ShapeValidationResult r = llc::validateShape(source, tree, Pose2{}, options);
  EXPECT_EQ(r.points, 10u);
  EXPECT_DOUBLE_EQ(r.inlier_share, 0.9);
  EXPECT_TRUE(r.accepted);
  // Moved 0.6 m further up, every pair is 1.1 m long: nothing within d.
  r = llc::validateShape(source, tree, Pose2{0.0, 0.6, 0.0}, options);
  EXPECT_DOUBLE_EQ(r.inlier_share, 0.0);
  EXPECT_FALSE(r.accepted);
  EXPECT_NE(r.reject_reason.find("below"), std::string::npos);
  r = llc::validateShape({}, tree, Pose2{}, options);
  EXPECT_FALSE(r.accepted);
}

TEST(ShapeValidation, CountsOnlyPointsTheOtherScannerCouldSee) {
  // Target: a wall 2 m ahead seen by a forward 180-degree scanner. Source: the same wall plus
  // four points behind the target scanner, which it could never have seen.
  Points2 target, source;
  for (int i = -10; i <= 10; ++i) target.emplace_back(2.0, 0.2 * i), source.emplace_back(2.0, 0.2 * i + 0.1);
  for (int i = 0; i < 4; ++i) source.emplace_back(-3.0, double(i));
  const llc::KdTree2 tree(target);
  const llc::FieldOfView view = llc::FieldOfView::arc(-M_PI / 2, M_PI / 2, 40.0);
  llc::ShapeValidationOptions options;
  llc::ShapeValidationResult r = llc::validateShape(source, tree, Pose2{}, options, &view);
  EXPECT_EQ(r.points, 21u);
  EXPECT_DOUBLE_EQ(r.inlier_share, 1.0);
  options.only_in_view = false;  // the paper's way: every point counts
  r = llc::validateShape(source, tree, Pose2{}, options, &view);
  EXPECT_EQ(r.points, 25u);
  EXPECT_DOUBLE_EQ(r.inlier_share, 21.0 / 25.0);
  EXPECT_FALSE(r.accepted);
  // Nothing in view: refused with a reason.
  options.only_in_view = true;
  r = llc::validateShape(source, tree, Pose2{-10.0, 0.0, M_PI}, options, &view);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.reject_reason, "no point in the other scan's view");
  // The view of a scan: its bearing span, or everything for a full circle.
  const llc::FieldOfView half = llc::fieldOfView(llc_test::ringScan(std::vector<double>(8, 1.0)), 30.0);
  EXPECT_TRUE(half.fullCircle());
  EXPECT_TRUE(half.contains(Point2(-5, 0)));
  EXPECT_FALSE(half.contains(Point2(31, 0)));
  llc::Scan front;
  for (int i = 0; i <= 180; ++i) front.bearings.push_back((i - 90) * M_PI / 180), front.ranges.push_back(1.0);
  const llc::FieldOfView f = llc::fieldOfView(front, 30.0);
  EXPECT_FALSE(f.fullCircle());
  EXPECT_TRUE(f.contains(Point2(1, 0.5)));
  EXPECT_FALSE(f.contains(Point2(-1, 0.5)));
  EXPECT_NEAR(f.width(), M_PI, 1e-12);  // what a turn on the spot can add to it: TrajectoryJoin
  EXPECT_NEAR(half.width(), 2 * M_PI, 1e-12);
}

TEST(ShapeValidation, SeenThroughShareByHand) {
  // Target: five beams around straight ahead, all returning from 5 m; a sixth with no return.
  llc::Scan target;
  for (int i = -2; i <= 2; ++i) target.bearings.push_back(0.1 * i), target.ranges.push_back(5.0);
  target.bearings.push_back(0.35), target.ranges.push_back(std::numeric_limits<double>::infinity());
  const llc::FreeSpace space = llc::freeSpace(target, 40.0);
  ASSERT_EQ(space.bearings.size(), 6u);
  EXPECT_TRUE(std::isnan(space.ranges[5]));
  // Moved 1 m ahead by the pose: (1, 0) lands 2 m out where the target saw to 5 m (seen
  // through); (3.8, 0) lands 4.8 m out (within the margin); (9, 0) behind the wall; (0, 5)
  // outside the beams; (2, 0.4) at bearing ~0.13, bracketed by beams 0.1 and 0.2 and flanked by
  // 0 and the no-return beam: 3.04 m out, seen through.
  const Points2 source{{1.0, 0.0}, {3.8, 0.0}, {9.0, 0.0}, {0.0, 5.0}, {2.0, 0.4}};
  std::size_t tested = 0;
  EXPECT_DOUBLE_EQ(llc::seenThroughShare(source, Pose2{1.0, 0.0, 0.0}, space, 0.5, &tested), 2.0 / 4.0);
  EXPECT_EQ(tested, 4u);
  // A wider margin than the gap: only the first (3 m short of the wall) stays seen through.
  EXPECT_DOUBLE_EQ(llc::seenThroughShare(source, Pose2{1.0, 0.0, 0.0}, space, 2.5, &tested), 1.0 / 4.0);
  // Nothing to test: 0, and no target beams: 0.
  EXPECT_EQ(llc::seenThroughShare({}, Pose2{}, space, 0.5, &tested), 0.0);
  EXPECT_EQ(tested, 0u);
  EXPECT_EQ(llc::seenThroughShare(source, Pose2{}, llc::FreeSpace{}, 0.5), 0.0);
  // A full circle wraps round: a point just short of +pi is bracketed by the last and first beams.
  const llc::FreeSpace ring = llc::freeSpace(llc_test::ringScan(std::vector<double>(8, 3.0)), 40.0);
  EXPECT_DOUBLE_EQ(llc::seenThroughShare({{-1.0, 0.01}}, Pose2{}, ring, 0.5, &tested), 1.0);
  EXPECT_EQ(tested, 1u);
  llc::ShapeValidationOptions bad;
  bad.max_seen_through_share = 1.5;
  EXPECT_FALSE(bad.validate().empty());
  bad = {};
  bad.free_space_margin = -1.0;
  EXPECT_FALSE(bad.validate().empty());
}

TEST(Icp, ConvergesToTheTruthFromANearbyStartWithACovariance) {
  const Pose2 a{0.3, -0.2, 0.1}, b{1.4, 0.6, 0.5};
  const Pose2 truth = llc::between(a, b);
  const llc::IcpOptions options;
  const llc::IcpTarget target(llc::scanPoints(scanAt(room(), a), 40.0), options);
  const Points2 source = llc::scanPoints(scanAt(room(), b), 40.0);
  const Pose2 start{truth.x + 0.3, truth.y - 0.2, truth.theta + 0.15};
  const llc::IcpResult r = llc::alignIcp(source, target, start, options);
  ASSERT_TRUE(r.converged) << r.reject_reason;
  EXPECT_TRUE(r.reject_reason.empty());
  expectPoseNear(r.pose, truth, 2e-3, 1e-3);
  EXPECT_LT(r.rms_residual, 0.01);
  EXPECT_TRUE(r.covariance.allFinite());
  EXPECT_GT(r.covariance.determinant(), 0.0);
  EXPECT_GT(r.covariance(0, 0), 0.0);
}

TEST(Icp, LeavesOutSourcePointsTheTargetCouldNotSee) {
  // Target, a forward 180-degree scanner at the origin: a wall across at x = 2 and a wall
  // along at y = -1, seen from x = 0.05 on. Source, at the same pose (the truth is the
  // identity): those walls and a ledge at y = -0.3 behind the target scanner (x < 0), which it
  // could not see. Paired with the nearest target points, the ledge's points all pull the
  // source down towards the wall at y = -1; left out, ICP stays at the truth.
  Points2 target, source;
  for (int i = 0; i <= 40; ++i) {
    const Point2 across(2.0, -2.0 + 0.1 * i), along(0.05 + 0.04875 * i, -1.0);
    target.push_back(across), target.push_back(along), source.push_back(across), source.push_back(along);
  }
  for (int i = 0; i <= 30; ++i) source.emplace_back(-0.05 - 0.04 * i, -0.3);
  const llc::IcpOptions options;
  const llc::IcpTarget icp_target(target, options);
  const llc::FieldOfView view = llc::FieldOfView::arc(-M_PI / 2, M_PI / 2, 40.0);
  const llc::IcpResult seen = llc::alignIcp(source, icp_target, Pose2{}, options, nullptr, &view);
  ASSERT_TRUE(seen.converged) << seen.reject_reason;
  expectPoseNear(seen.pose, Pose2{}, 1e-6, 1e-6);
  // Without the view the ledge moves the result (the reason for the view).
  const llc::IcpResult all = llc::alignIcp(source, icp_target, Pose2{}, options);
  EXPECT_TRUE(!all.converged || std::hypot(all.pose.x, all.pose.y) > 0.01 || std::abs(all.pose.theta) > 0.01)
      << all.pose.x << ' ' << all.pose.y << ' ' << all.pose.theta;
}

TEST(Icp, NormalGateDropsPairsAcrossACorner) {
  // Source: the same room; its normals all turned by 90 degrees claim every point lies on a
  // wall perpendicular to the real one, so with the gate no pair survives.
  const llc::IcpOptions options;
  const llc::IcpTarget target(llc::scanPoints(scanAt(room(), Pose2{}), 40.0), options);
  const Points2 source = llc::scanPoints(scanAt(room(), Pose2{0.1, 0.0, 0.0}), 40.0);
  Points2 turned = llc::estimateNormals(llc::KdTree2(source), 6, 0.6);
  const llc::IcpResult plain = llc::alignIcp(source, target, Pose2{}, options, &turned);
  for (Point2& n : turned) n = Point2(-n.y(), n.x());
  const llc::IcpResult gated = llc::alignIcp(source, target, Pose2{}, options, &turned);
  EXPECT_TRUE(plain.converged) << plain.reject_reason;
  EXPECT_FALSE(gated.converged);
  EXPECT_EQ(gated.reject_reason, "too few correspondences");
}

TEST(Icp, RefusesDegenerateAndEmptyInputWithAReason) {
  const llc::IcpOptions options;
  // A straight corridor: the position along it is unconstrained.
  const llc::IcpTarget target(llc::scanPoints(scanAt(corridor(), Pose2{}), 40.0), options);
  const Points2 source = llc::scanPoints(scanAt(corridor(), Pose2{0.5, 0.0, 0.0}), 40.0);
  llc::IcpResult r = llc::alignIcp(source, target, Pose2{}, options);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.reject_reason, "degenerate geometry");
  EXPECT_TRUE(std::isfinite(r.pose.x) && std::isfinite(r.pose.y) && std::isfinite(r.pose.theta));
  r = llc::alignIcp({}, target, Pose2{}, options);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.reject_reason, "too few points");
  r = llc::alignIcp(source, target, Pose2{std::nan(""), 0.0, 0.0}, options);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.reject_reason, "initial pose not finite");
  EXPECT_FALSE(llc::IcpOptions{}.validate().size());
  llc::IcpOptions bad;
  bad.trim_fraction = 0.0;
  EXPECT_FALSE(bad.validate().empty());
  bad = {};
  bad.max_normal_angle = 0.0;
  EXPECT_FALSE(bad.validate().empty());
  bad = {};
  bad.fixed_pairs_after = 0;
  EXPECT_FALSE(bad.validate().empty());
}

TEST(Icp, RemappingKeepsTheSeedAlongACorridorsAxisAndCorrectsTheRest) {
  // The corridor with one niche (0.2 m deep, 1 m wide) in a wall: its far end is all that
  // fixes the position along the axis (a weak direction of the Hessian, above the degeneracy
  // ratio). From a seed 0.06 m along the axis, 0.03 m across and 0.01 rad off, ICP alone finds
  // the truth; with remapping it corrects the lateral offset and the heading and keeps the
  // seed's position along the axis (where wheels know better than a niche or two).
  const std::vector<llc_test::Wall> walls = {{{-100, -1.5}, {100, -1.5}}, {{-100, 1.5}, {2.8, 1.5}},
                                             {{3.8, 1.5}, {100, 1.5}},    {{2.8, 1.5}, {2.8, 1.7}},
                                             {{2.8, 1.7}, {3.8, 1.7}},    {{3.8, 1.7}, {3.8, 1.5}}};
  const Pose2 truth{0.3, 0.0, 0.0};
  llc::IcpOptions options;
  const llc::IcpTarget target(llc::scanPoints(scanAt(walls, Pose2{}), 40.0), options);
  const Points2 source = llc::scanPoints(scanAt(walls, truth), 40.0);
  const Pose2 seed{0.36, 0.03, 0.01};
  const llc::IcpResult plain = llc::alignIcp(source, target, seed, options);
  ASSERT_TRUE(plain.converged) << plain.reject_reason;
  expectPoseNear(plain.pose, truth, 0.01, 0.002);
  options.remap_ratio = 0.01;
  const llc::IcpResult remapped = llc::alignIcp(source, target, seed, options);
  ASSERT_TRUE(remapped.converged) << remapped.reject_reason;
  EXPECT_NEAR(remapped.pose.y, truth.y, 0.005);
  EXPECT_NEAR(remapped.pose.theta, truth.theta, 0.002);
  EXPECT_NEAR(remapped.pose.x, seed.x, 0.005) << "the seed's position along the axis stays";
  // In a room every direction is well fixed: remapping changes nothing.
  const llc::IcpTarget room_target(llc::scanPoints(scanAt(room(), Pose2{}), 40.0), options);
  const Pose2 moved{0.4, -0.2, 0.1};
  const llc::IcpResult in_room =
      llc::alignIcp(llc::scanPoints(scanAt(room(), moved), 40.0), room_target, Pose2{0.5, -0.1, 0.05}, options);
  ASSERT_TRUE(in_room.converged) << in_room.reject_reason;
  expectPoseNear(in_room.pose, moved, 2e-3, 1e-3);
  llc::IcpOptions bad;
  for (const double ratio : {-0.1, 1.0, std::nan("")}) {
    bad.remap_ratio = ratio;
    EXPECT_NE(bad.validate().find("remap_ratio"), std::string::npos) << ratio;
  }
}

TEST(Icp, WithThePairsFixedFromTheFirstStepStillReachesTheTruth) {
  // The pairs found at the start are kept (moved with the pose) for every later step. Point
  // to line, a point paired with the wrong point of the right wall still pulls the right way,
  // so Gauss-Newton on those pairs settles near the truth; a wrong update of the fixed pairs
  // (not moved, or residuals left stale) would stop at the start or never converge.
  const Pose2 a{0.3, -0.2, 0.1}, b{1.4, 0.6, 0.5};
  const Pose2 truth = llc::between(a, b);
  llc::IcpOptions options;
  options.fixed_pairs_after = 1;
  const llc::IcpTarget target(llc::scanPoints(scanAt(room(), a), 40.0), options);
  const Points2 source = llc::scanPoints(scanAt(room(), b), 40.0);
  const llc::IcpResult r = llc::alignIcp(source, target, Pose2{truth.x + 0.1, truth.y - 0.05, truth.theta + 0.03}, options);
  ASSERT_TRUE(r.converged) << r.reject_reason;
  EXPECT_GT(r.iterations, 1);
  expectPoseNear(r.pose, truth, 0.02, 0.01);
}

/// The whole stage, no initial guess: rotations up to 180 degrees either way.
class AlignerRecovers : public ::testing::TestWithParam<double> {};

TEST_P(AlignerRecovers, AKnownRigidTransformOfASyntheticScan) {
  const double turn = GetParam();
  const Pose2 a{-1.0, 0.5, 0.3};
  const Pose2 b{a.x + 1.2 * std::cos(turn), a.y + 0.8 * std::sin(turn), llc::normalizeAngle(a.theta + turn)};
  const llc::ScanAligner aligner;
  const auto pa = aligner.prepare(scanAt(room(), a, 720, 0.005, 1));
  const auto pb = aligner.prepare(scanAt(room(), b, 720, 0.005, 2));
  const llc::ScanAlignmentResult r = aligner.align(*pa, *pb);
  ASSERT_TRUE(r.accepted) << r.reject_reason;
  expectPoseNear(r.pose, llc::between(a, b), 0.02, 0.005);
  EXPECT_GT(r.validation.inlier_share, 0.95);
  EXPECT_LT(r.validation.seen_through_share, 0.02);  // the same room: nothing seen through
  EXPECT_TRUE(r.covariance.allFinite());
}

INSTANTIATE_TEST_SUITE_P(Turns, AlignerRecovers,
                         ::testing::Values(0.0, 0.4, M_PI / 2, 2.5, M_PI - 1e-9, -M_PI / 2, -2.9));

TEST(Aligner, ConvergesWithThirtyPercentClutterAndPartialOverlap) {
  const Pose2 a{0.0, 0.0, 0.0}, b{1.0, -0.8, 2.2};
  llc::Scan sb = scanAt(room(), b, 720, 0.005, 4);
  // Scan b sees only 240 degrees of the room (the rest blocked), and 30% of its beams hit
  // clutter at random ranges that scan a never saw.
  llc::Random random(11);
  for (std::size_t i = 0; i < sb.size(); ++i) {
    if (sb.bearings[i] > M_PI / 3) sb.ranges[i] = std::numeric_limits<double>::infinity();
    else if (random.uniform() < 0.3) sb.ranges[i] = random.uniform(0.3, 0.9) * sb.ranges[i];
  }
  llc::ScanAlignerOptions options;
  options.validation.min_inlier_share = 0.6;  // the clutter is not in scan a ...
  options.validation.max_seen_through_share = 1.0;  // ... which saw the walls behind it
  const llc::ScanAligner aligner(options);
  const llc::ScanAlignmentResult r = aligner.align(*aligner.prepare(scanAt(room(), a)), *aligner.prepare(sb));
  ASSERT_TRUE(r.icp.converged) << r.reject_reason;
  expectPoseNear(r.pose, llc::between(a, b), 0.05, 0.01);
  EXPECT_TRUE(r.accepted) << r.reject_reason;
  EXPECT_EQ(r.refusal, llc::AlignmentRefusal::kNone);
  // With the seen-through test (the default share), that clutter contradicts the match.
  options.validation.max_seen_through_share = llc::ShapeValidationOptions{}.max_seen_through_share;
  const llc::ScanAligner strict(options);
  const llc::ScanAlignmentResult s = strict.align(*strict.prepare(scanAt(room(), a)), *strict.prepare(sb));
  expectPoseNear(s.pose, llc::between(a, b), 0.05, 0.01);
  EXPECT_FALSE(s.accepted);
  EXPECT_EQ(s.reject_reason.rfind("validation: seen-through share", 0), 0u) << s.reject_reason;
  EXPECT_EQ(s.refusal, llc::AlignmentRefusal::kValidation);
  EXPECT_GT(s.validation.seen_through_share, 0.15);
}

/// Each bad scan aligned to `good`, `good` to it, and it to itself: refused with a reason,
/// the pose finite, no throw.
void expectRefusedWithAFinitePose(const llc::ScanAligner& aligner, const std::vector<const llc::Scan*>& bad,
                                  const llc::PreparedScan& good) {
  for (const llc::Scan* s : bad) {
    const auto p = aligner.prepare(*s);
    for (const llc::ScanAlignmentResult& r : {aligner.align(*p, good), aligner.align(good, *p), aligner.align(*p, *p)}) {
      EXPECT_FALSE(r.accepted);
      EXPECT_FALSE(r.reject_reason.empty());
      EXPECT_TRUE(std::isfinite(r.pose.x) && std::isfinite(r.pose.y) && std::isfinite(r.pose.theta));
    }
  }
}

TEST(Aligner, DegenerateInputGivesAClearNonConvergedResult) {
  const llc::ScanAligner aligner;
  llc::Scan empty;
  llc::Scan two = llc_test::ringScan({1.0, std::nan(""), -1.0, 2.0});
  llc::Scan garbage = llc_test::ringScan(std::vector<double>(360, std::numeric_limits<double>::infinity()));
  expectRefusedWithAFinitePose(aligner, {&empty, &two, &garbage}, *aligner.prepare(scanAt(room(), Pose2{})));
  // A straight corridor: CRF-match may find associations, but ICP must call it degenerate.
  const auto c1 = aligner.prepare(scanAt(corridor(), Pose2{}));
  const auto c2 = aligner.prepare(scanAt(corridor(), Pose2{0.7, 0.1, 0.2}));
  const llc::ScanAlignmentResult r = aligner.align(*c1, *c2);
  EXPECT_FALSE(r.accepted);
  EXPECT_FALSE(r.reject_reason.empty());
  EXPECT_TRUE(std::isfinite(r.pose.x) && std::isfinite(r.pose.theta));
}

TEST(Aligner, BadPartialScansGiveAClearResultWithTheFieldOfViewInUse) {
  // 180-degree scans, where the field of view now shapes ICP and the choice: bearings all NaN
  // (no view at all), ranges NaN / inf / negative / zero, and a scan of two beams. Against a
  // good half-room scan and against each other: refused with a reason, pose finite, no throw.
  auto half = [](const llc::Scan& full) {
    llc::Scan out;
    for (std::size_t i = 0; i < full.size(); ++i)
      if (std::abs(full.bearings[i]) <= M_PI / 2) out.bearings.push_back(full.bearings[i]), out.ranges.push_back(full.ranges[i]);
    out.full_circle = false;
    return out;
  };
  const llc::ScanAligner aligner;
  const llc::Scan good = half(scanAt(room(), Pose2{}));
  llc::Scan no_bearings = good, bad_ranges = good, two;
  for (double& b : no_bearings.bearings) b = std::nan("");
  const double bad[4] = {std::nan(""), std::numeric_limits<double>::infinity(), -1.0, 0.0};
  for (std::size_t i = 0; i < bad_ranges.size(); ++i) bad_ranges.ranges[i] = bad[i % 4];
  two.bearings = {-0.1, 0.1}, two.ranges = {2.0, 2.0}, two.full_circle = false;
  expectRefusedWithAFinitePose(aligner, {&no_bearings, &bad_ranges, &two}, *aligner.prepare(good));
}

TEST(Aligner, PositionStdRefusesACorridorThatOnlyItsFarEndPinsDown) {
  // A corridor closed by one short wall 9 m ahead: ICP converges, but only that end wall's
  // few points fix the position along the corridor, so its uncertainty there is large. The
  // room is pinned down by walls all round.
  std::vector<llc_test::Wall> dead_end = corridor();
  dead_end.push_back({{9.0, -1.5}, {9.0, 1.5}});
  const Pose2 a{0.0, 0.0, 0.0}, b{0.4, 0.2, 0.15};
  llc::ScanAlignerOptions options;
  options.validation.max_position_std = 0.0;  // off: measure both
  const llc::ScanAligner measuring(options);
  auto alignIn = [](const llc::ScanAligner& aligner, const std::vector<llc_test::Wall>& world, Pose2 pa, Pose2 pb) {
    return aligner.align(*aligner.prepare(scanAt(world, pa, 360, 0.02, 3)), *aligner.prepare(scanAt(world, pb, 360, 0.02, 4)));
  };
  const llc::ScanAlignmentResult in_corridor = alignIn(measuring, dead_end, a, b);
  const llc::ScanAlignmentResult in_room = alignIn(measuring, room(), a, b);
  ASSERT_TRUE(in_corridor.accepted) << in_corridor.reject_reason;
  ASSERT_TRUE(in_room.accepted) << in_room.reject_reason;
  expectPoseNear(in_room.pose, llc::between(a, b), 0.05, 0.01);
  // Off, the check reports nothing; the covariance says the corridor is the weaker fit.
  EXPECT_EQ(in_corridor.validation.position_std, 0.0);
  const auto stdAlongWeakest = [](const Eigen::Matrix3d& c) {
    return std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c.topLeftCorner<2, 2>()).eigenvalues()(1));
  };
  const double corridor_std = stdAlongWeakest(in_corridor.covariance), room_std = stdAlongWeakest(in_room.covariance);
  EXPECT_GT(corridor_std, 2.0 * room_std) << corridor_std << " vs " << room_std;
  // A limit between the two refuses the corridor by name and keeps the room; the default keeps the room.
  options.validation.max_position_std = std::sqrt(corridor_std * room_std);
  const llc::ScanAligner strict(options);
  const llc::ScanAlignmentResult refused = alignIn(strict, dead_end, a, b);
  EXPECT_FALSE(refused.accepted);
  EXPECT_EQ(refused.reject_reason.rfind("validation: position std", 0), 0u) << refused.reject_reason;
  EXPECT_EQ(refused.refusal, llc::AlignmentRefusal::kValidation);
  EXPECT_NEAR(refused.validation.position_std, corridor_std, 1e-12);
  EXPECT_TRUE(alignIn(strict, room(), a, b).accepted);
  EXPECT_TRUE(alignIn(llc::ScanAligner{}, room(), a, b).accepted);
}

TEST(Aligner, FitCountsOnlyPointsTheOtherScannerCouldSee) {
  // a: the forward half of a 360-degree scan of the room (a 180-degree scanner); b: the whole
  // scan, from the same spot. At the truth every point either could see matches, so the fit is
  // 1; b's rear half, which a's scanner never saw, is no evidence against the pose (counted,
  // it would halve b's share and make the fit about 0.75).
  const llc::Scan full = scanAt(room(), Pose2{});
  llc::Scan front;
  for (std::size_t i = 0; i < full.size(); ++i)
    if (std::abs(full.bearings[i]) <= M_PI / 2) front.bearings.push_back(full.bearings[i]), front.ranges.push_back(full.ranges[i]);
  front.full_circle = false;
  const llc::ScanAligner aligner;
  const auto a = aligner.prepare(front), b = aligner.prepare(full);
  EXPECT_NEAR(aligner.fit(*a, *b, Pose2{}), 1.0, 1e-12);
  EXPECT_LT(aligner.fit(*a, *b, Pose2{0.3, 0.0, 0.0}), 0.9);  // and a wrong pose still fits worse
}

TEST(Aligner, PicksTheBestShareAmongResultsOfComparableOverlap) {
  // Overlaps 400, 100, 300 and shares 0.7, 0.95, 0.8: the 100-point result fits best but
  // covers a quarter of the largest overlap; at 0.6 only 400 and 300 (>= 240) compete.
  const std::vector<llc::AlignmentFit> fits = {{0.7, 400}, {0.95, 100}, {0.8, 300}};
  EXPECT_EQ(llc::pickAlignment(fits, 0.6), 2u);
  EXPECT_EQ(llc::pickAlignment(fits, 0.0), 1u);   // every result competes: the best share
  EXPECT_EQ(llc::pickAlignment(fits, 0.8), 0u);   // only 400 (300 < 320)
  EXPECT_EQ(llc::pickAlignment(fits, 0.75), 2u);  // 300 >= 300: the bound is inclusive
  EXPECT_EQ(llc::pickAlignment({}, 0.6), 0u);
}

TEST(Aligner, WeakDirectionStartsLieAlongTheLargerAxisOfThePositionCovariance) {
  // Covariance with axes along 30 degrees (variance 4e-4) and 120 degrees (1e-6): the starts
  // lie along 30 degrees at -0.25, +0.25, -0.5, +0.5, -1, +1 m, heading unchanged.
  const double angle = M_PI / 6, c = std::cos(angle), s = std::sin(angle);
  Eigen::Matrix2d rotation;
  rotation << c, -s, s, c;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity() * 1e-6;
  covariance.topLeftCorner<2, 2>() = rotation * Eigen::Vector2d(4e-4, 1e-6).asDiagonal() * rotation.transpose();
  const Pose2 pose{1.0, -2.0, 0.4};
  const std::vector<Pose2> starts = llc::weakDirectionStarts(pose, covariance, 0.25, 3);
  ASSERT_EQ(starts.size(), 6u);
  const double shifts[6] = {-0.25, 0.25, -0.5, 0.5, -1.0, 1.0};
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(starts[k].x, 1.0 + shifts[k] * c, 1e-12) << k;
    EXPECT_NEAR(starts[k].y, -2.0 + shifts[k] * s, 1e-12) << k;
    EXPECT_EQ(starts[k].theta, 0.4);
  }
  EXPECT_TRUE(llc::weakDirectionStarts(pose, covariance, 0.25, 0).empty());
}

TEST(Aligner, RefusesBadOptions) {
  // Each entry spoils one option of an otherwise default set (the nested stages' options are
  // validated with the rest).
  using Spoil = std::function<void(llc::ScanAlignerOptions&)>;
  const std::vector<std::pair<const char*, Spoil>> spoils = {
      {"min_inlier_share", [](auto& o) { o.validation.min_inlier_share = 1.5; }},
      {"crf distance weight", [](auto& o) { o.crf.weights.distance = -1.0; }},
      {"reverse_below", [](auto& o) { o.reverse_below = 2.0; }},
      {"global_search_below", [](auto& o) { o.global_search_below = 1.5; }},
      {"min_relative_overlap", [](auto& o) { o.min_relative_overlap = -0.1; }},
      {"weak_direction_shift", [](auto& o) { o.weak_direction_shift = 0.0; }},
      {"weak_direction_restarts", [](auto& o) { o.weak_direction_restarts = -1; }},
      {"weak_direction_above", [](auto& o) { o.weak_direction_above = 1.1; }},
      {"icp fixed_pairs_after", [](auto& o) { o.icp.fixed_pairs_after = 0; }},
      {"max_position_std -0.01", [](auto& o) { o.validation.max_position_std = -0.01; }},
      {"max_position_std nan", [](auto& o) { o.validation.max_position_std = std::nan(""); }},
      {"max_position_std inf", [](auto& o) { o.validation.max_position_std = std::numeric_limits<double>::infinity(); }},
      {"global rotations", [](auto& o) { o.global.rotations = 0; }},
  };
  for (const auto& [name, spoil] : spoils) {
    llc::ScanAlignerOptions options;
    spoil(options);
    EXPECT_THROW(llc::ScanAligner{options}, std::invalid_argument) << name;
  }
}

TEST(Aligner, ReverseMatchingAddsStartsAndAgreesWithTheForwardOne) {
  // Always matching both ways (reverse_below = 1) must find the same transform on a clean
  // pair, with more ICP candidates considered.
  const Pose2 a{0.2, -0.4, 0.1}, b{1.1, 0.3, 2.0};
  llc::ScanAlignerOptions both;
  both.reverse_below = 1.0;
  llc::ScanAlignerOptions forward_only;
  forward_only.reverse_below = 0.0;
  const llc::ScanAligner aligner_both(both), aligner_forward(forward_only);
  const auto pa = aligner_both.prepare(scanAt(room(), a, 720, 0.005, 3));
  const auto pb = aligner_both.prepare(scanAt(room(), b, 720, 0.005, 4));
  const llc::ScanAlignmentResult r_both = aligner_both.align(*pa, *pb);
  const llc::ScanAlignmentResult r_forward = aligner_forward.align(*pa, *pb);
  ASSERT_TRUE(r_both.accepted && r_forward.accepted);
  EXPECT_GT(r_both.icp_poses.size(), r_forward.icp_poses.size());
  expectPoseNear(r_both.pose, llc::between(a, b), 0.02, 0.005);
  expectPoseNear(r_forward.pose, llc::between(a, b), 0.02, 0.005);
}

TEST(Aligner, MatchingTheOtherWayOnASecondThreadChangesNothing) {
  // A clean pair (the forward match suffices) and a room against a corridor (a poor forward
  // fit: the match the other way round is used).
  llc::ScanAlignerOptions parallel, serial;
  parallel.parallel = true;
  serial.parallel = false;
  const llc::ScanAligner aligner_parallel(parallel), aligner_serial(serial);
  const Pose2 a{0.2, -0.4, 0.1}, b{1.1, 0.3, 2.0};
  const auto pa = aligner_serial.prepare(scanAt(room(), a, 720, 0.005, 3));
  const auto pb = aligner_serial.prepare(scanAt(room(), b, 720, 0.005, 4));
  const auto other = aligner_serial.prepare(scanAt(corridor(), b, 720, 0.005, 5));
  for (const auto& second : {pb, other}) {
    const llc::ScanAlignmentResult p = aligner_parallel.align(*pa, *second);
    // Serial by its options, and the parallel aligner kept on the calling thread by its caller.
    for (const llc::ScanAlignmentResult& s : {aligner_serial.align(*pa, *second), aligner_parallel.align(*pa, *second, false)}) {
      EXPECT_EQ(p.accepted, s.accepted);
      EXPECT_EQ(p.reject_reason, s.reject_reason);
      EXPECT_EQ(p.pose.x, s.pose.x);
      EXPECT_EQ(p.pose.y, s.pose.y);
      EXPECT_EQ(p.pose.theta, s.pose.theta);
      EXPECT_EQ(p.icp_shares, s.icp_shares);
      EXPECT_EQ(p.validation.inlier_share, s.validation.inlier_share);
    }
  }
  const llc::ScanAlignmentResult poor = aligner_parallel.align(*pa, *other);
  EXPECT_FALSE(poor.accepted);
  for (const double share : poor.icp_shares) EXPECT_LT(share, parallel.reverse_below);
}

/// Energy of an association under the weights: what max-product minimises.
double energy(const llc::CrfScan& s, const llc::CrfScan& t, const std::vector<long>& y, const llc::CrfWeights& w) {
  const auto totals = llc::crfFeatureTotals(s, t, y);
  const auto weights = w.asArray();
  double e = 0.0;
  for (std::size_t q = 0; q < totals.size(); ++q) e += weights[q] * totals[q];
  return e;
}

TEST(CrfMatch, MapAssociationHasTheLowestEnergyAndConfidencesAreProbabilities) {
  const llc::CrfMatchOptions options;
  const Pose2 a{0.0, 0.0, 0.0}, b{0.8, 0.4, 1.9};
  const llc::CrfScan sa = llc::describeForCrf(llc::scanPoints(scanAt(room(), a), 40.0), options);
  const llc::CrfScan sb = llc::describeForCrf(llc::scanPoints(scanAt(room(), b), 40.0), options);
  ASSERT_GT(sb.nodes.size(), 20u);
  const llc::CrfMatchResult r = llc::matchCrf(sb, sa, options);
  ASSERT_TRUE(r.ok) << r.reject_reason;
  ASSERT_EQ(r.association.size(), sb.nodes.size());
  for (double c : r.confidence) EXPECT_TRUE(c >= 0.0 && c <= 1.0 + 1e-12);
  // The MAP association is at least as good as the true one and any change of one state.
  const double best = energy(sb, sa, r.association, options.weights);
  const std::vector<long> truth = llc::crfTrueAssociation(sb, sa, llc::between(a, b), 0.3);
  EXPECT_LE(best, energy(sb, sa, truth, options.weights) + 1e-9);
  llc::Random random(5);
  for (int k = 0; k < 200; ++k) {
    std::vector<long> changed = r.association;
    changed[random.index(changed.size())] = long(random.index(sa.nodes.size() + 1)) - 1;
    EXPECT_LE(best, energy(sb, sa, changed, options.weights) + 1e-9);
  }
  expectPoseNear(r.pose, llc::between(a, b), 0.2, 0.05);
}

TEST(CrfWeightsFile, RoundTripAndRefusals) {
  llc_test::TempDir dir;
  llc::CrfWeights w;
  w.local[2] = 0.125;
  w.order = 3.5;
  llc::saveCrfWeights(w, {{"data", "test"}}, dir.file("w.yaml"));
  const llc::CrfWeights back = llc::loadCrfWeights(dir.file("w.yaml"));
  EXPECT_EQ(back.asArray(), w.asArray());
  EXPECT_THROW(llc::loadCrfWeights(dir.file("missing.yaml")), llc::CrfWeightsError);
  llc_test::writeText(dir.file("text.yaml"), "hello: [");
  EXPECT_THROW(llc::loadCrfWeights(dir.file("text.yaml")), llc::CrfWeightsError);
  llc_test::writeText(dir.file("v2.yaml"), "format: laser_loop_closure/crf_weights\nversion: 2\n");
  try {
    llc::loadCrfWeights(dir.file("v2.yaml"));
    FAIL();
  } catch (const llc::CrfWeightsError& e) {
    EXPECT_NE(std::string(e.what()).find("version 2"), std::string::npos);
  }
  llc_test::writeText(dir.file("cut.yaml"), "format: laser_loop_closure/crf_weights\nversion: 1\nlocal: [1, 1, 1, 1, 1, 1, 1]\n");
  EXPECT_THROW(llc::loadCrfWeights(dir.file("cut.yaml")), llc::CrfWeightsError);
  llc_test::writeText(dir.file("neg.yaml"),
                      "format: laser_loop_closure/crf_weights\nversion: 1\nlocal: [1, 1, 1, 1, 1, 1, 1]\n"
                      "outlier: 1\ndistance: -2\norder: 1\n");
  EXPECT_THROW(llc::loadCrfWeights(dir.file("neg.yaml")), llc::CrfWeightsError);
  llc_test::writeText(dir.file("short.yaml"),
                      "format: laser_loop_closure/crf_weights\nversion: 1\nlocal: [1, 1]\noutlier: 1\ndistance: 2\norder: 1\n");
  EXPECT_THROW(llc::loadCrfWeights(dir.file("short.yaml")), llc::CrfWeightsError);
}

TEST(CrfTraining, PerceptronIsDeterministicAndKeepsWeightsNonNegative) {
  const llc::CrfMatchOptions options;
  std::vector<llc::CrfScan> scans;
  std::vector<Pose2> poses = {{0, 0, 0}, {1.0, 0.5, 1.0}, {-1.5, -1.0, -2.0}, {2.0, 1.0, 3.0}};
  for (std::size_t k = 0; k < poses.size(); ++k)
    scans.push_back(llc::describeForCrf(llc::scanPoints(scanAt(room(), poses[k], 720, 0.01, k + 1), 40.0), options));
  std::vector<llc::CrfTrainingPair> pairs;
  for (std::size_t k = 1; k < poses.size(); ++k) pairs.push_back({&scans[k], &scans[0], llc::between(poses[0], poses[k])});
  llc::CrfTrainingOptions training;
  training.epochs = 3;
  const llc::CrfTrainingResult one = llc::trainCrfWeights(pairs, options, training);
  const llc::CrfTrainingResult two = llc::trainCrfWeights(pairs, options, training);
  EXPECT_EQ(one.weights.asArray(), two.weights.asArray());
  ASSERT_EQ(one.error_by_epoch.size(), 3u);
  for (double v : one.weights.asArray()) EXPECT_GE(v, 0.0);
  EXPECT_DOUBLE_EQ(one.weights.outlier, 1.0);
  training.epochs = 0;
  EXPECT_THROW(llc::trainCrfWeights(pairs, options, training), std::invalid_argument);
}

}  // namespace

TEST(FieldOfView, ContainsAgreesWithTheBearingsOfItsArc) {
  // The reference: a point is inside when its atan2 bearing lies in [min, max] and it is in
  // range. Arcs narrow, exactly pi, wide, and of zero width; points on a dense ring of radii.
  const double arcs[][2] = {{-M_PI / 2, M_PI / 2}, {-0.3, 0.9}, {-2.5, 2.1}, {-M_PI, M_PI}, {0.4, 0.4}, {-3.0, -1.0}, {1.0, 3.1}};
  for (const auto& arc : arcs) {
    const llc::FieldOfView view = llc::FieldOfView::arc(arc[0], arc[1], 30.0);
    for (int i = 0; i < 3600; ++i) {
      const double bearing = -M_PI + (i + 0.37) * 2.0 * M_PI / 3600.0;  // never exactly an edge
      for (double r : {0.5, 10.0, 29.9, 30.5}) {
        const Point2 p(r * std::cos(bearing), r * std::sin(bearing));
        const double b = std::atan2(p.y(), p.x());
        const bool inside = r < 30.0 && b >= arc[0] && b <= arc[1];
        ASSERT_EQ(view.contains(p), inside) << "arc [" << arc[0] << ", " << arc[1] << "], bearing " << b << ", range " << r;
      }
    }
  }
  EXPECT_FALSE(llc::FieldOfView::arc(0.0, 0.0, 30.0).contains(Point2(-1.0, 0.0))) << "a zero-width arc has no backward ray";
  EXPECT_TRUE(llc::FieldOfView::arc(0.0, 0.0, 30.0).contains(Point2(1.0, 0.0)));
  EXPECT_TRUE(llc::FieldOfView::fullCircle(30.0).contains(Point2(-29.0, 0.0)));
  EXPECT_FALSE(llc::FieldOfView::fullCircle(30.0).contains(Point2(0.0, 31.0)));
  EXPECT_THROW(llc::FieldOfView::arc(1.0, 0.5, 30.0), std::invalid_argument);
  EXPECT_THROW(llc::FieldOfView::arc(-4.0, 0.5, 30.0), std::invalid_argument);
}
