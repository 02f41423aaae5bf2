// SE(2) Jacobians, g2o files, and the ESDF on CHOLMOD against a dense Eigen reference.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <limits>

#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/io/g2o_io.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/geometry/se2_jacobians.hpp"
#include "../test_util.hpp"

namespace {

using llc::Pose2;

Pose2 randomPose(llc::Random& random, double extent = 3.0) {
  return {random.uniform(-extent, extent), random.uniform(-extent, extent), random.uniform(-M_PI, M_PI)};
}

/// Central differences of f at p, angles wrapped in the difference.
template <class F>
Eigen::Matrix3d numericJacobian(F f, const Pose2& p) {
  Eigen::Matrix3d j;
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[k] = h;
    const Eigen::Vector3d plus = llc::toVector(f(llc::toPose(llc::toVector(p) + d)));
    const Eigen::Vector3d minus = llc::toVector(f(llc::toPose(llc::toVector(p) - d)));
    Eigen::Vector3d diff = plus - minus;
    diff.z() = llc::normalizeAngle(diff.z());
    j.col(k) = diff / (2 * h);
  }
  return j;
}

TEST(Se2Jacobians, MatchFiniteDifferences) {
  llc::Random random(1);
  for (int t = 0; t < 50; ++t) {
    const Pose2 a = randomPose(random), b = randomPose(random);
    Eigen::Matrix3d ja, jb;
    llc::composeJacobians(a, b, &ja, &jb);
    EXPECT_LT((ja - numericJacobian([&](const Pose2& x) { return llc::compose(x, b); }, a)).norm(), 1e-7);
    EXPECT_LT((jb - numericJacobian([&](const Pose2& x) { return llc::compose(a, x); }, b)).norm(), 1e-7);
    EXPECT_LT((llc::inverseJacobian(a) - numericJacobian([](const Pose2& x) { return llc::inverse(x); }, a)).norm(), 1e-7);
    llc::betweenJacobians(a, b, &ja, &jb);
    EXPECT_LT((ja - numericJacobian([&](const Pose2& x) { return llc::between(x, b); }, a)).norm(), 1e-7);
    EXPECT_LT((jb - numericJacobian([&](const Pose2& x) { return llc::between(a, x); }, b)).norm(), 1e-7);
  }
}

/// A random graph: a noisy odometry chain of n poses and some loop edges, true poses known.
llc::PoseGraph2 randomGraph(std::uint64_t seed, std::size_t n, std::size_t loops, std::vector<Pose2>* truth) {
  llc::Random random(seed);
  truth->assign(1, Pose2{});
  for (std::size_t k = 1; k < n; ++k)
    truth->push_back(llc::compose(truth->back(), Pose2{random.uniform(0.5, 1.5), random.uniform(-0.2, 0.2), random.uniform(-0.6, 0.6)}));
  llc::PoseGraph2 g;
  const Eigen::Matrix3d information = Eigen::Vector3d(100.0, 100.0, 400.0).asDiagonal();
  auto noisy = [&](const Pose2& z) {
    return Pose2{z.x + random.normal(0, 0.1), z.y + random.normal(0, 0.1), llc::normalizeAngle(z.theta + random.normal(0, 0.05))};
  };
  for (std::size_t k = 1; k < n; ++k) g.edges.push_back({k - 1, k, noisy(llc::between((*truth)[k - 1], (*truth)[k])), information});
  for (std::size_t l = 0; l < loops; ++l) {
    const std::size_t a = random.index(n), b = random.index(n);
    if (a + 2 > b) continue;
    g.edges.push_back({a, b, noisy(llc::between((*truth)[a], (*truth)[b])), information});
  }
  g.poses.assign(1, Pose2{});
  for (std::size_t k = 1; k < n; ++k) g.poses.push_back(llc::compose(g.poses.back(), g.edges[k - 1].measurement));
  return g;
}

/// The reference: dense Gauss-Newton on the same problem (pose 0 held by the same stiff prior
/// without a residual), iterated to convergence; Lambda inverted densely for covariances.
struct DenseReference {
  std::vector<Pose2> poses;
  Eigen::MatrixXd covariance;
  DenseReference(const llc::PoseGraph2& g, double prior) : poses(g.poses) {
    const long n = 3 * long(poses.size());
    Eigen::MatrixXd h;
    for (int iteration = 0; iteration < 100; ++iteration) {
      h = Eigen::MatrixXd::Zero(n, n);
      Eigen::VectorXd b = Eigen::VectorXd::Zero(n);
      h.block<3, 3>(0, 0) += prior * Eigen::Matrix3d::Identity();
      for (const llc::PoseEdge& e : g.edges) {
        // Error and Jacobians written out from the formulas, not from the filter's code.
        const Pose2 predicted = llc::between(poses[e.from], poses[e.to]);
        const Eigen::Vector3d r = llc::toVector(llc::between(e.measurement, predicted));
        Eigen::Matrix<double, 3, 6> j;
        const double cz = std::cos(e.measurement.theta), sz = std::sin(e.measurement.theta);
        Eigen::Matrix3d rz;
        rz << cz, sz, 0, -sz, cz, 0, 0, 0, 1;  // rotation by -theta_z: d(Z^-1 (+) h)/dh
        const Pose2& a = poses[e.from];
        const Pose2& c = poses[e.to];
        const double ca = std::cos(a.theta), sa = std::sin(a.theta), dx = c.x - a.x, dy = c.y - a.y;
        Eigen::Matrix3d ja, jb;
        ja << -ca, -sa, -sa * dx + ca * dy, sa, -ca, -ca * dx - sa * dy, 0, 0, -1;
        jb << ca, sa, 0, -sa, ca, 0, 0, 0, 1;
        j << rz * ja, rz * jb;
        const Eigen::Matrix<double, 6, 3> w = j.transpose() * e.information;
        const long ia = 3 * long(e.from), ib = 3 * long(e.to);
        const Eigen::Matrix<double, 6, 6> hh = w * j;
        h.block<3, 3>(ia, ia) += hh.block<3, 3>(0, 0);
        h.block<3, 3>(ia, ib) += hh.block<3, 3>(0, 3);
        h.block<3, 3>(ib, ia) += hh.block<3, 3>(3, 0);
        h.block<3, 3>(ib, ib) += hh.block<3, 3>(3, 3);
        const Eigen::Matrix<double, 6, 1> gr = w * r;
        b.segment<3>(ia) -= gr.head<3>();
        b.segment<3>(ib) -= gr.tail<3>();
      }
      const Eigen::VectorXd step = h.ldlt().solve(b);
      for (std::size_t p = 0; p < poses.size(); ++p)
        poses[p] = {poses[p].x + step[3 * long(p)], poses[p].y + step[3 * long(p) + 1],
                    llc::normalizeAngle(poses[p].theta + step[3 * long(p) + 2])};
      if (step.lpNorm<Eigen::Infinity>() < 1e-13) break;
    }
    covariance = h.inverse();
  }
};

TEST(Esdf, MatchesADenseReferenceOnRandomGraphs) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    std::vector<Pose2> truth;
    const llc::PoseGraph2 g = randomGraph(seed, 25, 12, &truth);
    llc::EsdfOptions options;
    options.relinearize_translation = 1e-12;  // iterate to convergence, as the reference does
    options.relinearize_rotation = 1e-12;
    options.relinearize_chi2 = 0.0;
    options.max_relinearizations = 100;
    llc::Esdf filter(Pose2{}, options);
    for (const llc::PoseEdge& e : g.edges) {
      if (e.to == filter.size()) filter.augmentWithInformation(e);
      else ASSERT_TRUE(filter.updateWithInformation(e, false).applied);
    }
    // Loops after the whole chain: all but the first update the factor in place (cholmod_updown).
    EXPECT_GT(filter.rankUpdates(), 0) << "seed " << seed;
    const DenseReference reference(g, options.prior_information);
    ASSERT_EQ(filter.size(), reference.poses.size());
    for (std::size_t p = 0; p < filter.size(); ++p) {
      EXPECT_NEAR(filter.mean()[p].x, reference.poses[p].x, 1e-9) << "seed " << seed << " pose " << p;
      EXPECT_NEAR(filter.mean()[p].y, reference.poses[p].y, 1e-9);
      EXPECT_NEAR(llc::normalizeAngle(filter.mean()[p].theta - reference.poses[p].theta), 0.0, 1e-9);
    }
    for (std::size_t p : {std::size_t(0), std::size_t(7), filter.size() - 1}) {
      const Eigen::Matrix3d c = filter.marginalCovariance(p);
      EXPECT_LT((c - reference.covariance.block<3, 3>(3 * long(p), 3 * long(p))).cwiseAbs().maxCoeff(), 1e-9) << p;
    }
    // Every pair: covariances come from solves over only the elimination-tree paths of the two
    // poses, so pairs on different branches, on one path, and a pose with itself all count.
    for (std::size_t a = 0; a < filter.size(); ++a)
      for (std::size_t b = 0; b < filter.size(); ++b) {
        const Eigen::Matrix<double, 6, 6> joint = filter.jointCovariance(a, b);
        const long ia = 3 * long(a), ib = 3 * long(b);
        EXPECT_LT((joint.block<3, 3>(0, 0) - reference.covariance.block<3, 3>(ia, ia)).cwiseAbs().maxCoeff(), 1e-9);
        EXPECT_LT((joint.block<3, 3>(3, 3) - reference.covariance.block<3, 3>(ib, ib)).cwiseAbs().maxCoeff(), 1e-9);
        ASSERT_LT((joint.block<3, 3>(0, 3) - reference.covariance.block<3, 3>(ia, ib)).cwiseAbs().maxCoeff(), 1e-9)
            << "seed " << seed << " poses " << a << ", " << b;
      }
    // The optimum is no worse than the truth.
    EXPECT_LE(llc::chiSquared(g.edges, filter.mean()), llc::chiSquared(g.edges, truth) + 1e-6);
  }
}

/// Runs the graph's edges through a filter in file order (augmenting new poses).
void feed(llc::Esdf& filter, const llc::PoseGraph2& g) {
  for (const llc::PoseEdge& e : g.edges) {
    if (e.to == filter.size()) filter.augmentWithInformation(e);
    else ASSERT_TRUE(filter.updateWithInformation(e, false).applied);
  }
}

TEST(Esdf, RelinearisingEdgesInPlaceEqualsRebuildingTheSystem) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    std::vector<Pose2> truth;
    const llc::PoseGraph2 g = randomGraph(seed, 25, 12, &truth);
    llc::EsdfOptions options;
    options.relinearize_translation = 1e-12;  // to convergence, every moved edge relinearised
    options.relinearize_rotation = 1e-12;
    options.relinearize_chi2 = 0.0;
    options.max_relinearizations = 100;
    options.max_edges_relinearized_in_place = 1000;  // always in place (rank update + downdate)
    llc::Esdf in_place(Pose2{}, options);
    options.max_edges_relinearized_in_place = 0;  // always rebuilt and refactored
    llc::Esdf rebuilt(Pose2{}, options);
    feed(in_place, g);
    feed(rebuilt, g);
    EXPECT_GT(in_place.edgesRelinearizedInPlace(), 0) << "seed " << seed;
    EXPECT_EQ(rebuilt.edgesRelinearizedInPlace(), 0);
    EXPECT_LT(in_place.factorizations(), rebuilt.factorizations());
    for (std::size_t p = 0; p < g.poses.size(); ++p) {
      EXPECT_NEAR(in_place.mean()[p].x, rebuilt.mean()[p].x, 1e-9) << "seed " << seed << " pose " << p;
      EXPECT_NEAR(in_place.mean()[p].y, rebuilt.mean()[p].y, 1e-9);
      EXPECT_NEAR(llc::normalizeAngle(in_place.mean()[p].theta - rebuilt.mean()[p].theta), 0.0, 1e-9);
    }
    const Eigen::Matrix<double, 6, 6> a = in_place.jointCovariance(2, 21), b = rebuilt.jointCovariance(2, 21);
    EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9) << "seed " << seed;
  }
}

TEST(Esdf, TimingsCountEachKindOfWorkOnlyWhenItHappens) {
  std::vector<Pose2> truth;
  const llc::PoseGraph2 g = randomGraph(4, 25, 12, &truth);
  llc::Esdf filter;
  for (const llc::PoseEdge& e : g.edges) {
    if (e.to == filter.size()) filter.augmentWithInformation(e);
  }
  // Augmentation alone composes poses: nothing is factorised, updated or solved.
  EXPECT_EQ(filter.timings().rank_updates + filter.timings().solves + filter.timings().factorizations, 0.0);
  const auto start = std::chrono::steady_clock::now();
  for (const llc::PoseEdge& e : g.edges) {
    if (e.to == e.from + 1) continue;
    ASSERT_TRUE(filter.updateWithInformation(e, false).applied);
  }
  filter.marginalCovariance(3);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const llc::Esdf::Timings& t = filter.timings();
  ASSERT_GT(filter.rankUpdates(), 0);
  EXPECT_GT(t.rank_updates, 0.0);
  EXPECT_GT(t.solves, 0.0);
  EXPECT_GT(t.factorizations, 0.0);
  EXPECT_LE(t.rank_updates + t.solves + t.factorizations, elapsed) << "parts of the elapsed time, counted once";
}

TEST(Esdf, BytesGrowWithTheGraphAndItsFactor) {
  // A chain's bytes per pose: two poses of 24 bytes, an edge with its linear model and a
  // diagonal and an off-diagonal block at least; at most a few kB.
  auto chainBytes = [](std::size_t poses, bool factorised) {
    llc::Esdf filter;
    for (std::size_t k = 1; k < poses; ++k) filter.augment(Pose2{1.0, 0.0, 0.01}, Eigen::Matrix3d::Identity() * 1e-4);
    if (factorised)  // a loop from the last pose to the first: the system is factorised
      EXPECT_TRUE(filter.update(poses - 1, 0, llc::between(filter.mean().back(), filter.mean().front()),
                                Eigen::Matrix3d::Identity() * 1e-2, false).applied);
    return filter.bytes();
  };
  const std::size_t small = chainBytes(500, false), large = chainBytes(2000, false);
  EXPECT_GT(small, 500u * (2 * sizeof(Pose2) + sizeof(llc::PoseEdge) + 2 * 9 * sizeof(double)));
  EXPECT_LT(small, 500u * 4000u);
  EXPECT_NEAR(double(large) / double(small), 4.0, 0.8) << "linear in the poses";
  EXPECT_GT(chainBytes(500, true), small) << "the factor's entries count";
}

TEST(Esdf, DefaultRelinearisationReachesTheOptimumWithFewerFactorisations) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    std::vector<Pose2> truth;
    const llc::PoseGraph2 g = randomGraph(seed, 25, 12, &truth);
    llc::Esdf by_default;  // relinearises only edges whose linear model misses (relinearize_chi2)
    llc::EsdfOptions always;
    always.relinearize_chi2 = 0.0;        // every edge whose pose moved past the thresholds
    always.max_edges_relinearized_in_place = 0;  // by rebuilding, as before in-place relinearisation
    llc::Esdf whenever_moved(Pose2{}, always);
    feed(by_default, g);
    feed(whenever_moved, g);
    const DenseReference reference(g, llc::EsdfOptions().prior_information);
    const double optimum = llc::chiSquared(g.edges, reference.poses);
    EXPECT_LE(llc::chiSquared(g.edges, by_default.mean()), optimum * 1.005) << "seed " << seed;  // issue 5: within 1%
    EXPECT_LE(by_default.factorizations(), whenever_moved.factorizations()) << "seed " << seed;
  }
}

TEST(Esdf, BadRelinearisationOptionsAreRefusedByName) {
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  for (const double bad : {-1e-3, nan, inf}) {
    llc::EsdfOptions options;
    options.relinearize_chi2 = bad;
    EXPECT_NE(options.validate().find("relinearize_chi2"), std::string::npos) << bad;
    EXPECT_THROW(llc::Esdf(Pose2{}, options), std::invalid_argument);
  }
  for (const double bad : {0.5, nan, inf}) {
    llc::EsdfOptions options;
    options.reorder_fill_ratio = bad;
    EXPECT_NE(options.validate().find("reorder_fill_ratio"), std::string::npos) << bad;
  }
  llc::EsdfOptions options;
  options.max_edges_relinearized_in_place = -1;
  EXPECT_NE(options.validate().find("max_edges_relinearized_in_place"), std::string::npos);
  options = {};
  options.relinearize_chi2 = 0.0;  // allowed: relinearise whatever moved
  options.max_edges_relinearized_in_place = 0;  // allowed: always rebuild
  options.reorder_fill_ratio = 1.0;  // allowed: reorder at any fill
  EXPECT_EQ(options.validate(), "");
}

TEST(Esdf, LinearizationMissBoundOfOddAnglesEndsAndIsNotBelowZero) {
  // Angles outside [-pi, pi) and infinite ones: an answer (no endless wrapping), never negative.
  const Pose2 at_a{0, 0, 0}, at_b{1, 0, 0};
  EXPECT_GE(llc::linearizationMissBound(Pose2{0, 0, 7.0}, Pose2{1, 0, 0}, at_a, at_b, 10.0), 0.0);
  EXPECT_GE(llc::linearizationMissBound(Pose2{0, 0, -40.0}, Pose2{1, 0, 0}, at_a, at_b, 10.0), 0.0);
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(llc::linearizationMissBound(Pose2{0, 0, inf}, Pose2{1, 0, 0}, at_a, at_b, 10.0) < 0.0);
  EXPECT_EQ(llc::linearizationMissBound(at_a, at_b, at_a, at_b, 10.0), 0.0) << "no move, no miss";
}

TEST(Esdf, LinearizationMissBoundIsNeverBelowTheTrueMiss) {
  // The true miss: the error at the new poses against its first-order model at the old ones,
  // with Jacobians by central differences (independent of the filter's own).
  llc::Random random(7);
  const Eigen::Matrix3d information = (Eigen::Matrix3d() << 80, 15, 3, 15, 40, -2, 3, -2, 300).finished();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> xy(information.topLeftCorner<2, 2>());
  const double largest = xy.eigenvalues().maxCoeff();
  int tight = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Pose2 z = randomPose(random), at_a = randomPose(random), at_b = randomPose(random);
    const double step = trial % 2 ? 0.05 : 0.5;  // small and large moves
    auto moved = [&](const Pose2& p) {
      return Pose2{p.x + random.uniform(-step, step), p.y + random.uniform(-step, step),
                   llc::normalizeAngle(p.theta + random.uniform(-step, step))};
    };
    const Pose2 a = moved(at_a), b = moved(at_b);
    auto error = [&](const Pose2& pa, const Pose2& pb) { return llc::between(z, llc::between(pa, pb)); };
    const Eigen::Matrix3d ja = numericJacobian([&](const Pose2& p) { return error(p, at_b); }, at_a);
    const Eigen::Matrix3d jb = numericJacobian([&](const Pose2& p) { return error(at_a, p); }, at_b);
    auto step_of = [](const Pose2& p, const Pose2& q) {
      return Eigen::Vector3d(p.x - q.x, p.y - q.y, llc::normalizeAngle(p.theta - q.theta));
    };
    Eigen::Vector3d miss = llc::toVector(error(a, b)) - llc::toVector(error(at_a, at_b)) - ja * step_of(a, at_a) -
                           jb * step_of(b, at_b);
    miss.z() = llc::normalizeAngle(miss.z());
    const double exact = miss.dot(information * miss);
    const double bound = llc::linearizationMissBound(a, b, at_a, at_b, largest);
    EXPECT_GE(bound * (1 + 1e-6) + 1e-12, exact) << "trial " << trial;
    tight += bound < 10 * exact;
  }
  EXPECT_GT(tight, 500) << "the bound should not be uselessly loose";
}

TEST(Esdf, CovariancesOfPosesAddedSinceTheLastFactorisationNeedNoNewOne) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    std::vector<Pose2> truth;
    const llc::PoseGraph2 g = randomGraph(seed, 25, 8, &truth);
    // Converged, so that the twin's fresh solve below stays at the same linearisation point.
    llc::EsdfOptions options;
    options.relinearize_translation = 1e-12;
    options.relinearize_rotation = 1e-12;
    options.relinearize_chi2 = 0.0;
    options.max_relinearizations = 100;
    llc::Esdf filter(Pose2{}, options), twin(Pose2{}, options);
    for (llc::Esdf* f : {&filter, &twin})
      for (const llc::PoseEdge& e : g.edges) {
        if (e.to == f->size()) f->augmentWithInformation(e);
        else ASSERT_TRUE(f->updateWithInformation(e, false).applied);
      }
    filter.marginalCovariance(0);  // current: factored
    // New poses: a chain off the newest, and branches off older poses (the front end's restart).
    const Eigen::Matrix3d c = Eigen::Vector3d(0.02, 0.01, 0.003).asDiagonal();
    const std::vector<std::pair<std::size_t, Pose2>> added = {
        {24, {1.0, 0.1, 0.2}}, {25, {0.8, -0.2, -0.4}}, {3, {0.5, 0.5, 1.0}}, {26, {1.2, 0.0, 0.1}}, {27, {0.3, 0.2, 2.5}}};
    for (llc::Esdf* f : {&filter, &twin})
      for (const auto& [base, motion] : added) f->augmentFrom(base, motion, c);
    const int factorizations = filter.factorizations();
    twin.solveFrom(twin.mean());  // the same system factorised afresh: the reference
    for (auto [a, b] : {std::pair<std::size_t, std::size_t>{2, 20}, {5, 25}, {25, 28}, {27, 26}, {29, 29}, {3, 27}, {0, 29}}) {
      const Eigen::Matrix<double, 6, 6> leaf = filter.jointCovariance(a, b), fresh = twin.jointCovariance(a, b);
      EXPECT_LT((leaf - fresh).cwiseAbs().maxCoeff(), 1e-9 * std::max(1.0, fresh.cwiseAbs().maxCoeff()))
          << "seed " << seed << " poses " << a << ", " << b;
    }
    EXPECT_EQ(filter.factorizations(), factorizations) << "propagated, not factorised";
    // A gate decision from the propagated covariance equals the factorised one.
    const Pose2 measured = llc::between(truth[4], filter.mean()[28]);
    EXPECT_NEAR(filter.innovationChi2(4, 28, measured, c), twin.innovationChi2(4, 28, measured, c), 1e-6);
    // A loop edge ends the run: the next covariance is factorised.
    ASSERT_TRUE(filter.update(10, 28, llc::between(filter.mean()[10], filter.mean()[28]), c, false).applied);
    filter.marginalCovariance(28);
    EXPECT_GT(filter.factorizations(), factorizations);
  }
}

TEST(Esdf, ChiSquareGateRefusesAPlantedWrongLoopAndAcceptsTheRightOnes) {
  std::vector<Pose2> truth;
  const llc::PoseGraph2 g = randomGraph(9, 40, 0, &truth);
  llc::Esdf filter;
  for (const llc::PoseEdge& e : g.edges) filter.augmentWithInformation(e);
  const Eigen::Matrix3d covariance = Eigen::Vector3d(0.01, 0.01, 0.0025).asDiagonal();
  // Right loops (true relative poses): accepted and applied.
  for (auto [a, b] : {std::pair<std::size_t, std::size_t>{2, 30}, {10, 39}, {0, 20}}) {
    const llc::EsdfUpdateResult r = filter.update(a, b, llc::between(truth[a], truth[b]), covariance, true);
    EXPECT_TRUE(r.applied) << r.reject_reason;
    EXPECT_LE(r.innovation_chi2, 16.27);
  }
  const std::vector<Pose2> before = filter.mean();
  const std::size_t constraints = filter.constraints().size();
  // A wrong loop: the true relative pose moved by 3 m. Refused, nothing changes.
  Pose2 wrong = llc::between(truth[5], truth[35]);
  wrong.x += 3.0;
  const llc::EsdfUpdateResult r = filter.update(5, 35, wrong, covariance, true);
  EXPECT_FALSE(r.applied);
  EXPECT_GT(r.innovation_chi2, 16.27);
  EXPECT_NE(r.reject_reason.find("chi2"), std::string::npos);
  EXPECT_EQ(filter.constraints().size(), constraints);
  for (std::size_t p = 0; p < before.size(); ++p) EXPECT_EQ(filter.mean()[p].x, before[p].x);
  // Bad updates are refused with a reason, never applied.
  EXPECT_FALSE(filter.update(3, 3, wrong, covariance, false).applied);
  EXPECT_FALSE(filter.update(3, 400, wrong, covariance, false).applied);
  EXPECT_FALSE(filter.update(1, 3, wrong, Eigen::Matrix3d::Zero(), false).applied);
  EXPECT_FALSE(filter.update(1, 3, Pose2{std::nan(""), 0.0, 0.0}, covariance, false).applied);
  EXPECT_FALSE(filter.update(1, 3, wrong, -covariance, false).applied);
  EXPECT_FALSE(filter.updateWithInformation(llc::PoseEdge{1, 3, wrong, -Eigen::Matrix3d::Identity()}, false).applied);
  for (std::size_t p = 0; p < before.size(); ++p) EXPECT_TRUE(std::isfinite(filter.mean()[p].x));
  EXPECT_THROW(filter.augment(wrong, Eigen::Matrix3d::Zero()), std::invalid_argument);
  EXPECT_THROW(filter.augment(Pose2{0.0, std::nan(""), 0.0}, covariance), std::invalid_argument);
  EXPECT_THROW(filter.augment(wrong, -covariance), std::invalid_argument);
  EXPECT_THROW(filter.augmentFrom(999, wrong, covariance), std::invalid_argument);
}

/// The graph through the filter in file order (loops applied incrementally) or in batch.
llc::Esdf& runGraph(llc::Esdf& filter, const llc::PoseGraph2& g, bool batch) {
  for (const llc::PoseEdge& e : g.edges) {
    if (e.to == filter.size()) filter.augmentWithInformation(e);
    else EXPECT_TRUE(filter.updateWithInformation(e, false, !batch).applied);
  }
  if (batch) filter.solveFrom(g.poses);
  return filter;
}

TEST(Esdf, RobustLoopsLetNoWrongLoopBendTheGraph) {
  std::vector<Pose2> truth;
  llc::PoseGraph2 clean = randomGraph(21, 60, 40, &truth);
  llc::Esdf reference;
  const double optimum = llc::chiSquared(clean.edges, runGraph(reference, clean, true).mean());
  // Wrong loops: two poses far apart said to be 1 m apart, with a loop's information.
  llc::PoseGraph2 corrupted = clean;
  const std::vector<std::pair<std::size_t, std::size_t>> wrong = {{3, 45}, {12, 58}, {20, 50}};
  for (auto [a, b] : wrong) corrupted.edges.push_back({a, b, Pose2{1.0, 0.0, 0.5}, clean.edges.back().information});
  llc::Esdf plain;
  const double bent = llc::chiSquared(clean.edges, runGraph(plain, corrupted, true).mean());
  EXPECT_GT(bent, 10.0 * optimum) << "the wrong loops bend a least-squares solution";
  llc::EsdfOptions options;
  options.robust_loop_chi2 = 16.27;
  for (bool batch : {true, false}) {
    llc::Esdf robust(Pose2{}, options);
    runGraph(robust, corrupted, batch);
    if (!batch) robust.solveFrom(corrupted.poses);  // as llc graph ends an incremental run
    EXPECT_NEAR(llc::chiSquared(clean.edges, robust.mean()), optimum, 0.01 * optimum) << "batch " << batch;
    const std::vector<double>& weights = robust.constraintWeights();
    ASSERT_EQ(weights.size(), corrupted.edges.size());
    for (std::size_t k = clean.edges.size(); k < weights.size(); ++k) EXPECT_LT(weights[k], 1e-3) << "wrong loop " << k;
    std::size_t held = 0;  // the true loops fit: held in full (a few may sit just past the kernel)
    for (std::size_t k = 0; k < clean.edges.size(); ++k) held += weights[k] == 1.0;
    EXPECT_GE(held, clean.edges.size() - 2);
  }
  // Where every loop fits, the robust solution is the least-squares one.
  llc::Esdf robust_clean(Pose2{}, options);
  EXPECT_NEAR(llc::chiSquared(clean.edges, runGraph(robust_clean, clean, true).mean()), optimum, 1e-6 * optimum);
  options.robust_loop_chi2 = -1.0;
  EXPECT_NE(options.validate().find("robust_loop_chi2"), std::string::npos);
}

TEST(Esdf, ALeastSquaresRunThatLeavesLoopsMisfittingIsSolvedAgainRobustly) {
  // What llc graph does by default: least squares incrementally, then the kernel switched on
  // and the graph solved again from its start (misfitConstraints reports what least squares left).
  std::vector<Pose2> truth;
  llc::PoseGraph2 clean = randomGraph(22, 60, 40, &truth);
  llc::Esdf reference;
  runGraph(reference, clean, false);
  const double optimum = llc::chiSquared(clean.edges, reference.mean());
  EXPECT_EQ(reference.misfitConstraints(16.27), 0U) << "every true constraint fits at the optimum";
  llc::PoseGraph2 corrupted = clean;
  for (auto [a, b] : std::vector<std::pair<std::size_t, std::size_t>>{{5, 44}, {15, 57}})
    corrupted.edges.push_back({a, b, Pose2{0.5, -1.0, 2.0}, clean.edges.back().information});
  llc::Esdf filter;
  runGraph(filter, corrupted, false);
  EXPECT_GT(llc::chiSquared(clean.edges, filter.mean()), 10.0 * optimum) << "least squares is bent";
  const std::size_t misfits = filter.misfitConstraints(16.27);
  EXPECT_GE(misfits, 1U) << "the wrong loops, or the odometry they bend";
  EXPECT_THROW(filter.setRobustLoopChi2(-1.0), std::invalid_argument);
  EXPECT_THROW(filter.setRobustLoopChi2(std::nan("")), std::invalid_argument);
  filter.setRobustLoopChi2(16.27);
  filter.solveFrom(corrupted.poses);
  EXPECT_NEAR(llc::chiSquared(clean.edges, filter.mean()), optimum, 0.01 * optimum);
  const std::vector<double>& weights = filter.constraintWeights();
  for (std::size_t k = clean.edges.size(); k < weights.size(); ++k) EXPECT_LT(weights[k], 1e-3) << "wrong loop " << k;
  EXPECT_EQ(filter.misfitConstraints(16.27), 2U) << "only the wrong loops misfit now";
  // Hand-worked: one loop 0 -> 1 said to be 1 m from an odometry step of 2 m, both with
  // information 1: least squares splits the difference, each misfits by 0.5 m, chi2 0.25.
  llc::Esdf pair;
  pair.augmentWithInformation(llc::PoseEdge{0, 1, Pose2{2.0, 0.0, 0.0}, Eigen::Matrix3d::Identity()});
  ASSERT_TRUE(pair.updateWithInformation(llc::PoseEdge{0, 1, Pose2{1.0, 0.0, 0.0}, Eigen::Matrix3d::Identity()}, false).applied);
  EXPECT_NEAR(pair.mean()[1].x, 1.5, 1e-9);
  EXPECT_EQ(pair.misfitConstraints(0.24), 2U);
  EXPECT_EQ(pair.misfitConstraints(0.26), 0U);
}

TEST(Esdf, AnInformationBeyondWhatDoublesHoldIsRefusedAndMovesNothing) {
  std::vector<Pose2> truth;
  const llc::PoseGraph2 g = randomGraph(9, 40, 0, &truth);
  llc::Esdf filter;
  for (const llc::PoseEdge& e : g.edges) filter.augmentWithInformation(e);
  filter.marginalCovariance(39);  // factorised
  const std::vector<Pose2> before = filter.mean();
  // Standard deviation 1e-12 (information 1e24): far beyond what doubles hold beside the rest.
  const Eigen::Matrix3d tiny = 1e-24 * Eigen::Matrix3d::Identity();
  for (const bool gate : {false, true}) {
    const llc::EsdfUpdateResult r = filter.update(2, 30, llc::between(truth[2], truth[30]), tiny, gate);
    EXPECT_FALSE(r.applied);
    EXPECT_NE(r.reject_reason.find("above max_information"), std::string::npos) << r.reject_reason;
  }
  for (std::size_t p = 0; p < before.size(); ++p) EXPECT_EQ(filter.mean()[p].x, before[p].x);
  EXPECT_THROW(filter.augment(Pose2{1.0, 0.0, 0.0}, tiny), std::invalid_argument);
  EXPECT_EQ(filter.size(), before.size());
  // One direction too sure is enough (the heading's here), and the limit is an option.
  Eigen::Matrix3d one_tiny = Eigen::Vector3d(0.01, 0.01, 1e-13).asDiagonal();
  EXPECT_FALSE(filter.update(2, 30, llc::between(truth[2], truth[30]), one_tiny, false).applied);
  llc::EsdfOptions looser;
  looser.max_information = 1e14;
  llc::Esdf trusting(Pose2{}, looser);
  for (const llc::PoseEdge& e : g.edges) trusting.augmentWithInformation(e);
  EXPECT_TRUE(trusting.update(2, 30, llc::between(truth[2], truth[30]), one_tiny, false).applied);
  // At the default limit (standard deviation 1e-6) the loop holds the poses where it says.
  const Eigen::Matrix3d sure = 1e-12 * Eigen::Matrix3d::Identity();
  const Pose2 measured = llc::between(truth[2], truth[30]);
  ASSERT_TRUE(filter.update(2, 30, measured, sure, false).applied);
  const Pose2 got = llc::between(filter.mean()[2], filter.mean()[30]);
  EXPECT_NEAR(got.x, measured.x, 1e-5);
  EXPECT_NEAR(got.y, measured.y, 1e-5);
  EXPECT_NEAR(llc::normalizeAngle(got.theta - measured.theta), 0.0, 1e-5);
  EXPECT_GE(filter.marginalCovariance(30).diagonal().minCoeff(), 0.0);
  // With no limit, a solve that fails (information 1e40) takes the constraint back: refused,
  // the means finite and where they were, and the filter still takes the next loop.
  llc::EsdfOptions unlimited;
  unlimited.max_information = 1e300;
  llc::Esdf reckless(Pose2{}, unlimited);
  for (const llc::PoseEdge& e : g.edges) reckless.augmentWithInformation(e);
  reckless.marginalCovariance(39);
  const std::vector<Pose2> settled = reckless.mean();
  const llc::EsdfUpdateResult failed = reckless.update(2, 30, measured, 1e-40 * Eigen::Matrix3d::Identity(), false);
  EXPECT_FALSE(failed.applied);
  EXPECT_NE(failed.reject_reason.find("taken back"), std::string::npos) << failed.reject_reason;
  EXPECT_EQ(reckless.constraints().size(), g.edges.size());
  for (std::size_t p = 0; p < settled.size(); ++p) EXPECT_NEAR(reckless.mean()[p].x, settled[p].x, 1e-9);
  EXPECT_TRUE(reckless.update(2, 30, measured, Eigen::Vector3d(0.01, 0.01, 0.0025).asDiagonal(), true).applied);
  for (const double bad : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    llc::EsdfOptions options;
    options.max_information = bad;
    EXPECT_NE(options.validate().find("max_information"), std::string::npos) << bad;
  }
}

TEST(Esdf, AugmentationIsTheCompositionAndLeavesOtherPosesAlone) {
  llc::Esdf filter(Pose2{1.0, 2.0, 0.5});
  const Eigen::Matrix3d covariance = Eigen::Vector3d(0.01, 0.02, 0.001).asDiagonal();
  filter.augment(Pose2{1.0, 0.0, M_PI / 2}, covariance);
  filter.augment(Pose2{2.0, 0.5, -0.3}, covariance);
  const Pose2 expected = llc::compose(llc::compose(Pose2{1.0, 2.0, 0.5}, Pose2{1.0, 0.0, M_PI / 2}), Pose2{2.0, 0.5, -0.3});
  EXPECT_NEAR(filter.mean()[2].x, expected.x, 1e-12);
  EXPECT_NEAR(filter.mean()[2].y, expected.y, 1e-12);
  EXPECT_NEAR(filter.mean()[2].theta, expected.theta, 1e-12);
  // Uncertainty grows along the chain; the relative pose of 1 and 2 has the odometry's covariance.
  EXPECT_GT(filter.marginalCovariance(2).trace(), filter.marginalCovariance(1).trace());
  Pose2 relative;
  Eigen::Matrix3d relative_covariance;
  filter.relativePose(1, 2, &relative, &relative_covariance);
  EXPECT_NEAR(relative.x, 2.0, 1e-12);
  EXPECT_LT((relative_covariance - covariance).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_THROW(filter.marginalCovariance(3), std::out_of_range);
  EXPECT_THROW(filter.jointCovariance(0, 7), std::out_of_range);
  EXPECT_THROW(filter.relativePose(9, 0, &relative, &relative_covariance), std::out_of_range);
  EXPECT_THROW(filter.innovationChi2(0, 5, relative, covariance), std::out_of_range);
}

TEST(Esdf, PlaceChiSquareOfAHandWorkedPair) {
  // Pose 1 is 3 m ahead and 4 m left of pose 0 with covariance diag(0.5, 2) in pose 0's frame;
  // one place would put it within about 1 m: 3^2 / (0.5 + 1) + 4^2 / (2 + 1) = 6 + 16/3.
  llc::Esdf filter(Pose2{10.0, -5.0, 2.0});
  filter.augment(Pose2{3.0, 4.0, M_PI / 2}, Eigen::Vector3d(0.5, 2.0, 0.01).asDiagonal());
  EXPECT_NEAR(filter.placeChi2(0, 1, 1.0), 6.0 + 16.0 / 3.0, 1e-6);
  // The other way round: pose 0 sits at (-4, 3) in pose 1's frame, and the heading's variance
  // swings that arm: C = R^T diag(0.5, 2) R + 0.01 (3, 4)(3, 4)^T = [2.09 0.12; 0.12 0.66].
  const Eigen::Vector2d t(-4.0, 3.0);
  Eigen::Matrix2d s;
  s << 3.09, 0.12, 0.12, 1.66;
  EXPECT_NEAR(filter.placeChi2(1, 0, 1.0), t.dot(s.inverse() * t), 1e-6);
  // A wider place makes it smaller; a pose is always at its own place.
  EXPECT_LT(filter.placeChi2(0, 1, 3.0), filter.placeChi2(0, 1, 1.0));
  EXPECT_NEAR(filter.placeChi2(1, 1, 1.0), 0.0, 1e-12);
  EXPECT_THROW(filter.placeChi2(0, 2, 1.0), std::out_of_range);
}

TEST(G2o, RoundTripAndOdometryChainStart) {
  llc_test::TempDir dir;
  std::vector<Pose2> truth;
  llc::PoseGraph2 g = randomGraph(3, 10, 5, &truth);
  g.edges[3].information(0, 1) = g.edges[3].information(1, 0) = 2.5;
  llc::writeG2o(g, dir.file("g.g2o"));
  const llc::PoseGraph2 back = llc::readG2o(dir.file("g.g2o"));
  ASSERT_EQ(back.poses.size(), g.poses.size());
  ASSERT_EQ(back.edges.size(), g.edges.size());
  EXPECT_TRUE(back.had_vertices);
  for (std::size_t p = 0; p < g.poses.size(); ++p) EXPECT_EQ(back.poses[p].x, g.poses[p].x);
  for (std::size_t k = 0; k < g.edges.size(); ++k) {
    EXPECT_EQ(back.edges[k].from, g.edges[k].from);
    EXPECT_EQ(back.edges[k].measurement.theta, g.edges[k].measurement.theta);
    EXPECT_EQ(back.edges[k].information, g.edges[k].information);
  }
  EXPECT_DOUBLE_EQ(llc::chiSquared(back.edges, back.poses), llc::chiSquared(g.edges, g.poses));
  // Without vertices: the odometry chain from the origin.
  llc_test::writeText(dir.file("chain.g2o"),
                      "# comment\nEDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\n"
                      "EDGE_SE2 1 2 2 0 0 1 0 0 1 0 1\nEDGE_SE2 2 0 0 3 0 1 0 0 1 0 1\n");
  const llc::PoseGraph2 chain = llc::readG2o(dir.file("chain.g2o"));
  EXPECT_FALSE(chain.had_vertices);
  ASSERT_EQ(chain.poses.size(), 3u);
  EXPECT_NEAR(chain.poses[2].x, 1.0, 1e-12);
  EXPECT_NEAR(chain.poses[2].y, 2.0, 1e-12);
}

TEST(G2o, MalformedLinesAreRefusedWithTheLineNumber) {
  llc_test::TempDir dir;
  auto refused = [&](const std::string& text, const std::string& expected) {
    llc_test::writeText(dir.file("bad.g2o"), text);
    try {
      llc::readG2o(dir.file("bad.g2o"));
      ADD_FAILURE() << "accepted: " << text;
    } catch (const llc::G2oError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  refused("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 zero 0\n", "bad.g2o:2: VERTEX_SE2");
  refused("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n", "bad.g2o:2: EDGE_SE2 needs");
  refused("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 -1\n", "bad.g2o:1: EDGE_SE2 information matrix is not positive definite");
  refused("EDGE_SE2 0 0 1 0 0 1 0 0 1 0 1\n", "two different ids");
  refused("EDGE_SE2 0 1 nan 0 0 1 0 0 1 0 1\n", "bad.g2o:1:");
  refused("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 1 1\n", "vertex 0 twice");
  refused("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 2 0 0 0\n", "without gaps");
  refused("EDGE_SE2 0 2 1 0 0 1 0 0 1 0 1\nEDGE_SE2 2 0 1 0 0 1 0 0 1 0 1\n", "no odometry edge 0 -> 1");
  // Ids beyond what the edges can chain are refused before anything is sized by them (an id
  // of 4e8 once took 12.5 GB, 4e12 std::bad_alloc).
  refused("EDGE_SE2 0 400000000 1 0 0 1 0 0 1 0 1\n", "cannot be whole");
  refused("EDGE_SE2 0 4000000000000 1 0 0 1 0 0 1 0 1\n", "cannot be whole");
  // A number with text after it is not that number.
  refused("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 15xyz\n", "bad.g2o:1: EDGE_SE2: unexpected text 'xyz'");
  refused("VERTEX_SE2 0 0 0 0 extra\n", "bad.g2o:1: VERTEX_SE2: unexpected text 'extra'");
  refused("# nothing\n", "no VERTEX_SE2 or EDGE_SE2");
  EXPECT_THROW(llc::readG2o(dir.file("missing.g2o")), llc::G2oError);
}

TEST(G2o, RealBenchmarkReadsWhenPresent) {
  const std::string path = std::string(LLC_SOURCE_DIR) + "/../shared/data/g2o/intel.g2o";
  if (!std::ifstream(path)) GTEST_SKIP() << path << " absent (../shared/data not here)";
  const llc::PoseGraph2 g = llc::readG2o(path);
  EXPECT_EQ(g.poses.size(), 1728u);
  EXPECT_EQ(g.edges.size(), 2512u);
}

}  // namespace
