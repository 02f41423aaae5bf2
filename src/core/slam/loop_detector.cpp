#include "laser_loop_closure/core/slam/loop_detector.hpp"

#include "laser_loop_closure/core/common/file_util.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <future>
#include <stdexcept>

namespace llc {
namespace {

StrongClassifier withThreshold(const StrongClassifier& classifier, double threshold) {
  StrongClassifier copy = classifier;
  if (threshold > 0.0) copy.setThresholdK(threshold);
  return copy;
}

/// The loop's refusal for the aligner's stage that refused it.
LoopRefusal loopRefusalOf(AlignmentRefusal refusal) {
  switch (refusal) {
    case AlignmentRefusal::kNone: return LoopRefusal::kNone;
    case AlignmentRefusal::kNoStart: return LoopRefusal::kCrfMatch;
    case AlignmentRefusal::kIcp: return LoopRefusal::kIcp;
    case AlignmentRefusal::kValidation: return LoopRefusal::kValidation;
  }
  return LoopRefusal::kOther;
}

}  // namespace

std::string LoopDetectorOptions::validate() const {
  if (max_candidates == 0) return "max_candidates must be >= 1";
  if (checked_candidates != 0 && checked_candidates < max_candidates)
    return "checked_candidates must be 0 or >= max_candidates";
  if (!(score_threshold >= 0.0 && score_threshold <= 1.0)) return "score_threshold must be in [0, 1] (0: the model's K)";
  if (threads == 0) return "threads must be >= 1";
  if (!(translation_sigma > 0.0) || !(rotation_sigma > 0.0)) return "translation_sigma and rotation_sigma must be > 0";
  if (!(nearby_distance > 0.0) || !std::isfinite(nearby_distance)) return "nearby_distance must be > 0 m";
  if (!(nearby_max_std > 0.0) || !std::isfinite(nearby_max_std)) return "nearby_max_std must be > 0 m";
  if (!(nearby_min_predicted_fit >= 0.0 && nearby_min_predicted_fit <= 1.0)) return "nearby_min_predicted_fit must be in [0, 1]";
  const std::string context_error = context.validate();
  if (!context_error.empty()) return "context: " + context_error;
  return calibration.validate();
}

Eigen::Matrix3d poseParameterCovariance(const Pose2& pose, const Eigen::Matrix3d& target_frame_covariance) {
  // exp(d) * pose to first order: (x - d_theta y + d_x, y + d_theta x + d_y, theta + d_theta).
  Eigen::Matrix3d jacobian;
  jacobian << 1.0, 0.0, -pose.y, 0.0, 1.0, pose.x, 0.0, 0.0, 1.0;
  return jacobian * target_frame_covariance * jacobian.transpose();
}

Eigen::Matrix3d loopCovariance(const Pose2& pose, const Eigen::Matrix3d& icp_covariance, const LoopDetectorOptions& options) {
  const Eigen::Vector3d floor(options.translation_sigma * options.translation_sigma,
                              options.translation_sigma * options.translation_sigma,
                              options.rotation_sigma * options.rotation_sigma);
  return poseParameterCovariance(pose, icp_covariance) + Eigen::Matrix3d(floor.asDiagonal());
}

LoopDetector::LoopDetector(const ClassifierModel& model, const ScanAlignerOptions& aligner,
                           const LoopDetectorOptions& options)
    : model_(model),
      classifier_(withThreshold(model.classifier, options.score_threshold)),
      options_(options),
      aligner_(aligner),
      extractor_(model.features),
      store_(model.features.feature_set),
      prepared_(options.prepared_cache),
      calibrator_(options.calibration.validate().empty() ? options.calibration : ThresholdCalibrationOptions{}) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("loop detector options: " + error);
}

void LoopDetector::setModel(const ClassifierModel& model) {
  if (!(model.features == model_.features))
    throw std::invalid_argument("the new model was made with other feature parameters than the stored keyframes");
  model_ = model;
  classifier_ = withThreshold(model.classifier, options_.score_threshold);
  calibrator_.clear();
}

double LoopDetector::pairScore(std::size_t stored, std::size_t query) const {
  if (stored >= store_.size() || query >= store_.size()) throw std::out_of_range("pairScore: no such keyframe");
  const std::vector<double> fq = store_.features(query), fs = store_.features(stored);
  std::vector<double> row(pairFeatureCount(store_.featureSet()));
  pairFeatures(store_.featureSet(), fq.data(), fs.data(), row.data());  // as KeyframeStore::query pairs them
  return classifier_.score(row.data());
}

std::size_t LoopDetector::calibrate(std::size_t index, const std::vector<std::size_t>& surely_elsewhere) {
  if (!options_.calibration.enabled) return 0;
  std::size_t scored = 0;
  for (std::size_t other : surely_elsewhere) {
    calibrator_.add(pairScore(other, index));
    ++scored;
  }
  if (options_.score_threshold == 0.0) classifier_.setThresholdK(calibrator_.threshold(model_.classifier.thresholdK()));
  return scored;
}

void LoopDetector::releasePrepared(std::size_t index) { prepared_.release(index); }

std::size_t LoopDetector::add(const Scan& scan, std::shared_ptr<const PreparedScan> prepared) {
  if (options_.prepared_cache == 0) {
    if (!prepared) prepared = aligner_.prepare(scan);
    return addWithFeatures(extractor_.extract(scan), std::move(prepared));
  }
  return addWithFeatures(extractor_.extract(scan), std::move(prepared), &scan);
}

std::size_t LoopDetector::addWithFeatures(const std::vector<double>& features,
                                          std::shared_ptr<const PreparedScan> prepared, const Scan* scan) {
  if (features.size() != store_.featureCount())
    throw std::invalid_argument("keyframe features: expected " + std::to_string(store_.featureCount()) + " values, got " +
                                std::to_string(features.size()));
  if (!prepared && !scan) throw std::invalid_argument("keyframe without a prepared scan or a scan to prepare");
  store_.add(features.data());
  return prepared_.add(std::move(prepared), scan);
}

LoopClosure LoopDetector::verify(std::size_t from, std::size_t to, double score) const {
  return verifyScan(from, prepared(to), to, score);
}

LoopClosure LoopDetector::verifyScan(std::size_t from, const PreparedScan& scan, std::size_t to, double score,
                                     bool second_thread) const {
  const ScanAlignmentResult alignment = aligner_.align(prepared(from), scan, second_thread);
  LoopClosure loop;
  loop.from = from;
  loop.to = to;
  loop.score = score;
  loop.pose = alignment.pose;
  loop.inlier_share = alignment.validation.inlier_share;
  loop.accepted = alignment.accepted;
  loop.refusal = loopRefusalOf(alignment.refusal);
  loop.reject_reason = alignment.reject_reason;
  loop.seconds = alignment.seconds;
  loop.covariance = loopCovariance(alignment.pose, alignment.covariance, options_);
  return loop;
}

LoopDetectionResult LoopDetector::detectScan(const std::vector<double>& features, const PreparedScan& scan, std::size_t to,
                                             std::size_t max_candidates, double threshold, std::size_t threads,
                                             const CandidateCheck& check) const {
  const auto start = std::chrono::steady_clock::now();
  if (features.size() != store_.featureCount())
    throw std::invalid_argument("detectScan: expected " + std::to_string(store_.featureCount()) + " features, got " +
                                std::to_string(features.size()));
  LoopDetectionResult result;
  result.keyframe = to;
  result.compared = store_.size();
  if (result.compared == 0 || max_candidates == 0) return result;
  const std::vector<LoopCandidate> candidates = store_.query(threshold > 0.0 ? withThreshold(classifier_, threshold) : classifier_,
                                                            features.data(), result.compared, max_candidates, options_.threads);
  result.candidates = candidates.size();
  result.classify_seconds = secondsSince(start);
  std::vector<std::size_t> from;
  std::vector<double> scores;
  for (const LoopCandidate& candidate : candidates) {
    if (check) {
      const auto checking = std::chrono::steady_clock::now();
      const LoopVerdict verdict = check(candidate.keyframe, to);
      result.check_seconds += secondsSince(checking);
      if (verdict.refusal != LoopRefusal::kNone) {
        LoopClosure refused;
        refused.from = candidate.keyframe, refused.to = to, refused.score = candidate.score;
        refused.refusal = verdict.refusal, refused.reject_reason = verdict.reason;
        result.not_aligned.push_back(std::move(refused));
        continue;
      }
    }
    from.push_back(candidate.keyframe);
    scores.push_back(candidate.score);
  }
  result.aligned = verifyScans(from, scan, to, threads, scores);
  result.seconds = secondsSince(start);
  return result;
}

std::vector<LoopClosure> LoopDetector::verifyScans(const std::vector<std::size_t>& from, const PreparedScan& scan,
                                                  std::size_t to, std::size_t threads, const std::vector<double>& scores) const {
  // Keyframe i on thread i % threads; each writes its own slot. With several threads, each
  // alignment stays on its own (its reverse match on a thread of its own would only compete
  // with the other candidates' work: 1e5 keyframes, 20 candidates of a mapped place: 57 -> 33 ms, BM_LocalizationGlobalSearch).
  std::vector<LoopClosure> aligned(from.size());
  const std::size_t workers = std::max<std::size_t>(1, std::min(threads, from.size()));
  auto alignEvery = [&](std::size_t first, std::size_t step) {
    for (std::size_t i = first; i < from.size(); i += step)
      aligned[i] = verifyScan(from[i], scan, to, i < scores.size() ? scores[i] : 0.0, workers == 1);
  };
  std::vector<std::future<void>> others;
  for (std::size_t t = 1; t < workers; ++t) others.push_back(std::async(std::launch::async, alignEvery, t, workers));
  alignEvery(0, workers);
  for (std::future<void>& other : others) other.get();
  return aligned;
}

LoopClosure LoopDetector::verifyFromPrediction(std::size_t from, std::size_t to, double score, const Pose2& predicted) const {
  const auto start = std::chrono::steady_clock::now();
  const PreparedScan& a = prepared(from);
  const PreparedScan& b = prepared(to);
  const IcpResult icp = aligner_.refine(a, b, predicted);
  const double fit = icp.converged ? aligner_.fit(a, b, icp.pose) : 0.0;
  if (fit >= options_.nearby_min_predicted_fit) {  // searched as any candidate
    LoopClosure loop = verify(from, to, score);
    loop.seconds = secondsSince(start);
    return loop;
  }
  LoopClosure loop;
  loop.from = from;
  loop.to = to;
  loop.score = score;
  loop.pose = icp.converged ? icp.pose : predicted;
  char text[128];
  std::snprintf(text, sizeof text, "validation: from the map's pose ICP fits %.3f, below nearby_min_predicted_fit %.3f", fit,
                options_.nearby_min_predicted_fit);
  loop.refusal = LoopRefusal::kValidation;
  loop.reject_reason = text;
  loop.seconds = secondsSince(start);
  return loop;
}

ContextCheckResult LoopDetector::checkContext(LoopClosure& loop, std::size_t before, const KeyframeContext& context) const {
  return checkContextWith(loop, before, context, *this, context);
}

ContextCheckResult LoopDetector::checkContextWith(LoopClosure& loop, std::size_t before, const KeyframeContext& context,
                                                  const LoopDetector& new_store, const KeyframeContext& new_context_of) const {
  auto scans = [&](const LoopDetector& store, const KeyframeContext& of, std::size_t keyframe, std::size_t older_than) {
    std::vector<ContextScan> found;
    for (const ContextKeyframe& k : of(keyframe, older_than, options_.context.distance, options_.context.spacing)) {
      if (!store.hasPrepared(k.keyframe) || !isFinite(k.pose)) continue;
      const PreparedScan& scan = store.prepared(k.keyframe);
      found.push_back({&scan.points, k.pose, &scan.icp_target.normals});
    }
    return found;
  };
  const std::vector<ContextScan> old_context = scans(*this, context, loop.from, before),
                                 new_context = scans(new_store, new_context_of, loop.to, loop.to + 1);
  ContextCheckResult checked =
      checkLoopContext(old_context, new_context, loop.pose, loop.covariance, options_.context, aligner_.options().icp);
  if (!checked.accepted) {
    loop.accepted = false;
    loop.refusal = LoopRefusal::kContext;
    loop.reject_reason = checked.reject_reason;
  }
  return checked;
}

LoopDetectionResult LoopDetector::detect(std::size_t index, const CandidateCheck& check, const NearbyKeyframes& nearby,
                                         const KeyframeContext& context) const {
  const auto start = std::chrono::steady_clock::now();
  if (index >= prepared_.size()) throw std::out_of_range("detect: no keyframe " + std::to_string(index));
  LoopDetectionResult result;
  result.keyframe = index;
  result.compared = index > options_.min_keyframe_gap ? index - options_.min_keyframe_gap : 0;
  if (result.compared == 0) {
    result.seconds = secondsSince(start);
    return result;
  }
  // Checks one candidate and aligns it when let through; true once a loop is found.
  auto tryCandidate = [&](std::size_t keyframe, double score, const Pose2* predicted = nullptr) {
    LoopVerdict verdict;
    if (check) {
      const auto check_start = std::chrono::steady_clock::now();
      verdict = check(keyframe, index);
      result.check_seconds += secondsSince(check_start);
    }
    if (verdict.refused()) {
      LoopClosure skipped;
      skipped.from = keyframe;
      skipped.to = index;
      skipped.score = score;
      skipped.refusal = verdict.refusal;
      skipped.reject_reason = std::move(verdict.reason);
      result.not_aligned.push_back(std::move(skipped));
      return false;
    }
    result.aligned.push_back(predicted && options_.nearby_min_predicted_fit > 0.0
                                 ? verifyFromPrediction(keyframe, index, score, *predicted)
                                 : verify(keyframe, index, score));
    LoopClosure& loop = result.aligned.back();
    if (loop.accepted && context && options_.context.enabled) {
      const auto context_start = std::chrono::steady_clock::now();
      ++(checkContext(loop, result.compared, context).checked ? result.context_checked : result.context_unchecked);
      const double seconds = secondsSince(context_start);  // one clock for the loop's time and the detection's
      loop.seconds += seconds;
      result.context_seconds += seconds;
    }
    return loop.accepted;
  };
  const std::vector<double> query = store_.features(index);
  // Without a check, only max_candidates can ever be aligned: no need to rank more.
  const std::size_t wanted = check ? std::max(options_.checked_candidates, options_.max_candidates) : options_.max_candidates;
  const std::vector<LoopCandidate> candidates =
      store_.query(classifier_, query.data(), result.compared, wanted, options_.threads);
  result.candidates = candidates.size();
  result.classify_seconds = secondsSince(start);
  bool found = false;
  for (const LoopCandidate& candidate : candidates) {
    if (result.aligned.size() == options_.max_candidates) break;
    found = tryCandidate(candidate.keyframe, candidate.score) || found;
    if (found && options_.stop_at_first_accepted) break;
  }
  if (!found && nearby && options_.nearby_candidates > 0) {
    auto seen = [&](std::size_t keyframe) {
      for (const auto* list : {&result.aligned, &result.not_aligned})
        for (const LoopClosure& loop : *list)
          if (loop.from == keyframe) return true;
      return false;
    };
    // A few more than wanted: the check may refuse some, and classifier candidates come back.
    const std::size_t before_nearby = result.aligned.size();
    for (const NearbyKeyframe& near : nearby(index, result.compared, options_.nearby_distance, options_.nearby_max_std,
                                             2 * options_.nearby_candidates + 3)) {
      if (result.nearby == options_.nearby_candidates) break;
      const std::size_t keyframe = near.keyframe;
      if (keyframe >= result.compared || seen(keyframe)) continue;
      const bool accepted = tryCandidate(keyframe, pairScore(keyframe, index), near.has_pose && isFinite(near.pose) ? &near.pose : nullptr);
      result.nearby = result.aligned.size() - before_nearby;
      if (accepted && options_.stop_at_first_accepted) break;
    }
  }
  result.seconds = secondsSince(start);
  return result;
}

}  // namespace llc
