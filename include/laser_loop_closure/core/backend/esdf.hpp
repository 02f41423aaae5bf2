// The Exactly Sparse Delayed-State Filter (Eustice, Singh & Leonard) over planar poses, in
// information form, on SuiteSparse CHOLMOD: every pose is kept (delayed states), odometry
// augments the state, odometry and loop closures are relative-pose updates, so the
// information matrix stays exactly sparse (one 3x3 block per pose and per constraint).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/io/g2o_io.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct EsdfOptions {
  /// A constraint is relinearised (its information taken again at the current means) when one
  /// of its poses has moved more than this from where the constraint was linearised ...
  double relinearize_translation = 0.05;  ///< m
  double relinearize_rotation = 0.02;     ///< rad
  /// ... and its linear model misses its true error at the current means by more than this
  /// (squared Mahalanobis distance in the constraint's information; 0: whenever it moved).
  /// A pose graph moved rigidly keeps its linear model, so this spares most relinearisations.
  double relinearize_chi2 = 0.001;
  /// Up to this many constraints are relinearised in place (a rank-3 update and downdate of
  /// the factor each); more, and the whole system is rebuilt at the current means and refactored.
  int max_edges_relinearized_in_place = 32;
  int max_relinearizations = 20;          ///< relinearisation rounds (each then solved) per update
  /// Rank updates add fill to L under the ordering chosen before them; once L has grown past
  /// this many times its size when last factorised, the next update reorders and refactors.
  double reorder_fill_ratio = 1.5;
  /// 3-DoF chi-square threshold of a loop closure's innovation (99.9%: 16.27); larger is refused.
  double loop_chi2_threshold = 16.27;
  double prior_information = 1e8;         ///< anchors the first pose (information per unit)
  /// Largest eigenvalue a constraint's information may have (per m^2 or rad^2; 1e12: a standard
  /// deviation of 1 um or 1 urad). More is refused: beside the others, double precision cannot
  /// hold it (applied, a loop far beyond it scatters the means or fails the factorisation).
  double max_information = 1e12;
  /// Robust loop closures (dynamic covariance scaling, Agarwal et al. 2013): a loop whose error
  /// at the current means has chi2 X above this keeps its information scaled by
  /// (2 W / (W + X))^2, recomputed at every relinearisation round, so a wrong loop that later
  /// loops contradict loses its hold on the map instead of bending it for good. Below W a loop
  /// counts in full (the least-squares optimum is unchanged where every loop fits). Odometry
  /// (augmentation) is never scaled. 0: off.
  double robust_loop_chi2 = 0.0;
  [[nodiscard]] std::string validate() const;
};

/// Why an update was not applied.
enum class EsdfRefusal {
  kNone,        ///< applied
  kMalformed,   ///< not two poses of the filter, or an information it cannot use (not finite, beyond max_information)
  kGate,        ///< the innovation's chi2 above loop_chi2_threshold
  kUnsolvable,  ///< the system could not be solved with it: taken back
};

/// What one update did.
struct [[nodiscard]] EsdfUpdateResult {
  bool applied = false;
  double innovation_chi2 = 0.0;  ///< r^T S^-1 r of the loop closure before it was applied (gated updates)
  int relinearizations = 0;
  EsdfRefusal refusal = EsdfRefusal::kNone;  ///< what decisions read
  std::string reject_reason;     ///< the same for people; empty when applied
};

/// Error of an edge at poses (a, b) in g2o's convention, e = t2v(Z^-1 (a^-1 b)), and its
/// Jacobians with respect to additive steps of a's and b's (x, y, theta).
Eigen::Vector3d linearizeEdge(const PoseEdge& e, const Pose2& a, const Pose2& b, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb);

/// An upper bound, with no trigonometry, of how far the first-order model of a relative-pose
/// error (g2o's t2v(Z^-1 (A^-1 B))) taken at poses (at_from, at_to) misses the true error at
/// (from, to), as a squared Mahalanobis distance in an information whose x, y block has
/// largest eigenvalue largest_information. Used to skip the exact test of most constraints.
double linearizationMissBound(const Pose2& from, const Pose2& to, const Pose2& at_from, const Pose2& at_to,
                              double largest_information);

class Esdf {
 public:
  /// Starts with one pose at `first`. Throws std::invalid_argument on bad options.
  explicit Esdf(const Pose2& first = Pose2{}, const EsdfOptions& options = {});
  ~Esdf();
  Esdf(const Esdf&) = delete;
  Esdf& operator=(const Esdf&) = delete;

  std::size_t size() const { return mean_.size(); }
  /// About the bytes held: poses, edges and their linear models, the system's blocks (as
  /// std::map nodes) and CHOLMOD's factor (its allocated entries).
  std::size_t bytes() const;
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
  /// files give it (the error lives in the frame of the measured pose). A constraint whose
  /// information exceeds max_information is refused; one with which the system cannot be
  /// solved (numerically not positive definite) is taken back and refused.
  EsdfUpdateResult updateWithInformation(const PoseEdge& edge, bool gate, bool solve = true);
  /// Batch use: every mean set to `poses` (one per pose), the system rebuilt there and solved,
  /// rebuilt again while any pose moves past the relinearisation thresholds (Gauss-Newton from
  /// that start; relinearize_chi2 and in-place relinearisation are for updates). Returns the
  /// relinearisations. With robust_loop_chi2, solved from two starts of the kernel (at once,
  /// and graduated from 100 times as wide) and the lower robust cost kept.
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
  /// The scale on each constraint's information now (1 but for robust loops that do not fit:
  /// see robust_loop_chi2), in the order of constraints().
  const std::vector<double>& constraintWeights() const { return weights_; }
  /// The robust cost at the current means: robust_loop_chi2's kernel on loops (chi2 where they
  /// fit), chi2 on odometry; the plain chi2 when robust_loop_chi2 is 0.
  double robustCost() const;
  /// Robust loops from now on (robust_loop_chi2 = w, checked as the options are): the next
  /// solveFrom and relinearisation rounds use the kernel. For a robust re-solve at the end of
  /// a least-squares run that left loops misfitting.
  void setRobustLoopChi2(double w);
  /// Constraints (odometry and loops) whose error at the current means has a chi2 above
  /// `chi2`. A wrong loop that least squares bends the graph to fit shows in the odometry.
  [[nodiscard]] std::size_t misfitConstraints(double chi2) const;
  int factorizations() const { return factorizations_; }
  int rankUpdates() const { return rank_updates_; }
  /// Relinearisation rounds, and how many constraints were relinearised in place by them.
  int relinearizations() const { return relinearizations_; }
  int edgesRelinearizedInPlace() const { return edges_relinearized_in_place_; }
  /// Rounds that rebuilt and refactored the whole system (too many stale constraints, or a
  /// factor that did not cover every pose) instead of swapping constraints in place.
  int rebuilds() const { return rebuilds_; }
  /// Wall time spent so far in CHOLMOD's three kinds of work, to see where an update's time goes.
  struct Timings {
    double rank_updates = 0.0;    ///< s in cholmod_updown (constraints added, relinearised in place)
    double solves = 0.0;          ///< s in solves with the factor (means, covariances)
    double factorizations = 0.0;  ///< s in building, analysing (ordering) and factorising the system afresh
  };
  const Timings& timings() const { return timings_; }

 private:
  struct Impl;
  /// Edge k's residual (shifted to the system's linearisation point) and Jacobians, taken at
  /// the poses where the edge was linearised.
  Eigen::Vector3d edgeTerms(std::size_t k, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb) const;
  /// Adds (sign 1) or removes (sign -1) edge k's information and gradient.
  void addToSystem(std::size_t k, double sign);
  void addEdge(const PoseEdge& edge, const Pose2& from_point, const Pose2& to_point, bool loop);
  /// Removes the newest constraint (its solve failed) and factorises the system without it, at
  /// linearization_before when a relinearisation round had moved the linearisation point.
  void takeBackNewestEdge(std::vector<Pose2> linearization_before);
  /// The system summed afresh from every edge at its linearisation point; `edges_removed`
  /// when an edge has gone since (its blocks go too), else the blocks are reused in place.
  void rebuildSystem(bool edges_removed = false);
  void factorAndSolve();
  void factorize();  ///< builds, analyses when the pattern changed, and factorises the system
  void solveMean();
  /// The edges' information added to (update) or removed from the factor in place.
  bool rankUpdate(const std::vector<std::size_t>& edges, bool update);
  /// How far edge k's linear model misses its error at the current means (squared Mahalanobis).
  double linearizationError(std::size_t k) const;
  /// Edge k's error at the current means, t2v(Z^-1 (A^-1 B)), its angle wrapped.
  Eigen::Vector3d currentError(std::size_t k) const;
  /// Edge k's error at the current means, as a squared Mahalanobis distance in its own
  /// (unscaled) information.
  double currentChi2(std::size_t k) const;
  /// The scale robust_loop_chi2 gives edge k at the current means (1 for odometry).
  double robustWeight(std::size_t k) const;
  /// Robust edges whose weight at the current means has moved from the one in the system.
  std::vector<std::size_t> reweightedEdges() const;
  /// Batch stages from `poses`: the robust kernel start_widen times as wide, narrowed by
  /// tenths to robust_loop_chi2, each stage solved from the last. Returns the rounds.
  int graduatedSolve(const std::vector<Pose2>& poses, double start_widen);

  /// The edges to relinearise now: moved past the thresholds and (tau > 0) missing their
  /// linear model by more than tau. Stops counting past limit.
  std::vector<std::size_t> staleEdges(double tau, std::size_t limit) const;
  bool relinearizeInPlace(const std::vector<std::size_t>& edges);
  /// linearization_before (when given and empty) receives the linearisation point before the
  /// first round that moves it, so that a failed update can be taken back.
  int relinearizeUntilSteady(bool batch = false, std::vector<Pose2>* linearization_before = nullptr);
  Eigen::Matrix<double, 6, 6> factoredJointCovariance(std::size_t a, std::size_t b);
  bool leafCovariancesAvailable(std::size_t a, std::size_t b) const;
  Eigen::Matrix<double, 6, 6> leafJointCovariance(std::size_t a, std::size_t b);
  struct LeafState;
  const LeafState& leafState(std::size_t leaf);
  EsdfOptions options_;
  std::vector<Pose2> mean_, linearization_;
  std::vector<PoseEdge> edges_;
  std::vector<std::pair<Pose2, Pose2>> edge_points_;  ///< per edge: the poses it was linearised at
  std::vector<double> largest_information_;           ///< per edge: largest eigenvalue of its x, y information
  std::vector<double> weights_;                       ///< per edge: the scale on its information in the system
  std::vector<char> is_loop_;                         ///< per edge: a loop (robust_loop_chi2, when > 0, may scale it)
  double robust_widen_ = 1.0;                         ///< the kernel's width over robust_loop_chi2 (batch stages)
  struct EdgeModel {  ///< an edge's linear model in the system: e ~ residual + ja dx_from + jb dx_to
    Eigen::Vector3d residual = Eigen::Vector3d::Zero();
    Eigen::Matrix3d ja = Eigen::Matrix3d::Zero(), jb = Eigen::Matrix3d::Zero();
  };
  std::vector<EdgeModel> edge_models_;
  Timings timings_;
  int factorizations_ = 0, relinearizations_ = 0, rank_updates_ = 0, edges_relinearized_in_place_ = 0, rebuilds_ = 0;
  std::unique_ptr<Impl> impl_;
};

}  // namespace llc
