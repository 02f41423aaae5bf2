// The Exactly Sparse Delayed-State Filter (Eustice, Singh & Leonard) over planar poses, in
// information form, on SuiteSparse CHOLMOD: every pose is kept (delayed states), odometry
// augments the state, odometry and loop closures are relative-pose updates, so the
// information matrix stays exactly sparse (one 3x3 block per pose and per constraint).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/g2o_io.hpp"
#include "laser_loop_closure/core/se2.hpp"

namespace llc {

struct EsdfOptions {
  /// Relinearise (rebuild the information at the current mean and refactor) when a pose's
  /// mean has moved more than this from where its constraints were linearised ...
  double relinearize_translation = 0.05;  ///< m
  double relinearize_rotation = 0.02;     ///< rad
  int max_relinearizations = 20;          ///< ... at most this many times per update
  /// 3-DoF chi-square threshold of a loop closure's innovation (99.9%: 16.27); larger is refused.
  double loop_chi2_threshold = 16.27;
  double prior_information = 1e8;         ///< anchors the first pose (information per unit)
  std::string validate() const;
};

/// What one update did.
struct EsdfUpdateResult {
  bool applied = false;
  double innovation_chi2 = 0.0;  ///< r^T S^-1 r of the loop closure before it was applied (gated updates)
  int relinearizations = 0;
  std::string reject_reason;     ///< empty when applied
};

class Esdf {
 public:
  /// Starts with one pose at `first`. Throws std::invalid_argument on bad options.
  explicit Esdf(const Pose2& first = Pose2{}, const EsdfOptions& options = {});
  ~Esdf();
  Esdf(const Esdf&) = delete;
  Esdf& operator=(const Esdf&) = delete;

  std::size_t size() const { return mean_.size(); }
  /// Augmentation by the motion model x_n = x_base (+) u (base: the last pose unless given),
  /// u's covariance in the frame of x_base. Returns the new pose's index. Its mean is exact at
  /// once: no other pose moves. Throws std::invalid_argument for a bad base or covariance.
  std::size_t augment(const Pose2& odometry, const Eigen::Matrix3d& covariance);
  std::size_t augmentFrom(std::size_t base, const Pose2& odometry, const Eigen::Matrix3d& covariance);
  /// The same with the odometry's information (g2o edges), e.from the base, e.to == size().
  std::size_t augmentWithInformation(const PoseEdge& edge);
  /// A relative-pose update: pose `to` seen from pose `from` is `measurement` with this
  /// covariance (of the measurement's own x, y, theta, i.e. in the frame of pose `from`). With gate, its innovation is chi-square tested first and refused when
  /// inconsistent (never applied). The mean is current afterwards.
  EsdfUpdateResult update(std::size_t from, std::size_t to, const Pose2& measurement, const Eigen::Matrix3d& covariance,
                          bool gate);
  /// The same with the information of g2o's error e = t2v(Z^-1 (X_from^-1 X_to)), as g2o
  /// files give it (the error lives in the frame of the measured pose).
  EsdfUpdateResult updateWithInformation(const PoseEdge& edge, bool gate, bool solve = true);
  /// Batch use: every mean set to `poses` (one per pose), the system rebuilt there and solved,
  /// relinearising until steady (Gauss-Newton from that start). Returns the relinearisations.
  int solveFrom(const std::vector<Pose2>& poses);

  const std::vector<Pose2>& mean() const { return mean_; }
  /// Marginal covariance of one pose, and the joint covariance of two (6x6, from then to),
  /// by sparse solves with the Cholesky factor (Lambda is never inverted). These and the two
  /// below throw std::out_of_range for a pose the filter does not have.
  Eigen::Matrix3d marginalCovariance(std::size_t pose);
  Eigen::Matrix<double, 6, 6> jointCovariance(std::size_t a, std::size_t b);
  /// Predicted pose of b in a's frame and its covariance (from the joint marginal).
  void relativePose(std::size_t a, std::size_t b, Pose2* mean, Eigen::Matrix3d* covariance);
  /// Could poses a and b be at one place? The squared Mahalanobis distance (2 DoF) of b's
  /// predicted position in a's frame from a's own, when two poses of one place lie about
  /// `radius` (m, one standard deviation per axis) apart: t^T (C_t + radius^2 I)^-1 t, with
  /// t and C_t the translation and its covariance from relativePose. Heading is left out:
  /// a place is recognised whichever way the robot faces.
  double placeChi2(std::size_t a, std::size_t b, double radius);
  /// Squared Mahalanobis distance of the measurement from the prediction, with the
  /// measurement's own covariance added: the chi-square statistic of an update (3 DoF).
  double innovationChi2(std::size_t from, std::size_t to, const Pose2& measurement, const Eigen::Matrix3d& covariance);
  double innovationChi2(const PoseEdge& edge);

  /// Every constraint applied so far (odometry and loops), in order, with its information.
  const std::vector<PoseEdge>& constraints() const { return edges_; }
  int factorizations() const { return factorizations_; }
  int rankUpdates() const { return rank_updates_; }
  int relinearizations() const { return relinearizations_; }

 private:
  struct Impl;
  void addToSystem(const PoseEdge& edge);
  void rebuildSystem();
  void factorAndSolve();
  void solveMean();
  bool rankUpdate(const PoseEdge& edge);
  int relinearizeUntilSteady();
  Eigen::Matrix<double, 6, 6> factoredJointCovariance(std::size_t a, std::size_t b);
  bool leafCovariancesAvailable(std::size_t a, std::size_t b) const;
  Eigen::Matrix<double, 6, 6> leafJointCovariance(std::size_t a, std::size_t b);
  struct LeafState;
  const LeafState& leafState(std::size_t leaf);
  EsdfOptions options_;
  std::vector<Pose2> mean_, linearization_;
  std::vector<PoseEdge> edges_;
  int factorizations_ = 0, relinearizations_ = 0, rank_updates_ = 0;
  std::unique_ptr<Impl> impl_;
};

}  // namespace llc
