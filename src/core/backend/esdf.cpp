#include "laser_loop_closure/core/backend/esdf.hpp"

#include <suitesparse/cholmod.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/geometry/se2_jacobians.hpp"

namespace llc {

std::string EsdfOptions::validate() const {
  if (!(relinearize_translation > 0.0) || !(relinearize_rotation > 0.0)) return "relinearize thresholds must be > 0";
  if (!(relinearize_chi2 >= 0.0) || !std::isfinite(relinearize_chi2)) return "relinearize_chi2 must be finite and >= 0";
  if (max_edges_relinearized_in_place < 0) return "max_edges_relinearized_in_place must be >= 0";
  if (!(reorder_fill_ratio >= 1.0) || !std::isfinite(reorder_fill_ratio)) return "reorder_fill_ratio must be finite and >= 1";
  if (max_relinearizations < 0) return "max_relinearizations must be >= 0";
  if (!(loop_chi2_threshold > 0.0)) return "loop_chi2_threshold must be > 0";
  if (!(prior_information > 0.0) || !std::isfinite(prior_information)) return "prior_information must be finite and > 0";
  if (!(max_information > 0.0) || !std::isfinite(max_information)) return "max_information must be finite and > 0";
  if (!(robust_loop_chi2 >= 0.0) || !std::isfinite(robust_loop_chi2)) return "robust_loop_chi2 must be finite and >= 0";
  return "";
}

/// A leaf's deviation as d_leaf = propagate d_root + w, cov(w) = noise, with root its first
/// factored ancestor: it depends only on the leaves' own edges, so it is made once per leaf.
struct Esdf::LeafState {
  std::size_t root = 0;
  Eigen::Matrix3d propagate, noise;
};

/// The linear system at the linearisation point, in blocks, and CHOLMOD's factor of it.
/// The information vector is kept in gradient form: b = eta - Lambda * linearisation, so that
/// the solve gives the step from the linearisation point (angles never leave [-pi, pi)).
struct Esdf::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  std::vector<std::map<std::size_t, Eigen::Matrix3d>> upper;  // upper[i][j], j >= i: block of Lambda
  Eigen::VectorXd gradient;                                    // b
  std::size_t blocks = 0, analysed_blocks = 0;
  bool current = false;      // factor and mean match the system
  bool factor_valid = false;  // the factor is that of the system at the current linearisation
  // Poses from leaf_start on were added by augmentation alone to a current system (each hangs
  // off one earlier pose by one edge): their covariances follow from the factor of the poses
  // before by propagation, with no new factorisation. npos: no such run.
  std::size_t leaf_start = std::string::npos;
  std::vector<std::size_t> augmentation_edge;  // per pose: index in edges_ of the edge that added it
  std::vector<LeafState> leaf_states;  // per leaf from leaf_start on, filled as far as asked
  std::size_t leaf_states_start = std::string::npos;  // the leaf_start they were made for
  std::vector<int> inverse_permutation;  // original variable -> row of the factor
  std::size_t factored_nonzeros = 0;     // entries of L when it was last factorised afresh
  /// Entries of L now: rank updates add fill under the ordering chosen before them.
  std::size_t factorNonzeros() const {
    const int* nz = static_cast<const int*>(factor->nz);
    std::size_t sum = 0;
    for (std::size_t j = 0; j < factor->n; ++j) sum += std::size_t(nz[j]);
    return sum;
  }
  Impl() {
    cholmod_start(&common);
    common.supernodal = CHOLMOD_SIMPLICIAL;  // LDL', which cholmod_updown works on
  }
  ~Impl() {
    freeSubsetWorkspace();
    if (factor) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  /// Reused by inverseBlock: a right-hand side, the pattern of its rows, and CHOLMOD's
  /// solution and workspaces (each n long; allocated by the first call, kept while n holds).
  cholmod_dense *subset_b = nullptr, *subset_x = nullptr, *subset_y = nullptr, *subset_e = nullptr;
  cholmod_sparse *subset_bset = nullptr, *subset_xset = nullptr;
  void freeSubsetWorkspace() {
    for (cholmod_dense** d : {&subset_b, &subset_x, &subset_y, &subset_e})
      if (*d) cholmod_free_dense(d, &common);
    for (cholmod_sparse** s : {&subset_bset, &subset_xset})
      if (*s) cholmod_free_sparse(s, &common);
  }
  Eigen::Matrix3d& block(std::size_t i, std::size_t j) {
    auto [it, added] = upper[i].try_emplace(j, Eigen::Matrix3d::Zero());
    blocks += added;
    return it->second;
  }
  /// CHOLMOD's objects, freed when they go out of scope (on every path, throws included).
  struct FreeSparse {
    cholmod_common* common;
    void operator()(cholmod_sparse* a) const { cholmod_free_sparse(&a, common); }
  };
  struct FreeDense {
    cholmod_common* common;
    void operator()(cholmod_dense* a) const { cholmod_free_dense(&a, common); }
  };
  using Sparse = std::unique_ptr<cholmod_sparse, FreeSparse>;
  using Dense = std::unique_ptr<cholmod_dense, FreeDense>;
  /// A CHOLMOD result checked: null, or an error status (not a warning such as not positive
  /// definite, which the callers judge), is a std::runtime_error naming the call.
  template <class T>
  T* checked(T* result, const char* call) {
    if (!result || common.status < CHOLMOD_OK)
      throw std::runtime_error(std::string("esdf: ") + call + " failed (CHOLMOD status " + std::to_string(common.status) + ")");
    return result;
  }
  Sparse sparse(std::size_t rows, std::size_t cols, std::size_t entries, int stype) {
    return Sparse(checked(cholmod_allocate_sparse(rows, cols, entries, 1, 1, stype, CHOLMOD_REAL, &common), "cholmod_allocate_sparse"),
                  FreeSparse{&common});
  }
  /// Solves Lambda X = B for a dense right-hand side.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs) {
    Dense b(checked(cholmod_allocate_dense(rhs.rows(), rhs.cols(), rhs.rows(), CHOLMOD_REAL, &common), "cholmod_allocate_dense"),
            FreeDense{&common});
    Eigen::Map<Eigen::MatrixXd>(static_cast<double*>(b->x), rhs.rows(), rhs.cols()) = rhs;
    Dense x(checked(cholmod_solve(CHOLMOD_A, factor, b.get(), &common), "cholmod_solve"), FreeDense{&common});
    return Eigen::Map<Eigen::MatrixXd>(static_cast<double*>(x->x), rhs.rows(), rhs.cols());
  }
  /// The block of Lambda^-1 on the given variables, exact. Each column is a solve with a
  /// sparse right-hand side (cholmod_solve2 with Bset) that visits only the union of the
  /// factor's elimination-tree paths from the variables to the root: the rows of L \ e_i and of
  /// the back substitution on them depend on nothing else. A dense solve swept the whole factor
  /// per column, a cost that grew with the map for every place check and loop gate.
  Eigen::MatrixXd inverseBlock(const std::vector<int>& variables) {
    const std::size_t n = factor->n, count = variables.size();
    if (!subset_b || subset_b->nrow != n || !subset_bset || subset_bset->nzmax < count) {
      freeSubsetWorkspace();
      subset_b = checked(cholmod_zeros(n, 1, CHOLMOD_REAL, &common), "cholmod_zeros");
      subset_bset = checked(cholmod_allocate_sparse(n, 1, std::max<std::size_t>(count, 6), 0, 1, 0, CHOLMOD_PATTERN, &common),
                            "cholmod_allocate_sparse");
    }
    int* rows = static_cast<int*>(subset_bset->i);
    static_cast<int*>(subset_bset->p)[0] = 0;
    static_cast<int*>(subset_bset->p)[1] = int(count);
    for (std::size_t k = 0; k < count; ++k) rows[k] = variables[k];
    double* b = static_cast<double*>(subset_b->x);
    Eigen::MatrixXd block(count, count);
    for (std::size_t column = 0; column < count; ++column) {
      b[variables[column]] = 1.0;
      const int solved = cholmod_solve2(CHOLMOD_A, factor, subset_b, subset_bset, &subset_x, &subset_xset, &subset_y,
                                        &subset_e, &common);
      b[variables[column]] = 0.0;  // every other entry stays zero for the next column
      if (!solved || common.status < CHOLMOD_OK)
        throw std::runtime_error("esdf: cholmod_solve2 failed (CHOLMOD status " + std::to_string(common.status) + ")");
      const double* x = static_cast<const double*>(subset_x->x);
      for (std::size_t row = 0; row < count; ++row) block(Eigen::Index(row), Eigen::Index(column)) = x[variables[row]];
    }
    return block;
  }
};

Esdf::Esdf(const Pose2& first, const EsdfOptions& options) : options_(options), impl_(std::make_unique<Impl>()) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("esdf options: " + error);
  mean_ = {first};
  linearization_ = {first};
  impl_->upper.resize(1);
  impl_->gradient = Eigen::VectorXd::Zero(3);
  impl_->block(0, 0) += options_.prior_information * Eigen::Matrix3d::Identity();
}

std::size_t Esdf::bytes() const {
  auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t bytes = sizeof(*this) + sizeof(Impl) + held(mean_) + held(linearization_) + held(edges_) + held(edge_points_) +
                      held(largest_information_) + held(weights_) + held(is_loop_) + held(edge_models_) +
                      held(impl_->upper) + held(impl_->augmentation_edge) + held(impl_->leaf_states) +
                      held(impl_->inverse_permutation) + std::size_t(impl_->gradient.size()) * sizeof(double);
  constexpr std::size_t kMapNode = 4 * sizeof(void*) + sizeof(std::pair<const std::size_t, Eigen::Matrix3d>);
  for (const auto& row : impl_->upper) bytes += row.size() * kMapNode;
  if (const cholmod_factor* factor = impl_->factor) {
    // Simplicial LDL': values and row indices per entry; column pointers, counts, links, permutation.
    bytes += factor->nzmax * (sizeof(double) + sizeof(int)) + factor->n * 6 * sizeof(int);
  }
  for (const cholmod_dense* d : {impl_->subset_b, impl_->subset_x, impl_->subset_y, impl_->subset_e})
    if (d) bytes += d->nzmax * sizeof(double);
  for (const cholmod_sparse* s : {impl_->subset_bset, impl_->subset_xset})
    if (s) bytes += s->nzmax * sizeof(int);
  return bytes;
}

Esdf::~Esdf() = default;

Eigen::Vector3d linearizeEdge(const PoseEdge& e, const Pose2& a, const Pose2& b, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb) {
  const Pose2 predicted = between(a, b);
  Eigen::Matrix3d j_outer, j_a, j_b;
  composeJacobians(inverse(e.measurement), predicted, nullptr, &j_outer);
  betweenJacobians(a, b, &j_a, &j_b);
  *ja = j_outer * j_a;
  *jb = j_outer * j_b;
  return toVector(between(e.measurement, predicted));
}

namespace {

/// g2o's information is that of the error e = (-)Z (+) h, which lives in the frame of the
/// measured pose Z; a covariance of Z's own (x, y, theta), as odometry and scan matching give
/// it, is turned into that frame (a rotation by -theta_Z of its x, y part).
Eigen::Matrix3d errorInformation(const Pose2& z, const Eigen::Matrix3d& covariance) {
  Eigen::Matrix3d r;
  composeJacobians(inverse(z), z, nullptr, &r);
  return (r * covariance * r.transpose()).inverse();
}

/// Adds the wall time of its own lifetime to a counter.
class StopWatch {
 public:
  explicit StopWatch(double* total) : total_(total), start_(std::chrono::steady_clock::now()) {}
  ~StopWatch() { *total_ += secondsSince(start_); }
  StopWatch(const StopWatch&) = delete;
  StopWatch& operator=(const StopWatch&) = delete;

 private:
  double* total_;
  std::chrono::steady_clock::time_point start_;
};

/// Why a constraint's measurement and information cannot enter the system; empty when they can.
std::string unusableConstraint(const PoseEdge& e, double max_information) {
  if (!std::isfinite(e.measurement.x + e.measurement.y + e.measurement.theta) || !e.information.allFinite() ||
      e.information.llt().info() != Eigen::Success)
    return "measurement not finite or information not positive definite";
  const double largest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(e.information, Eigen::EigenvaluesOnly).eigenvalues()[2];
  if (largest > max_information) {
    std::ostringstream why;
    why << std::setprecision(3) << "information " << largest << " above max_information " << max_information
        << " (a standard deviation this small cannot be held beside the others)";
    return why.str();
  }
  return "";
}

Pose2 plus(const Pose2& p, const double* step) { return {p.x + step[0], p.y + step[1], normalizeAngle(p.theta + step[2])}; }
}  // namespace

Eigen::Vector3d Esdf::edgeTerms(std::size_t k, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb) const {
  const PoseEdge& e = edges_[k];
  const auto& [at_from, at_to] = edge_points_[k];
  // e(x) ~ r + Ja (x_from - at_from) + Jb (x_to - at_to), and the unknowns are the steps
  // from linearization_: move r there so that every edge speaks of the same steps.
  return linearizeEdge(e, at_from, at_to, ja, jb) + *ja * poseDifference(linearization_[e.from], at_from) +
         *jb * poseDifference(linearization_[e.to], at_to);
}

void Esdf::addToSystem(std::size_t k, double sign) {
  const PoseEdge& e = edges_[k];
  Eigen::Matrix3d ja, jb;
  const Eigen::Vector3d r = edgeTerms(k, &ja, &jb);
  if (sign > 0.0) edge_models_[k] = {r, ja, jb};
  const Eigen::Matrix3d information = weights_[k] * e.information;
  const Eigen::Matrix3d wa = sign * ja.transpose() * information, wb = sign * jb.transpose() * information;
  impl_->block(e.from, e.from) += wa * ja;
  impl_->block(e.to, e.to) += wb * jb;
  if (e.from < e.to) impl_->block(e.from, e.to) += wa * jb;
  else impl_->block(e.to, e.from) += wb * ja;
  impl_->gradient.segment<3>(3 * long(e.from)) -= wa * r;
  impl_->gradient.segment<3>(3 * long(e.to)) -= wb * r;
  impl_->current = false;
}

void Esdf::addEdge(const PoseEdge& edge, const Pose2& from_point, const Pose2& to_point, bool loop) {
  // Largest eigenvalue of the translation block, for linearizationMissBound.
  const Eigen::Matrix2d xy = edge.information.topLeftCorner<2, 2>();
  const double half_trace = 0.5 * xy.trace();
  largest_information_.push_back(half_trace + std::sqrt(std::max(0.0, half_trace * half_trace - xy.determinant())));
  edge_models_.emplace_back();
  edges_.push_back(edge);
  edge_points_.push_back({from_point, to_point});
  is_loop_.push_back(loop);
  weights_.push_back(1.0);
  weights_.back() = robustWeight(edges_.size() - 1);  // scaled from the start when it does not fit
  addToSystem(edges_.size() - 1, 1.0);
}

void Esdf::rebuildSystem(bool edges_removed) {
  impl_->factor_valid = false;
  impl_->leaf_start = std::string::npos;
  if (edges_removed) {
    for (auto& row : impl_->upper) row.clear();
    impl_->blocks = 0;
  } else {
    // The same edges make the same blocks: zeroed where they are (each is summed again from
    // zero in the same order, so the values are the same bits), not freed and allocated again.
    for (auto& row : impl_->upper)
      for (auto& entry : row) entry.second.setZero();
  }
  impl_->gradient.setZero();
  impl_->block(0, 0) += options_.prior_information * Eigen::Matrix3d::Identity();
  // The prior holds pose 0 where it started (mean_ may have moved it by rounding only).
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    edge_points_[k] = {linearization_[edges_[k].from], linearization_[edges_[k].to]};
    addToSystem(k, 1.0);
  }
  // Same blocks as before: the symbolic analysis (ordering, pattern of L) still holds.
}

void Esdf::factorAndSolve() {
  factorize();
  solveMean();
}

void Esdf::factorize() {
  Impl& m = *impl_;
  const StopWatch watch(&timings_.factorizations);
  const std::size_t n = 3 * size();
  // Column-compressed, upper triangle (stype = 1), built straight from the blocks: column c of
  // pose-block j holds, for every block (i, j) with i <= j, rows 3i..3i+2 (only up to the
  // diagonal in the diagonal block). Blocks are kept by row, so gather them per column first.
  std::vector<std::vector<std::pair<std::size_t, const Eigen::Matrix3d*>>> by_column(size());
  std::size_t entries = 0;
  for (std::size_t i = 0; i < m.upper.size(); ++i)
    for (const auto& [j, b] : m.upper[i]) by_column[j].push_back({i, &b}), entries += 9;
  const Impl::Sparse a = m.sparse(n, n, entries, 1);
  auto* cp = static_cast<int*>(a->p);
  auto* ri = static_cast<int*>(a->i);
  auto* rx = static_cast<double*>(a->x);
  std::size_t k = 0;
  for (std::size_t j = 0; j < size(); ++j)
    for (int c = 0; c < 3; ++c) {
      cp[3 * j + std::size_t(c)] = int(k);
      for (const auto& [i, b] : by_column[j])  // rows ascending: blocks by row index, i <= j
        for (int r = 0; r < 3; ++r) {
          if (i == j && r > c) break;
          ri[k] = int(3 * i) + r, rx[k] = (*b)(r, c), ++k;
        }
    }
  cp[n] = int(k);
  if (!m.factor || m.analysed_blocks != m.blocks || m.factor->n != n) {
    if (m.factor) cholmod_free_factor(&m.factor, &m.common);
    m.factor = m.checked(cholmod_analyze(a.get(), &m.common), "cholmod_analyze");
    m.analysed_blocks = m.blocks;
    const int* perm = static_cast<const int*>(m.factor->Perm);
    m.inverse_permutation.assign(n, 0);
    for (std::size_t k = 0; k < n; ++k) m.inverse_permutation[std::size_t(perm[k])] = int(k);
  }
  const int factorized = cholmod_factorize(a.get(), m.factor, &m.common);
  ++factorizations_;
  if (m.common.status == CHOLMOD_NOT_POSDEF) throw std::runtime_error("esdf: information matrix not positive definite");
  if (!factorized || m.common.status < CHOLMOD_OK)
    throw std::runtime_error("esdf: cholmod_factorize failed (CHOLMOD status " + std::to_string(m.common.status) + ")");
  m.factored_nonzeros = m.factorNonzeros();
  m.factor_valid = true;
}

void Esdf::solveMean() {
  const StopWatch watch(&timings_.solves);
  const Eigen::VectorXd step = impl_->solve(impl_->gradient);
  if (!step.allFinite()) throw std::runtime_error("esdf: the solve gave non-finite means");
  for (std::size_t p = 0; p < size(); ++p) mean_[p] = plus(linearization_[p], step.data() + 3 * p);
  impl_->current = true;
  impl_->leaf_start = std::string::npos;
}

bool Esdf::rankUpdate(const std::vector<std::size_t>& edges, bool update) {
  Impl& m = *impl_;
  const std::size_t n = 3 * size();
  if (!m.factor_valid || !m.factor || m.factor->n != n) return false;
  // A constraint adds J^T Omega J = C C^T with C = J^T W, Omega = W W^T (Cholesky): a rank-3
  // update (or, to take it out, downdate) of the factor, its rows in the factor's order. All
  // edges go in one call: CHOLMOD walks their merged paths up to eight columns at a time.
  const Impl::Sparse c = m.sparse(n, 3 * edges.size(), 18 * edges.size(), 0);
  auto* cp = static_cast<int*>(c->p);
  auto* ci = static_cast<int*>(c->i);
  auto* cx = static_cast<double*>(c->x);
  std::array<std::pair<int, double>, 6> column;
  int col = 0;
  for (const std::size_t k : edges) {
    const PoseEdge& e = edges_[k];
    Eigen::Matrix3d ja, jb;
    edgeTerms(k, &ja, &jb);
    const Eigen::LLT<Eigen::Matrix3d> llt(weights_[k] * e.information);
    if (llt.info() != Eigen::Success) return false;
    const Eigen::Matrix3d w = llt.matrixL();
    const Eigen::Matrix3d ca = ja.transpose() * w, cb = jb.transpose() * w;
    for (int j = 0; j < 3; ++j, ++col) {
      for (int r = 0; r < 3; ++r) {
        column[std::size_t(r)] = {m.inverse_permutation[3 * e.from + std::size_t(r)], ca(r, j)};
        column[std::size_t(3 + r)] = {m.inverse_permutation[3 * e.to + std::size_t(r)], cb(r, j)};
      }
      std::sort(column.begin(), column.end());
      cp[col] = 6 * col;
      for (int i = 0; i < 6; ++i) ci[6 * col + i] = column[std::size_t(i)].first, cx[6 * col + i] = column[std::size_t(i)].second;
    }
  }
  cp[col] = 6 * col;
  int ok = 0;
  {
    const StopWatch watch(&timings_.rank_updates);
    ok = cholmod_updown(update ? 1 : 0, c.get(), m.factor, &m.common);
  }
  if (!ok || m.common.status != CHOLMOD_OK) {
    m.factor_valid = false;
    return false;
  }
  rank_updates_ += int(edges.size());
  m.analysed_blocks = 0;  // the update may have changed L's pattern: analyse afresh next time
  return true;
}

std::size_t Esdf::augment(const Pose2& odometry, const Eigen::Matrix3d& covariance) {
  return augmentFrom(size() - 1, odometry, covariance);
}

std::size_t Esdf::augmentFrom(std::size_t base, const Pose2& odometry, const Eigen::Matrix3d& covariance) {
  return augmentWithInformation(PoseEdge{base, size(), odometry, errorInformation(odometry, covariance)});
}

std::size_t Esdf::augmentWithInformation(const PoseEdge& e) {
  if (e.from >= size() || e.to != size()) throw std::invalid_argument("esdf: augmentation must go from an existing pose to a new one");
  if (const std::string why = unusableConstraint(e, options_.max_information); !why.empty())
    throw std::invalid_argument("esdf: odometry " + why);
  if (impl_->current && impl_->factor_valid && impl_->factor && impl_->factor->n == 3 * size()) impl_->leaf_start = size();
  impl_->augmentation_edge.resize(size() + 1, std::string::npos);
  impl_->augmentation_edge[size()] = edges_.size();
  mean_.push_back(compose(mean_[e.from], e.measurement));
  linearization_.push_back(mean_.back());
  impl_->upper.emplace_back();
  impl_->gradient.conservativeResize(3 * long(size()));
  impl_->gradient.tail<3>().setZero();
  addEdge(e, mean_[e.from], mean_.back(), false);
  // Only the new pose is constrained by this edge, and it can satisfy it exactly: every other
  // mean is unchanged and the new one is the composition (so nothing is solved here).
  return e.to;
}

EsdfUpdateResult Esdf::update(std::size_t from, std::size_t to, const Pose2& measurement, const Eigen::Matrix3d& covariance,
                              bool gate) {
  PoseEdge e{from, to, measurement, errorInformation(measurement, covariance)};
  if (!e.information.allFinite()) {
    EsdfUpdateResult r;
    r.refusal = EsdfRefusal::kMalformed;
    r.reject_reason = "measurement covariance is not invertible";
    return r;
  }
  return updateWithInformation(e, gate);
}

EsdfUpdateResult Esdf::updateWithInformation(const PoseEdge& e, bool gate, bool solve) {
  EsdfUpdateResult result;
  if (e.from >= size() || e.to >= size() || e.from == e.to) {
    result.refusal = EsdfRefusal::kMalformed;
    result.reject_reason = "poses " + std::to_string(e.from) + " and " + std::to_string(e.to) + " are not two poses of the filter";
    return result;
  }
  // A NaN here would poison every mean at the next solve, and an information beyond what
  // double precision holds beside the others would scatter them: refuse both instead.
  result.reject_reason = unusableConstraint(e, options_.max_information);
  if (!result.reject_reason.empty()) {
    result.refusal = EsdfRefusal::kMalformed;
    return result;
  }
  if (gate) {
    result.innovation_chi2 = innovationChi2(e);
    if (!(result.innovation_chi2 <= options_.loop_chi2_threshold)) {
      result.refusal = EsdfRefusal::kGate;
      result.reject_reason = "innovation chi2 " + std::to_string(result.innovation_chi2) + " above " +
                             std::to_string(options_.loop_chi2_threshold);
      return result;
    }
  }
  impl_->leaf_start = std::string::npos;  // no longer a run of leaves: the next covariance needs a factor
  const bool factor_was_valid = impl_->factor_valid;
  addEdge(e, mean_[e.from], mean_[e.to], true);  // linearised where the poses are now
  impl_->factor_valid = false;
  result.applied = true;
  if (!solve) return result;
  // The factor is updated in place when it covers every pose (no pose added since it was
  // made); otherwise, or if the update fails, it is made again.
  impl_->factor_valid = factor_was_valid;
  std::vector<Pose2> linearization_before;  // filled by the first rebuild, for a take-back
  try {
    // Reordered (analysed afresh) once the updates' fill has made L much denser than a new
    // ordering would: the solves' cost follows L's size.
    if (rankUpdate({edges_.size() - 1}, true) && double(impl_->factorNonzeros()) <= options_.reorder_fill_ratio * double(impl_->factored_nonzeros)) solveMean();
    else factorAndSolve();
    result.relinearizations = relinearizeUntilSteady(false, &linearization_before);
  } catch (const std::runtime_error& e) {
    takeBackNewestEdge(std::move(linearization_before));
    result.applied = false;
    result.refusal = EsdfRefusal::kUnsolvable;
    result.reject_reason = std::string("the system could not be solved with it (") + e.what() + "): taken back";
  }
  return result;
}

void Esdf::takeBackNewestEdge(std::vector<Pose2> linearization_before) {
  edges_.pop_back();
  edge_points_.pop_back();
  largest_information_.pop_back();
  weights_.pop_back();
  is_loop_.pop_back();
  edge_models_.pop_back();
  // Back to the linearisation point of before the update when a round moved it (to means
  // the failed solve may have made), and the system rebuilt there.
  if (!linearization_before.empty()) linearization_ = std::move(linearization_before);
  rebuildSystem(true);
  factorAndSolve();
}

int Esdf::solveFrom(const std::vector<Pose2>& poses) {
  if (poses.size() != size()) throw std::invalid_argument("esdf: solveFrom needs one pose per filter pose");
  if (!(options_.robust_loop_chi2 > 0.0)) return graduatedSolve(poses, 1.0);
  // Robust loops: two starts of the same robust cost, the lower kept. The kernel at once holds
  // the means near a start that is nearly right (a file's own poses) but near a start far off
  // too (an odometry chain, where every loop misfits); a kernel 100 times as wide, narrowed by
  // tenths, first lets the loops pull the means near, but from a start nearly right it lets
  // wrong loops bend them first.
  int rounds = graduatedSolve(poses, 1.0);
  const std::vector<Pose2> narrow = mean_;
  const double narrow_cost = robustCost();
  rounds += graduatedSolve(poses, 100.0);
  if (robustCost() > narrow_cost) rounds += graduatedSolve(narrow, 1.0);
  return rounds;
}

int Esdf::graduatedSolve(const std::vector<Pose2>& poses, double start_widen) {
  mean_ = poses;
  int rounds = 0;
  for (double widen = start_widen; widen >= 1.0; widen /= 10.0) {
    robust_widen_ = widen;
    for (std::size_t k = 0; k < edges_.size(); ++k) weights_[k] = robustWeight(k);
    linearization_ = mean_;
    rebuildSystem();
    factorAndSolve();
    rounds += relinearizeUntilSteady(true);
  }
  robust_widen_ = 1.0;
  return rounds;
}

void Esdf::setRobustLoopChi2(double w) {
  EsdfOptions options = options_;
  options.robust_loop_chi2 = w;
  if (const std::string error = options.validate(); !error.empty()) throw std::invalid_argument("esdf options: " + error);
  options_ = options;
}

std::size_t Esdf::misfitConstraints(double chi2) const {
  std::size_t count = 0;
  for (std::size_t k = 0; k < edges_.size(); ++k) count += currentChi2(k) > chi2;
  return count;
}

double Esdf::robustCost() const {
  // Dynamic covariance scaling's cost (the switchable constraint's, its switch eliminated):
  // s^2 X + W (1 - s)^2 with s = min(1, 2 W / (W + X)); X itself for odometry.
  const double w = options_.robust_loop_chi2;
  double cost = 0.0;
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    const double chi2 = currentChi2(k);
    const double s = is_loop_[k] && w > 0.0 && chi2 > w ? 2.0 * w / (w + chi2) : 1.0;
    cost += s * s * chi2 + w * (1.0 - s) * (1.0 - s);
  }
  return cost;
}

Eigen::Matrix<double, 6, 6> Esdf::factoredJointCovariance(std::size_t a, std::size_t b) {
  const StopWatch watch(&timings_.solves);
  const int ia = 3 * int(a), ib = 3 * int(b);
  Eigen::Matrix<double, 6, 6> joint;
  if (a == b) {
    const Eigen::Matrix3d own = impl_->inverseBlock({ia, ia + 1, ia + 2});
    joint << own, own, own, own;
  } else {
    joint = impl_->inverseBlock({ia, ia + 1, ia + 2, ib, ib + 1, ib + 2});
  }
  return 0.5 * (joint + joint.transpose());
}

namespace {
constexpr std::size_t kMaxLeafChain = 2000;  // longer runs are factorised instead (and the recursion stays shallow)
}  // namespace

const Esdf::LeafState& Esdf::leafState(std::size_t leaf) {
  Impl& m = *impl_;
  if (m.leaf_states_start != m.leaf_start) m.leaf_states.clear(), m.leaf_states_start = m.leaf_start;
  while (m.leaf_states.size() <= leaf - m.leaf_start) {
    const std::size_t p = m.leaf_start + m.leaf_states.size();
    const PoseEdge& e = edges_[m.augmentation_edge[p]];
    Eigen::Matrix3d jq, jp;
    edgeTerms(m.augmentation_edge[p], &jq, &jp);
    const Eigen::Matrix3d jp_inverse = jp.inverse();
    const Eigen::Matrix3d a = -jp_inverse * jq;
    const Eigen::Matrix3d w = jp_inverse * e.information.inverse() * jp_inverse.transpose();
    LeafState state;
    if (e.from < m.leaf_start) {
      state.root = e.from, state.propagate = a, state.noise = w;
    } else {
      const LeafState& base = m.leaf_states[e.from - m.leaf_start];
      state.root = base.root, state.propagate = a * base.propagate, state.noise = a * base.noise * a.transpose() + w;
    }
    m.leaf_states.push_back(state);
  }
  return m.leaf_states[leaf - m.leaf_start];
}

Eigen::Matrix<double, 6, 6> Esdf::leafJointCovariance(std::size_t a, std::size_t b) {
  const std::size_t m = impl_->leaf_start;
  // The common queries (a stored pose and a leaf; one leaf) in constant time from the states.
  if ((a < m) != (b < m) || (a == b && a >= m)) {
    const bool swapped = a >= m && a != b;
    const std::size_t leaf = swapped ? a : b, other = swapped ? b : a;
    const LeafState state = leafState(leaf);
    const bool same = other == leaf;
    const Eigen::Matrix<double, 6, 6> base = factoredJointCovariance(same ? state.root : other, state.root);
    const Eigen::Matrix3d& p = state.propagate;
    const Eigen::Matrix3d leaf_block = p * base.block<3, 3>(3, 3) * p.transpose() + state.noise;
    const Eigen::Matrix3d other_block = same ? leaf_block : Eigen::Matrix3d(base.block<3, 3>(0, 0));
    const Eigen::Matrix3d cross = same ? leaf_block : Eigen::Matrix3d(base.block<3, 3>(0, 3) * p.transpose());  // (other, leaf)
    Eigen::Matrix<double, 6, 6> joint;
    joint.block<3, 3>(0, 0) = swapped ? leaf_block : other_block;
    joint.block<3, 3>(3, 3) = swapped ? other_block : leaf_block;
    joint.block<3, 3>(0, 3) = swapped ? Eigen::Matrix3d(cross.transpose()) : cross;
    joint.block<3, 3>(3, 0) = joint.block<3, 3>(0, 3).transpose();
    return 0.5 * (joint + joint.transpose());
  }
  auto root = [&](std::size_t p) {
    while (p >= m) p = edges_[impl_->augmentation_edge[p]].from;
    return p;
  };
  const std::size_t ra = root(a), rb = root(b);
  const Eigen::Matrix<double, 6, 6> base = factoredJointCovariance(ra, rb);
  // A leaf p with base q and edge error r ~ r0 + J_q dq + J_p dp (information Omega) is, given
  // q, dp = A dq + w with A = -J_p^-1 J_q and cov(w) = J_p^-1 Omega^-1 J_p^-T: exactly what
  // the factor of the larger system would give, since a leaf changes no other marginal.
  std::map<std::pair<std::size_t, std::size_t>, Eigen::Matrix3d> memo;
  std::function<Eigen::Matrix3d(std::size_t, std::size_t)> block = [&](std::size_t i, std::size_t j) -> Eigen::Matrix3d {
    if (i > j) return block(j, i).transpose();
    if (j < m) {  // both factored: i and j are ra or rb
      const int bi = i == ra ? 0 : 3, bj = j == ra ? 0 : 3;
      return base.block<3, 3>(bi, bj);
    }
    const auto key = std::make_pair(i, j);
    if (const auto found = memo.find(key); found != memo.end()) return found->second;
    const PoseEdge& e = edges_[impl_->augmentation_edge[j]];
    Eigen::Matrix3d jq, jp;
    edgeTerms(impl_->augmentation_edge[j], &jq, &jp);
    const Eigen::Matrix3d jp_inverse = jp.inverse();
    const Eigen::Matrix3d propagate = -jp_inverse * jq;
    Eigen::Matrix3d result;
    if (i == j) result = propagate * block(e.from, e.from) * propagate.transpose() +
                         jp_inverse * e.information.inverse() * jp_inverse.transpose();
    else result = block(i, e.from) * propagate.transpose();
    memo.emplace(key, result);
    return result;
  };
  Eigen::Matrix<double, 6, 6> joint;
  joint.block<3, 3>(0, 0) = block(a, a);
  joint.block<3, 3>(3, 3) = block(b, b);
  joint.block<3, 3>(0, 3) = block(a, b);
  joint.block<3, 3>(3, 0) = joint.block<3, 3>(0, 3).transpose();
  return 0.5 * (joint + joint.transpose());
}

bool Esdf::leafCovariancesAvailable(std::size_t a, std::size_t b) const {
  const Impl& m = *impl_;
  if (m.leaf_start == std::string::npos || !m.factor_valid || !m.factor || m.factor->n != 3 * m.leaf_start) return false;
  auto chain = [&](std::size_t p) {
    std::size_t length = 0;
    while (p >= m.leaf_start && length <= kMaxLeafChain) p = edges_[m.augmentation_edge[p]].from, ++length;
    return length;
  };
  return chain(a) <= kMaxLeafChain && chain(b) <= kMaxLeafChain;
}

Eigen::Matrix<double, 6, 6> Esdf::jointCovariance(std::size_t a, std::size_t b) {
  if (a >= size() || b >= size()) throw std::out_of_range("esdf: no pose " + std::to_string(std::max(a, b)));
  if (!impl_->current && leafCovariancesAvailable(a, b)) return leafJointCovariance(a, b);
  if (!impl_->current) factorAndSolve();
  return factoredJointCovariance(a, b);
}

Eigen::Matrix3d Esdf::marginalCovariance(std::size_t pose) {
  if (pose >= size()) throw std::out_of_range("esdf: no pose " + std::to_string(pose));
  return jointCovariance(pose, pose).topLeftCorner<3, 3>();
}

void Esdf::relativePose(std::size_t a, std::size_t b, Pose2* mean, Eigen::Matrix3d* covariance) {
  const Eigen::Matrix<double, 6, 6> joint = jointCovariance(a, b);
  Eigen::Matrix3d ja, jb;
  betweenJacobians(mean_[a], mean_[b], &ja, &jb);
  Eigen::Matrix<double, 3, 6> j;
  j << ja, jb;
  *mean = between(mean_[a], mean_[b]);
  *covariance = j * joint * j.transpose();
}

double Esdf::placeChi2(std::size_t a, std::size_t b, double radius) {
  Pose2 relative;
  Eigen::Matrix3d covariance;
  relativePose(a, b, &relative, &covariance);
  const Eigen::Vector2d t(relative.x, relative.y);
  const Eigen::Matrix2d s = covariance.topLeftCorner<2, 2>() + radius * radius * Eigen::Matrix2d::Identity();
  return t.dot(s.ldlt().solve(t));
}

double Esdf::innovationChi2(std::size_t from, std::size_t to, const Pose2& measurement, const Eigen::Matrix3d& covariance) {
  return innovationChi2(PoseEdge{from, to, measurement, errorInformation(measurement, covariance)});
}

double Esdf::innovationChi2(const PoseEdge& e) {
  const Eigen::Matrix<double, 6, 6> joint = jointCovariance(e.from, e.to);
  Eigen::Matrix3d ja, jb;
  const Eigen::Vector3d r = linearizeEdge(e, mean_[e.from], mean_[e.to], &ja, &jb);
  Eigen::Matrix<double, 3, 6> j;
  j << ja, jb;
  // Innovation covariance: the poses' joint uncertainty seen through the error, plus the
  // measurement's own (the inverse of its error-space information).
  const Eigen::Matrix3d s = j * joint * j.transpose() + e.information.inverse();
  return r.dot(s.ldlt().solve(r));
}

}  // namespace llc
