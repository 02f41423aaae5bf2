// Marginalising poses out of a pose graph (backend/marginalization): hand-worked chains, the
// ESDF as the reference for what is kept, and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/backend/marginalization.hpp"
#include "laser_loop_closure/core/common/random.hpp"

namespace {

using llc::Pose2;
using llc::PoseEdge;

/// The graph as SlamBackEnd::restore rebuilds it (augmentations, then updates), solved from `poses`.
std::unique_ptr<llc::Esdf> rebuild(const std::vector<Pose2>& poses, const std::vector<PoseEdge>& edges) {
  auto esdf = std::make_unique<llc::Esdf>(poses.front());
  for (const PoseEdge& e : edges) {
    if (e.to == esdf->size()) {
      esdf->augmentWithInformation(e);
    } else {
      const llc::EsdfUpdateResult update = esdf->updateWithInformation(e, false, false);
      EXPECT_TRUE(update.applied) << e.from << " -> " << e.to << ": " << update.reject_reason;
    }
  }
  esdf->solveFrom(poses);
  return esdf;
}

const Eigen::Matrix3d kInformation = Eigen::Vector3d(100.0, 400.0, 900.0).asDiagonal();

TEST(Marginalization, TheMiddleOfAChainBecomesTheComposedOdometryWithItsCovariance) {
  // 0 -> 1 -> 2: forward 1 m and a left turn, then forward 1 m: pose 2 at (1, 1, pi/2) from 0.
  const std::vector<PoseEdge> edges{{0, 1, {1.0, 0.0, M_PI / 2}, kInformation}, {1, 2, {1.0, 0.0, 0.0}, kInformation}};
  std::vector<Pose2> poses{{0, 0, 0}, {1, 0, M_PI / 2}, {1, 1, M_PI / 2}};
  const auto full = rebuild(poses, edges);
  // Poses off their optimum by 1-2 cm: the composed measurement comes from the constraints,
  // not from where the poses happen to be.
  poses[1] = {1.01, -0.02, M_PI / 2 + 0.01};
  poses[2] = {0.98, 1.02, M_PI / 2 - 0.01};
  const llc::PoseGraphReduction reduced = llc::marginalizePoses(poses, edges, {0, 1, 0});
  ASSERT_EQ(reduced.edges.size(), 1u);
  EXPECT_EQ(reduced.retired, 1u);
  EXPECT_EQ(reduced.kept, (std::vector<std::size_t>{0, 2}));
  const PoseEdge& composed = reduced.edges[0];
  EXPECT_EQ(composed.from, 0u);
  EXPECT_EQ(composed.to, 1u);
  EXPECT_NEAR(composed.measurement.x, 1.0, 2e-3);
  EXPECT_NEAR(composed.measurement.y, 1.0, 2e-3);
  EXPECT_NEAR(composed.measurement.theta, M_PI / 2, 2e-3);
  EXPECT_NEAR(reduced.max_kl, 0.0, 1e-9);  // one neighbour pair: the tree is the marginal itself
  // The kept pose's covariance is the full graph's (the ESDF as reference).
  const auto small = rebuild({{0, 0, 0}, {1, 1, M_PI / 2}}, reduced.edges);
  const Eigen::Matrix3d expected = full->marginalCovariance(2), got = small->marginalCovariance(1);
  EXPECT_LT((got - expected).norm(), 2e-2 * expected.norm()) << got << "\n\n" << expected;
}

TEST(Marginalization, RetiringHalfOfALoopyGraphKeepsItsOptimumAndItsCovariancesClose) {
  llc::Random random(7);
  std::vector<Pose2> truth{Pose2{}};
  const std::size_t n = 40;
  for (std::size_t k = 1; k < n; ++k)
    truth.push_back(llc::compose(truth.back(), Pose2{random.uniform(0.5, 1.0), random.uniform(-0.1, 0.1), random.uniform(-0.5, 0.5)}));
  auto noisy = [&](const Pose2& z) {
    return Pose2{z.x + random.normal(0, 0.05), z.y + random.normal(0, 0.03), llc::normalizeAngle(z.theta + random.normal(0, 0.02))};
  };
  std::vector<PoseEdge> edges;
  for (std::size_t k = 1; k < n; ++k) edges.push_back({k - 1, k, noisy(llc::between(truth[k - 1], truth[k])), kInformation});
  for (std::size_t k = 5; k < n; k += 3) edges.push_back({k - 5, k, noisy(llc::between(truth[k - 5], truth[k])), kInformation});
  std::vector<Pose2> start{truth[0]};
  for (std::size_t k = 1; k < n; ++k) start.push_back(llc::compose(start.back(), edges[k - 1].measurement));
  const auto full = rebuild(start, edges);
  std::vector<char> retire(n, 0);
  for (std::size_t k = 1; k < n; k += 2) retire[k] = 1;
  const llc::PoseGraphReduction reduced = llc::marginalizePoses(full->mean(), edges, retire);
  EXPECT_EQ(reduced.retired, n / 2);
  EXPECT_EQ(reduced.kept_unfactorizable, 0u);
  EXPECT_LT(reduced.edges.size(), edges.size() - n / 2 + 1);  // each pose retired takes at least one constraint with it
  EXPECT_GT(reduced.max_kl, 0.0);                              // loops make neighbourhoods that are no tree
  const auto small = rebuild(reduced.poses, reduced.edges);
  double worst_shift = 0.0, worst_ratio = 0.0, best_ratio = 1e9;
  for (std::size_t i = 0; i < reduced.kept.size(); ++i) {
    const Pose2& a = small->mean()[i];
    const Pose2& b = full->mean()[reduced.kept[i]];
    worst_shift = std::max(worst_shift, std::hypot(a.x - b.x, a.y - b.y));
    if (i == 0) continue;
    const double ratio = small->marginalCovariance(i).trace() / full->marginalCovariance(reduced.kept[i]).trace();
    worst_ratio = std::max(worst_ratio, ratio);
    best_ratio = std::min(best_ratio, ratio);
  }
  // Each pose's position stays within a fraction of its own standard deviation (~ cm here).
  EXPECT_LT(worst_shift, 0.01) << "m";
  EXPECT_LT(worst_ratio, 1.5);
  EXPECT_GT(best_ratio, 0.67);
  std::printf("retired %zu of %zu poses: %zu -> %zu constraints, KL mean %.3g max %.3g nats; worst shift %.4f m; "
              "covariance trace ratio %.3f .. %.3f\n",
              reduced.retired, n, edges.size(), reduced.edges.size(), reduced.mean_kl, reduced.max_kl, worst_shift,
              best_ratio, worst_ratio);
}

TEST(Marginalization, AnyRetiredSetLeavesAGraphTheEsdfRebuildsPoseByPose) {
  // Random chains with random loops (either way round) and random poses retired: the order of
  // elimination and the trees must leave every kept pose reachable from an older one.
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    llc::Random random(seed);
    const std::size_t n = 30 + random.index(40);
    std::vector<Pose2> poses{Pose2{}};
    std::vector<PoseEdge> edges;
    for (std::size_t k = 1; k < n; ++k) {
      const Pose2 step{random.uniform(0.5, 1.0), random.uniform(-0.1, 0.1), random.uniform(-0.5, 0.5)};
      edges.push_back({k - 1, k, step, kInformation});
      poses.push_back(llc::compose(poses.back(), step));
    }
    for (std::size_t l = 0; l < n; ++l) {
      std::size_t a = random.index(n), b = random.index(n);
      if (a == b) continue;
      if (random.uniform(0.0, 1.0) < 0.3) std::swap(a, b);  // some loops from the newer pose
      edges.push_back({a, b, llc::between(poses[a], poses[b]), kInformation});
    }
    std::vector<char> retire(n, 0);
    for (std::size_t k = 0; k < n; ++k) retire[k] = random.uniform(0.0, 1.0) < 0.6;
    const llc::PoseGraphReduction reduced = llc::marginalizePoses(poses, edges, retire);
    EXPECT_EQ(reduced.kept.front(), 0u) << "pose 0 left (seed " << seed << ")";
    EXPECT_EQ(reduced.kept.size() + reduced.retired, n);
    EXPECT_EQ(reduced.retired + reduced.kept_unfactorizable, std::size_t(std::count(retire.begin() + 1, retire.end(), 1)));
    std::size_t reached = 0;  // as SlamSession::validate reads the order
    for (const PoseEdge& e : reduced.edges) {
      if (e.to == reached + 1 && e.from < e.to) ++reached;
      else EXPECT_LE(std::max(e.from, e.to), reached) << "seed " << seed << ": a constraint reaches a pose before it exists";
    }
    EXPECT_EQ(reached + 1, reduced.kept.size()) << "seed " << seed;
    // Consistent measurements: the kept poses stay where they were.
    const auto small = rebuild(reduced.poses, reduced.edges);
    for (std::size_t i = 0; i < reduced.kept.size(); ++i)
      EXPECT_LT(std::hypot(small->mean()[i].x - poses[reduced.kept[i]].x, small->mean()[i].y - poses[reduced.kept[i]].y), 1e-6)
          << "seed " << seed << " pose " << reduced.kept[i];
  }
}

TEST(Marginalization, ALeafLeavesWithItsConstraintsAndPoseZeroNeverLeaves) {
  const std::vector<PoseEdge> edges{{0, 1, {1, 0, 0}, kInformation}, {1, 2, {1, 0, 0}, kInformation}, {0, 2, {2, 0, 0}, kInformation}};
  const std::vector<Pose2> poses{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  const llc::PoseGraphReduction leaf = llc::marginalizePoses({poses[0], poses[1]}, {edges[0]}, {1, 1});
  EXPECT_EQ(leaf.kept, (std::vector<std::size_t>{0}));
  EXPECT_TRUE(leaf.edges.empty());
  // Pose 2 joined to 0 twice (through 1 and directly): retiring 1 leaves two constraints 0 -> 1
  // (renumbered), the augmentation first.
  const llc::PoseGraphReduction two = llc::marginalizePoses(poses, edges, {1, 1, 0});
  EXPECT_EQ(two.kept, (std::vector<std::size_t>{0, 2}));
  ASSERT_EQ(two.edges.size(), 2u);
  for (const PoseEdge& e : two.edges) EXPECT_TRUE(e.from == 0 && e.to == 1);
}

TEST(Marginalization, BadGraphsAreRefusedByName) {
  const std::vector<Pose2> poses{{0, 0, 0}, {1, 0, 0}};
  const PoseEdge edge{0, 1, {1, 0, 0}, kInformation};
  auto refused = [&](const std::vector<Pose2>& p, const std::vector<PoseEdge>& e, const std::vector<char>& r, const std::string& says) {
    try {
      llc::marginalizePoses(p, e, r);
      ADD_FAILURE() << "accepted, expected: " << says;
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(says), std::string::npos) << error.what();
    }
  };
  refused(poses, {edge}, {0}, "retire flags");
  refused(poses, {{0, 5, {1, 0, 0}, kInformation}}, {0, 1}, "unknown poses");
  refused(poses, {{1, 1, {1, 0, 0}, kInformation}}, {0, 1}, "unknown poses");
  refused(poses, {{1, 0, {1, 0, 0}, kInformation}}, {0, 1}, "no constraint from an older pose");
  refused({{0, 0, 0}, {NAN, 0, 0}}, {edge}, {0, 1}, "not finite");
  PoseEdge bad = edge;
  bad.information(0, 0) = INFINITY;
  refused(poses, {bad}, {0, 1}, "not finite");
}

}  // namespace
