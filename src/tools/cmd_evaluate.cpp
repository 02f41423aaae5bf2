// llc evaluate: the paper's section V on labelled pairs.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

#include "commands.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/classifier/classifier_training.hpp"
#include "laser_loop_closure/core/classifier/evaluation.hpp"
#include "laser_loop_closure/core/classifier/log_out_evaluation.hpp"
#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/slam/odometry_prior_gate.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/classifier/threshold_calibration.hpp"

namespace llc_tool {
namespace {

/// A CSV output: nothing reaches the disk before its commit(), which checks every byte.
llc::AtomicTextFile openCsv(const std::string& path) {
  llc::AtomicTextFile out(path);
  out << std::setprecision(10);
  return out;
}

/// Pair rows with scan b of every pair turned on the spot by a random angle of 90..180
/// degrees either way (the paper's rotation test). Angles are returned in *angles.
llc::TrainingSet rotatedTrainingSet(const std::vector<PairData>& data,
                                    const llc::FeatureOptions& options, std::uint64_t seed,
                                    std::vector<double>* angles) {
  llc::FeatureExtractor extractor(options);
  llc::Random random(seed ^ 0x5eedULL);
  llc::TrainingSet set;
  set.dimension = llc::pairFeatureCount(options.feature_set);
  std::vector<double> row(set.dimension);
  for (const PairData& item : data)
    for (const llc::LabeledPair& p : item.pairs) {
      const double magnitude = random.uniform(M_PI / 2, M_PI);
      const double angle = random.uniform() < 0.5 ? -magnitude : magnitude;
      angles->push_back(angle);
      const std::vector<double> turned =
          extractor.extract(llc::rotateScan(item.sequence.scans[p.b].scan, angle));
      llc::pairFeatures(options.feature_set, item.features[p.a].data(), turned.data(), row.data());
      set.add(row.data(), p.label);
    }
  return set;
}

/// Whether each pair (in pairTrainingSet order) survives alignment and shape validation.
std::vector<char> validateAll(const std::vector<PairData>& data, const llc::ScanAligner& aligner) {
  std::vector<char> accepted;
  for (const PairData& item : data) {
    PreparedScanCache prepared(aligner, item.sequence);
    for (const llc::LabeledPair& p : item.pairs)
      accepted.push_back(aligner.align(*prepared.get(p.a), *prepared.get(p.b)).accepted);
  }
  return accepted;
}

/// --leave-one-log-out: for each --data item, a model trained (stumps and K, as `llc train`
/// does) on the other items only, scored on it. Per-log rows and means; writes
/// leave_one_log_out.csv and summary.txt.
int runLeaveOneLogOut(const Args& args, const std::vector<PairData>& data, const llc::FeatureOptions& features,
                      const std::string& out_dir, std::chrono::steady_clock::time_point start) {
  if (data.size() < 2) throw UsageError("--leave-one-log-out needs at least two --data items");
  const std::vector<llc::ScanAugmentation> kinds = augmentations(args);
  llc::ClassifierTrainingOptions training;
  training.rounds = int(args.integer("rounds", 50));
  training.folds = int(args.integer("folds", 10));
  training.repeats = int(args.integer("repeats", 1));
  training.seed = std::uint64_t(args.integer("seed", 1));
  training.target_false_alarm = args.number("target-false-alarm", 0.01);
  training.excluded_features = excludedFeatures(args, features);
  const std::string invalid = training.validate();
  if (invalid.size()) throw UsageError(invalid);
  std::vector<llc::TrainingSet> logs;
  std::vector<std::string> names;
  for (const PairData& item : data) {
    logs.push_back(llc::pairTrainingSet(item.features, item.pairs, features.feature_set));
    std::string name = item.log_path.substr(item.log_path.find_last_of('/') + 1);
    for (const char* suffix : {".gz", ".log", ".bag", "-corrected"})
      if (name.size() > std::strlen(suffix) && name.compare(name.size() - std::strlen(suffix), std::string::npos, suffix) == 0)
        name.resize(name.size() - std::strlen(suffix));
    names.push_back(name);
  }
  // --false-alarm-negatives N: N more negatives per log (farther apart than llc pairs' 10 m by
  // the log's true poses), scored only for the realised false-alarm rate.
  const long extra_count = args.integer("false-alarm-negatives", 0);
  if (extra_count < 0) throw UsageError("--false-alarm-negatives must be zero or more");
  std::vector<llc::TrainingSet> extra;
  std::vector<std::vector<llc::LabeledPair>> extra_pairs;
  for (const PairData& item : data) {
    std::vector<llc::Pose2> truth;
    for (const llc::LoggedScan& s : item.sequence.scans) truth.push_back(s.truth);
    const std::vector<llc::LabeledPair> negatives =
        llc::sampleNegativePairs(truth, llc::PairLabelingOptions{}.negative_min_distance, std::size_t(extra_count), training.seed);
    extra.push_back(llc::pairTrainingSet(item.features, negatives, features.feature_set));
    extra_pairs.push_back(negatives);
  }
  // --calibration-pairs N: K fitted again per held-out log on N pairs its own odometry (drifted
  // with --drift*, else as logged) says are surely two places (ThresholdCalibration).
  const long calibration_count = args.integer("calibration-pairs", 0);
  if (calibration_count < 0) throw UsageError("--calibration-pairs must be zero or more");
  llc::SystemOptions system;
  applyParameterFlags(args, &system);  // --loops/calibration/{min_distance,drift_per_metre,max_path}
  // Its target and raise_only as configured (--loops/calibration/target_false_alarm,
  // --loops/calibration/raise_only), or chosen per held-out log without it:
  // --calibration-targets T1,T2,... (nested leave-one-log-out, LogOutCalibration).
  const llc::ThresholdCalibrationOptions calibration = system.slam.loops.calibration;
  if (const std::string invalid = calibration.validate(); !invalid.empty()) throw UsageError(invalid);
  llc::LogOutCalibration log_out_calibration;
  log_out_calibration.target_false_alarm = calibration.target_false_alarm;
  log_out_calibration.raise_only = calibration.raise_only;
  if (args.has("calibration-targets")) {
    std::istringstream list(args.get("calibration-targets", ""));
    for (std::string item; std::getline(list, item, ',');) {
      char* end = nullptr;
      const double target = std::strtod(item.c_str(), &end);
      if (item.empty() || *end != '\0' || !(target > 0.0 && target < 1.0))
        throw UsageError("--calibration-targets: '" + item + "' is not a rate in (0, 1)");
      log_out_calibration.candidate_targets.push_back(target);
    }
    if (calibration_count == 0) throw UsageError("--calibration-targets needs --calibration-pairs N");
    if (data.size() < 3) throw UsageError("--calibration-targets needs at least three --data items (each target is chosen on two or more logs besides the held-out one)");
  }
  const std::optional<llc::OdometryDrift> drift = odometryDrift(args);
  std::vector<llc::TrainingSet> calibration_sets;
  std::ostringstream calibration_purity;  // how many calibration pairs are truly over 10 m apart
  for (const PairData& item : data) {
    if (calibration_count == 0) break;
    std::vector<llc::Pose2> odometry, truth;
    for (const llc::LoggedScan& s : item.sequence.scans) odometry.push_back(s.odometry), truth.push_back(s.truth);
    if (drift) odometry = llc::driftOdometry(odometry, *drift);
    const std::vector<llc::LabeledPair> pairs =
        llc::sampleSurelyDifferentPairs(odometry, calibration, std::size_t(calibration_count), training.seed + 1);
    std::size_t truly_far = 0;
    for (const llc::LabeledPair& p : pairs)
      truly_far += std::hypot(truth[p.b].x - truth[p.a].x, truth[p.b].y - truth[p.a].y) > llc::PairLabelingOptions{}.negative_min_distance;
    calibration_purity << " " << truly_far << "/" << pairs.size();
    calibration_sets.push_back(llc::pairTrainingSet(item.features, pairs, features.feature_set));
  }
  log_out_calibration.pairs = &calibration_sets;
  std::size_t fitted = 0;
  const llc::LogOutAugmentation augmentation = augmentedSets(data, kinds, features);
  const llc::LeaveOneLogOutResult result = llc::leaveOneLogOut(logs, names, [&](const llc::TrainingSet& set,
                                                                                const std::vector<llc::TrainingSet>& companions) {
    // Nested target choice fits n - 1 more models per held-out log.
    const std::size_t models = logs.size() * (log_out_calibration.candidate_targets.empty() ? 1 : logs.size());
    std::cerr << "llc evaluate: model " << ++fitted << " of " << models << " (" << set.size() << " pairs)\n";
    return llc::trainClassifierModel(set, features, training, companions.empty() ? nullptr : &companions).model.classifier;
  }, &extra, calibration_count ? &log_out_calibration : nullptr, augmentation.empty() ? nullptr : &augmentation);
  // --validate: the loop stage held out. Each pair the held-out model's own K lets through
  // (labelled pairs and extra negatives) is aligned and shape-validated, as a robot would;
  // alignment fits nothing, so it needs no holding out itself.
  // With --drift, the last step too: the back end's chi-square gate with the front end's
  // odometry chain (ICP seeded by the drifted wheels) between the two scans as its only prior.
  struct StageCounts {
    std::size_t positives_passed = 0, positives_confirmed = 0, negatives_passed = 0, negatives_accepted = 0;
    std::size_t positives_through_gate = 0, negatives_through_gate = 0;
    std::size_t wrong_poses_through = 0;  ///< through everything, with a pose off the truth (either label)
  };
  std::vector<StageCounts> stage(data.size());
  if (args.has("validate")) {
    const llc::ScanAligner aligner(alignerOptions(args));
    llc::AtomicTextFile stage_csv = openCsv(out_dir + "/loop_stage.csv");  // every pair aligned: what decided it
    stage_csv << "log,a,b,label,extra,score,accepted,inlier_share,seen_through_share,position_std,true_distance_m,"
                 "error_m,error_deg,gate_chi2,through_gate,reject_reason\n";
    const llc::LoopDetectorOptions loop_options;  // the loop covariance's floors, as in mapping
    for (std::size_t i = 0; i < data.size(); ++i) {
      const llc::HeldOutLog& log = result.logs[i];
      PreparedScanCache prepared(aligner, data[i].sequence);
      const std::vector<llc::LoggedScan>& scans = data[i].sequence.scans;
      std::unique_ptr<llc::OdometryPriorGate> gate;
      if (drift) {
        std::vector<llc::Pose2> odometry;
        std::vector<llc::Scan> log_scans;
        for (const llc::LoggedScan& s : scans) odometry.push_back(s.odometry), log_scans.push_back(s.scan);
        gate = std::make_unique<llc::OdometryPriorGate>(llc::OdometryPriorGate::fromFrontEnd(
            log_scans, llc::driftOdometry(odometry, *drift), llc::ScanOdometryOptions{}, aligner.options(), features));
      }
      StageCounts& counts = stage[i];
      auto judge = [&](llc::LabeledPair p, bool extra_pair, double score) {
        if (p.a > p.b) std::swap(p.a, p.b);  // the older scan first, as a loop is
        const llc::ScanAlignmentResult a = aligner.align(*prepared.get(p.a), *prepared.get(p.b));
        const llc::ShapeValidationResult& v = a.validation;
        const llc::Pose2 error = llc::between(llc::between(scans[p.a].truth, scans[p.b].truth), a.pose);
        double chi2 = std::numeric_limits<double>::quiet_NaN();
        bool through = a.accepted;
        if (a.accepted && gate) {
          const llc::Pose2 loop = a.pose;
          chi2 = gate->chi2(p.a, p.b, loop, llc::loopCovariance(loop, a.covariance, loop_options));
          through = !gate->refuses(p.a, p.b, loop, llc::loopCovariance(loop, a.covariance, loop_options));
        }
        stage_csv << log.name << ',' << p.a << ',' << p.b << ',' << p.label << ',' << extra_pair << ',' << score << ','
                  << a.accepted << ',' << v.inlier_share << ',' << v.seen_through_share << ',' << v.position_std << ','
                  << std::hypot(scans[p.b].truth.x - scans[p.a].truth.x, scans[p.b].truth.y - scans[p.a].truth.y) << ','
                  << std::hypot(error.x, error.y) << ',' << std::abs(error.theta) * 180.0 / M_PI << ',' << chi2 << ','
                  << through << ",\"" << a.reject_reason << "\"\n";
        if (p.label == 1) ++counts.positives_passed, counts.positives_confirmed += a.accepted, counts.positives_through_gate += through;
        else ++counts.negatives_passed, counts.negatives_accepted += a.accepted, counts.negatives_through_gate += through;
        // What bends a map is a wrong pose, as llc slam counts wrong loops (1 m or 0.1 rad off).
        if (through && (std::hypot(error.x, error.y) > 1.0 || std::abs(error.theta) > 0.1)) ++counts.wrong_poses_through;
      };
      for (std::size_t r = 0; r < data[i].pairs.size(); ++r)
        if (log.scores[r] >= log.k) judge(data[i].pairs[r], false, log.scores[r]);
      for (std::size_t r = 0; r < extra_pairs[i].size(); ++r)
        if (log.extra_scores[r] >= log.k) judge(extra_pairs[i][r], true, log.extra_scores[r]);
      std::cerr << "llc evaluate: loop stage on " << log.name << " done\n";
    }
    stage_csv.commit();
  }
  llc::AtomicTextFile csv = openCsv(out_dir + "/leave_one_log_out.csv");
  csv << "log,pairs,positives,training_pairs,k,detection_at_k,realised_false_alarm,false_alarm_negatives,detection_at_1pct_fa,"
         "detection_at_0pct_fa,auc,calibration_pairs,calibration_target,calibrated_k,detection_at_calibrated_k,"
         "realised_false_alarm_calibrated\n";
  std::ostringstream s;
  s << std::setprecision(4) << std::fixed;
  s << "leave_one_log_out: logs=" << data.size() << " features=" << llc::toString(features.feature_set)
    << " rounds=" << training.rounds << " k_folds=" << training.folds << " target_false_alarm=" << training.target_false_alarm
    << " seed=" << training.seed << " augment=" << args.get("augment", "none")
    << " exclude_features=" << args.get("exclude-features", "none") << "\n";
  for (std::size_t i = 0; i < result.logs.size(); ++i) {
    const llc::HeldOutLog& log = result.logs[i];
    csv << log.name << ',' << log.pairs << ',' << log.positives << ',' << log.training_pairs << ',' << log.k << ','
        << log.detection_at_k << ',' << log.realised_false_alarm << ',' << log.false_alarm_negatives << ','
        << log.detection_at_1pct << ',' << log.detection_at_0pct << ',' << log.auc << ',' << log.calibration_pairs << ','
        << log.calibration_target << ',' << log.calibrated_k << ',' << log.detection_at_calibrated_k << ',' << log.realised_false_alarm_calibrated << '\n';
    s << "held_out=" << log.name << " pairs=" << log.pairs << " k=" << log.k << " realised_false_alarm=" << log.realised_false_alarm
      << " (of " << log.false_alarm_negatives << " negatives)"
      << " detection_at_k=" << log.detection_at_k << " detection_at_1pct_fa=" << log.detection_at_1pct
      << " detection_at_0pct_fa=" << log.detection_at_0pct << " auc=" << log.auc;
    if (args.has("validate")) {
      const StageCounts& c = stage[i];
      s << " stage_true_confirmed=" << c.positives_confirmed << "/" << log.positives << " (" << c.positives_passed
        << " passed K) stage_false_accepted=" << c.negatives_accepted << "/" << c.negatives_passed << " (of "
        << log.false_alarm_negatives << " negatives)";
      if (drift)
        s << " through_gate_true=" << c.positives_through_gate << " through_gate_false=" << c.negatives_through_gate
          << " through_gate_wrong_pose=" << c.wrong_poses_through;
    }
    if (log.calibration_pairs)
      s << " calibration_pairs=" << log.calibration_pairs << " calibration_target=" << log.calibration_target
        << " calibrated_k=" << log.calibrated_k
        << " realised_false_alarm_calibrated=" << log.realised_false_alarm_calibrated
        << " detection_at_calibrated_k=" << log.detection_at_calibrated_k;
    s << "\n";
  }
  if (args.has("validate")) {
    StageCounts total;
    std::size_t positives = 0;
    for (std::size_t i = 0; i < stage.size(); ++i) {
      total.positives_confirmed += stage[i].positives_confirmed, total.negatives_accepted += stage[i].negatives_accepted;
      total.negatives_passed += stage[i].negatives_passed, positives += result.logs[i].positives;
      total.positives_through_gate += stage[i].positives_through_gate;
      total.negatives_through_gate += stage[i].negatives_through_gate;
      total.wrong_poses_through += stage[i].wrong_poses_through;
    }
    s << "loop_stage_held_out: true_pairs_confirmed=" << total.positives_confirmed << "/" << positives
      << " false_pairs_accepted=" << total.negatives_accepted << " (of " << total.negatives_passed
      << " negatives that passed K)\n";
    if (drift)
      s << "loop_stage_with_gate: true_pairs_through=" << total.positives_through_gate << "/" << positives
        << " false_pairs_through=" << total.negatives_through_gate << " wrong_poses_through=" << total.wrong_poses_through
        << " (the back end's chi2 gate, prior: the front end's odometry chain on the drifted wheels, no loop)\n";
    else
      s << "loop_stage_with_gate: not run (give --drift: the logs' own odometry is their truth)\n";
  }
  if (calibration_count)
    s << "calibration: target_false_alarm="
      << (log_out_calibration.candidate_targets.empty() ? std::to_string(calibration.target_false_alarm)
                                                         : "chosen per held-out log without it (nested)")
      << " raise_only=" << (calibration.raise_only ? "true" : "false") << " min_distance=" << calibration.min_distance << " drift_per_metre=" << calibration.drift_per_metre
      << " max_path=" << calibration.max_path << " odometry=" << (drift ? "drifted" : "as logged")
      << " truly_over_10m_apart=" << calibration_purity.str() << "\nmean_realised_false_alarm_calibrated="
      << result.mean_realised_false_alarm_calibrated << " best=" << result.best_realised_false_alarm_calibrated
      << " worst=" << result.worst_realised_false_alarm_calibrated
      << " mean_detection_at_calibrated_k=" << result.mean_detection_at_calibrated_k << "\n";
  s << "mean_realised_false_alarm=" << result.mean_realised_false_alarm
    << " worst_realised_false_alarm=" << result.worst_realised_false_alarm << " mean_detection_at_k=" << result.mean_detection_at_k
    << "\nmean_detection_at_0pct_fa=" << result.mean_detection_at_0pct << " mean_auc=" << result.mean_auc << "\n";
  s << "seconds=" << std::setprecision(1) << llc::secondsSince(start) << "\n";
  s << std::setprecision(4) << "mean_detection_at_1pct_fa=" << result.mean_detection_at_1pct << "\n";
  csv.commit();
  llc::writeFileAtomically(out_dir + "/summary.txt", s.str());
  std::cout << s.str() << std::flush;
  return 0;
}

}  // namespace

int runEvaluate(const Args& args) {
  const auto start = std::chrono::steady_clock::now();
  const std::string out_dir = args.required("out");
  const llc::FeatureOptions features = featureOptions(args);
  // The flags read late in the run, checked before it starts.
  const int max_rounds = int(args.integer("curve-max-rounds", 1000));
  const int curve_repeats = int(args.integer("curve-repeats", 1));
  if (max_rounds < 1 || curve_repeats < 1) throw UsageError("--curve-max-rounds and --curve-repeats must be >= 1");
  const int ablation_repeats = int(args.integer("ablation-repeats", 1));
  if (ablation_repeats < 1) throw UsageError("--ablation-repeats must be >= 1");
  std::optional<llc::ScanAlignerOptions> aligner_options;
  if (args.has("validate")) aligner_options = alignerOptions(args);
  if ((args.has("augment") || args.has("exclude-features")) && !args.has("leave-one-log-out"))
    throw UsageError("--augment and --exclude-features go with --leave-one-log-out (or llc train)");
  augmentations(args);  // bad lists refused before anything is loaded
  excludedFeatures(args, features);
  prepareOutputFolder("out", out_dir);
  const std::vector<PairData> data = loadPairData(args.all("data"), features, args);
  if (args.has("leave-one-log-out")) return runLeaveOneLogOut(args, data, features, out_dir, start);
  const llc::TrainingSet set = pairTrainingSet(data, features.feature_set);

  llc::CrossValidationOptions cv;
  cv.folds = int(args.integer("folds", 10));
  cv.repeats = int(args.integer("repeats", 10));
  cv.seed = std::uint64_t(args.integer("seed", 1));
  cv.adaboost.rounds = int(args.integer("rounds", 50));
  const std::string invalid = cv.validate();
  if (!invalid.empty()) throw UsageError(invalid);
  std::size_t positives = 0;
  for (int y : set.labels) positives += y == 1;
  std::cout << "pairs=" << set.size() << " positives=" << positives << " negatives=" << set.size() - positives
            << " features=" << set.dimension << " (" << llc::toString(features.feature_set)
            << (features.closed_ring ? ", closed ring" : ", open ring") << ")\n";

  std::vector<double> angles;
  llc::TrainingSet rotated;
  const bool rotation = !args.has("no-rotation");
  if (rotation) rotated = rotatedTrainingSet(data, features, cv.seed, &angles);
  const std::vector<llc::CrossValidationRun> runs =
      llc::crossValidate(set, cv, rotation ? &rotated : nullptr);
  const llc::CrossValidationSummary summary = llc::summarize(runs, set.labels);

  {  // ROC averaged over repeats, and the pooled scores of the first repeat.
    llc::AtomicTextFile roc = openCsv(out_dir + "/roc.csv");
    roc << "false_alarm,detection\n";
    for (std::size_t g = 0; g < summary.roc_false_alarm.size(); ++g)
      roc << summary.roc_false_alarm[g] << ',' << summary.roc_detection[g] << '\n';
    roc.commit();
    llc::AtomicTextFile scores = openCsv(out_dir + "/scores.csv");
    scores << "data,a,b,label,score" << (rotation ? ",rotation_deg,score_rotated" : "") << '\n';
    std::size_t row = 0;
    for (std::size_t d = 0; d < data.size(); ++d)
      for (const llc::LabeledPair& p : data[d].pairs) {
        scores << d << ',' << p.a << ',' << p.b << ',' << p.label << ',' << runs[0].scores[row];
        if (rotation) scores << ',' << angles[row] * 180.0 / M_PI << ',' << runs[0].alternate_scores[row];
        scores << '\n';
        ++row;
      }
    scores.commit();
  }

  // Figure 3: error against T.
  std::vector<llc::ErrorRates> by_rounds;
  if (!args.has("no-curve")) {
    by_rounds = llc::errorByRounds(set, max_rounds, cv.folds, curve_repeats, cv.seed);
    llc::AtomicTextFile curve = openCsv(out_dir + "/error_vs_rounds.csv");
    curve << "rounds,false_alarm,missed_detection,total\n";
    for (std::size_t t = 0; t < by_rounds.size(); ++t)
      curve << t + 1 << ',' << by_rounds[t].false_alarm << ',' << by_rounds[t].missed_detection << ','
            << by_rounds[t].total() << '\n';
    curve.commit();
  }

  // Table I test 1: features in the order AdaBoost picks them, trained on all pairs.
  const llc::AdaBoostResult full = llc::AdaBoostTrainer(cv.adaboost).train(set);
  const std::vector<std::string>& names = llc::pairFeatureNames(features.feature_set);
  {
    llc::AtomicTextFile order = openCsv(out_dir + "/feature_order.csv");
    order << "round,feature,name,polarity,threshold,alpha,cv_total_error\n";
    for (std::size_t t = 0; t < full.rounds.size(); ++t) {
      const llc::Stump& s = full.rounds[t].stump;
      order << t + 1 << ',' << s.feature + 1 << ',' << names[std::size_t(s.feature)] << ',' << s.polarity << ','
            << s.threshold << ',' << s.alpha << ',';
      if (t < by_rounds.size()) order << by_rounds[t].total();
      order << '\n';
    }
    order.commit();
  }

  // Table I test 2: remove one feature at a time and retrain.
  if (!args.has("no-ablation")) {
    llc::CrossValidationOptions ablation = cv;
    ablation.repeats = ablation_repeats;
    const llc::ErrorRates all = llc::summarize(llc::crossValidate(set, ablation), set.labels, 2).at_half;
    const std::vector<llc::ErrorRates> without = llc::errorWithoutEachFeature(set, ablation);
    llc::AtomicTextFile removal = openCsv(out_dir + "/feature_removal.csv");
    removal << "feature,name,false_alarm,missed_detection,total,increase\n";
    removal << "0,none," << all.false_alarm << ',' << all.missed_detection << ',' << all.total() << ",0\n";
    for (std::size_t f = 0; f < without.size(); ++f)
      removal << f + 1 << ',' << names[f] << ',' << without[f].false_alarm << ','
              << without[f].missed_detection << ',' << without[f].total() << ','
              << without[f].total() - all.total() << '\n';
    removal.commit();
  }

  // Rotation test at the operating point K (1% false alarm) and at K = 0.5.
  double kept_at_k = 0.0, kept_at_half = 0.0;
  if (rotation) {
    std::size_t same_k = 0, same_half = 0, total = 0;
    for (const llc::CrossValidationRun& run : runs)
      for (std::size_t i = 0; i < run.scores.size(); ++i, ++total) {
        same_k += (run.scores[i] >= summary.k_at_1pct) == (run.alternate_scores[i] >= summary.k_at_1pct);
        same_half += (run.scores[i] >= 0.5) == (run.alternate_scores[i] >= 0.5);
      }
    kept_at_k = double(same_k) / double(total);
    kept_at_half = double(same_half) / double(total);
  }

  // The paper's Figure 5 (dashed): a pair is a loop only if the classifier calls it a match
  // and its scans align and pass shape validation; a refused pair scores -1, below every K.
  std::ostringstream validated_text;
  if (args.has("validate")) {
    const llc::ScanAligner aligner(*aligner_options);
    llc::AtomicTextFile stage_csv = openCsv(out_dir + "/loop_stage.csv");  // every pair aligned: what decided it
    stage_csv << "log,a,b,label,extra,score,accepted,inlier_share,seen_through_share,position_std,true_distance_m,reject_reason\n";
    const std::vector<char> accepted = validateAll(data, aligner);
    std::vector<llc::CrossValidationRun> validated = runs;
    std::size_t negatives_called = 0, negatives_refused = 0;
    for (llc::CrossValidationRun& run : validated)
      for (std::size_t i = 0; i < run.scores.size(); ++i) {
        if (set.labels[i] == 0 && run.scores[i] >= summary.k_at_1pct) ++negatives_called, negatives_refused += !accepted[i];
        if (!accepted[i]) run.scores[i] = -1.0;
      }
    const llc::CrossValidationSummary v = llc::summarize(validated, set.labels);
    llc::AtomicTextFile roc = openCsv(out_dir + "/roc_validated.csv");
    roc << "false_alarm,detection\n";
    for (std::size_t g = 0; g < v.roc_false_alarm.size(); ++g) roc << v.roc_false_alarm[g] << ',' << v.roc_detection[g] << '\n';
    roc.commit();
    std::size_t positives_refused = 0, negatives_refused_all = 0;
    for (std::size_t i = 0; i < accepted.size(); ++i)
      (set.labels[i] == 1 ? positives_refused : negatives_refused_all) += !accepted[i];
    validated_text << std::setprecision(4) << std::fixed << "validation: positives_refused=" << positives_refused
                   << " negatives_refused=" << negatives_refused_all << " of " << positives << " and "
                   << set.size() - positives << "\n"
                   << "validation_refused_negatives_above_k_1pct=" << negatives_refused << "/" << negatives_called << "\n"
                   << "validated_detection_at_1pct_fa=" << v.detection_at_1pct << "\nvalidated_auc=" << v.auc << "\n";
  }

  std::ostringstream s;
  s << std::setprecision(4) << std::fixed;
  s << "folds=" << cv.folds << " repeats=" << cv.repeats << " rounds=" << cv.adaboost.rounds
    << " seed=" << cv.seed << "\n";
  s << "detection_at_1pct_fa_std=" << summary.detection_at_1pct_std << " auc_std=" << summary.auc_std << "\n";
  s << "error_at_k_0.5: false_alarm=" << summary.at_half.false_alarm
    << " missed_detection=" << summary.at_half.missed_detection << " total=" << summary.at_half.total() << "\n";
  s << "k_at_1pct_fa=" << summary.k_at_1pct << "\n";
  s << "detection_at_0pct_fa=" << summary.detection_at_0pct << "\n";
  if (rotation)
    s << "rotation_test: pairs=" << set.size() * runs.size() << " kept_class_at_k_1pct=" << kept_at_k
      << " kept_class_at_k_0.5=" << kept_at_half << "\n";
  s << validated_text.str();
  s << "seconds=" << std::setprecision(1) << llc::secondsSince(start) << "\n";
  s << std::setprecision(4) << "detection_at_1pct_fa=" << summary.detection_at_1pct << "\nauc=" << summary.auc << "\n";
  llc::writeFileAtomically(out_dir + "/summary.txt", s.str());
  // Plots, when the plotting helper is known (scripts/llc sets LLC_PLOTTER); it reads the
  // files written above, so it runs before the summary goes out (whose last two lines are
  // the headline numbers).
  if (const char* plotter = std::getenv("LLC_PLOTTER"); plotter && *plotter) {
    const std::string command = std::string(plotter) + " '" + out_dir + "' >&2";
    if (std::system(command.c_str()) != 0) std::cerr << "llc evaluate: warning: plotting failed\n";
  }
  std::cout << s.str() << std::flush;
  return 0;
}

}  // namespace llc_tool
