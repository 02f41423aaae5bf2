// llc slam: the whole pipeline (the nodelets' classes) on a log or bag at full speed, without
// a master; writes the trajectory, the loops, the map and a report.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

#include <Eigen/Cholesky>

#include "commands.hpp"
#include "input_preparation.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/io/g2o_io.hpp"
#include "laser_loop_closure/core/io/reference_truth.hpp"
#include "laser_loop_closure/core/map/map_picture.hpp"
#include "laser_loop_closure/core/sim/odometry_drift.hpp"
#include "laser_loop_closure/core/slam/odometry_offset.hpp"
#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"
#include "laser_loop_closure/core/slam/reference_check.hpp"
#include "laser_loop_closure/core/slam/slam_evaluation.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"

namespace llc_tool {
namespace {

/// A progress bar on a terminal; a line per tenth otherwise (logs stay short).
class Progress {
 public:
  explicit Progress(std::size_t total, bool enabled) : total_(total), enabled_(enabled), tty_(isatty(2)) {}
  void update(std::size_t done, std::size_t keyframes, std::size_t loops) {
    if (!enabled_ || total_ == 0) return;
    const int percent = int(100 * done / total_);
    if (tty_ ? percent == last_ && done != total_ : percent / 10 == last_ / 10) return;
    last_ = percent;
    std::ostringstream line;
    const int filled = percent * 30 / 100;
    line << "[" << std::string(std::size_t(filled), '#') << std::string(std::size_t(30 - filled), ' ') << "] " << std::setw(3)
         << percent << "% " << done << "/" << total_ << " scans, " << keyframes << " keyframes, " << loops << " loops";
    std::cerr << (tty_ ? "\r" : "") << line.str() << (tty_ && done != total_ ? "" : "\n") << std::flush;
  }

 private:
  std::size_t total_;
  bool enabled_, tty_;
  int last_ = -1;
};

struct TruthCheck {
  bool available = false;
  double slam_rms = 0.0, odometry_rms = 0.0, path_length = 0.0;
  std::size_t true_loop_keyframes = 0, closed = 0, wrong_loops = 0;
  std::size_t true_pairs_not_aligned = 0;  ///< candidates the place gate skipped that were true revisits
  llc::RevisitFates fates;                 ///< where the true revisits not closed were lost
  std::string wrong_loop_lines;            ///< one report line per wrong applied loop
  std::size_t wrong_loops_doubtful = 0;    ///< of the wrong loops, those with an end whose truth is doubtful (--truth)
  std::size_t wrong_loops_contradicted = 0;  ///< of the wrong loops, those with an end whose truth its own scans contradict
  /// Odometry steps and applied loops against the truth: RMS errors, and the mean of
  /// e^T C^-1 e with the covariance C the back end was given (3 when C is honest).
  double step_rms_m = 0.0, step_rms_rad = 0.0, step_nees = 0.0, loop_nees = 0.0;
  /// Per odometry step k (keyframe k-1 -> k): its error against the truth, as x, y, theta.
  std::vector<Eigen::Vector3d> step_errors;
};

/// e = truth^-1 * measured, as x, y, theta.
Eigen::Vector3d relativeError(const llc::Pose2& truth, const llc::Pose2& measured) {
  const llc::Pose2 e = llc::between(truth, measured);
  return {e.x, e.y, e.theta};
}

/// Keyframes with a true revisit (an older keyframe, min_gap keyframes back at least, within
/// positive_distance and, for partial scans, positive_heading), how many of them the pipeline
/// closed, and applied loops that are wrong (off the truth by more than 1 m or 0.1 rad).
TruthCheck checkAgainstTruth(const llc::SlamPipeline& slam, const llc::ScanSequence& sequence,
                             const std::vector<llc::OdometryStep>& steps,
                             const std::vector<llc::LoopClosure>& not_aligned, llc::LoopTruthOptions truth_options,
                             bool has_truth, const llc::ReferenceTruthResult* reference) {
  TruthCheck check;
  if (!has_truth || slam.keyframes().empty()) return check;
  check.available = true;
  const auto& keyframes = slam.keyframes();
  std::vector<llc::Pose2> truth, odometry;
  for (const llc::Keyframe& k : keyframes) {
    truth.push_back(sequence.scans[k.scan_index].truth);
    odometry.push_back(sequence.scans[k.scan_index].odometry);
  }
  check.slam_rms = llc::alignedRmsError(slam.poses(), truth);
  check.odometry_rms = llc::alignedRmsError(odometry, truth);
  for (std::size_t i = 1; i < truth.size(); ++i)
    check.path_length += std::hypot(truth[i].x - truth[i - 1].x, truth[i].y - truth[i - 1].y);
  for (std::size_t k = 1; k < truth.size() && k < steps.size(); ++k) {
    const Eigen::Vector3d e = relativeError(llc::between(truth[k - 1], truth[k]), steps[k].motion);
    check.step_rms_m += e.head<2>().squaredNorm();
    check.step_rms_rad += e(2) * e(2);
    check.step_nees += e.dot(steps[k].covariance.ldlt().solve(e));
    check.step_errors.push_back(e);
  }
  if (truth.size() > 1) {
    const double n = double(truth.size() - 1);
    check.step_rms_m = std::sqrt(check.step_rms_m / n), check.step_rms_rad = std::sqrt(check.step_rms_rad / n);
    check.step_nees /= n;
  }
  truth_options.min_keyframe_gap = slam.options().loops.min_keyframe_gap;
  std::vector<bool> full_circle;
  for (const llc::Keyframe& k : keyframes) full_circle.push_back(k.scan.full_circle);
  const llc::LoopTruthCheck loops = llc::checkLoopsAgainstTruth(truth, full_circle, slam.loops(), truth_options);
  check.true_loop_keyframes = loops.true_loop_keyframes;
  check.closed = loops.closed;
  check.wrong_loops = loops.wrong_loops;
  check.loop_nees = loops.loop_nees;
  check.true_pairs_not_aligned = llc::countTrueRevisitPairs(truth, full_circle, not_aligned, truth_options);
  check.fates = llc::revisitFates(truth, full_circle, slam.loops(), not_aligned, truth_options);
  std::ostringstream wrong;
  wrong << std::setprecision(4);
  for (const llc::LoopRecord& record : slam.loops()) {
    if (!record.applied) continue;
    const llc::Pose2 e = llc::between(llc::between(truth[record.loop.from], truth[record.loop.to]), record.loop.pose);
    const llc::Pose2 d = llc::between(truth[record.loop.from], truth[record.loop.to]);
    if (!(std::hypot(e.x, e.y) > truth_options.wrong_translation || std::abs(e.theta) > truth_options.wrong_rotation)) continue;
    const std::size_t from = keyframes[record.loop.from].scan_index, to = keyframes[record.loop.to].scan_index;
    wrong << "wrong_loop: scans " << from << " -> " << to << " truly " << std::hypot(d.x, d.y) << " m apart, off the truth by "
          << std::hypot(e.x, e.y) << " m " << e.theta * 180.0 / M_PI << " deg, score " << record.loop.score
          << ", inlier share " << record.loop.inlier_share << ", innovation chi2 " << record.innovation_chi2;
    // A carried truth pose may be off by as much as its gap's odometry misses the reference
    // (not known outside the matched scans): doubtful when the ends' possible errors (a turn's
    // over the loop's length too) could make a right loop look this wrong.
    if (reference) {
      const double miss_m = reference->gap_miss_m[from] + reference->gap_miss_m[to];
      const double miss_rad = reference->gap_miss_rad[from] + reference->gap_miss_rad[to];
      const bool unknown = std::isnan(miss_m) || std::isnan(miss_rad);
      if (unknown || (std::hypot(e.x, e.y) <= truth_options.wrong_translation + miss_m + miss_rad * std::hypot(d.x, d.y) &&
                      std::abs(e.theta) <= truth_options.wrong_rotation + miss_rad)) {
        ++check.wrong_loops_doubtful;
        wrong << "; truth doubtful: the ends' carried poses may be off by " << miss_m << " m " << miss_rad * 180.0 / M_PI
              << " deg together";
      }
    }
    // The reference itself may be off at an end (a SLAM-corrected log's glitch): its pose
    // against the keyframes on either side, by their scans.
    bool contradicted = false;
    for (const std::size_t end : {record.loop.from, record.loop.to}) {
      if (contradicted) break;
      // The three nearest keyframes on either side (a glitch spans a few scans: csail's three),
      // as the detector prepared them.
      const llc::LoopDetector& detector = slam.detector();
      std::vector<llc::ReferenceNeighbour> before, after;
      for (std::size_t k = end; k-- > 0 && end - k <= 3;) before.push_back({&detector.prepared(k), truth[k]});
      for (std::size_t k = end + 1; k < keyframes.size() && k - end <= 3; ++k) after.push_back({&detector.prepared(k), truth[k]});
      const llc::ReferenceCheck reference_check =
          llc::checkReferencePose(detector.aligner(), detector.prepared(end), truth[end], before, after);
      if (!reference_check.contradicted) continue;
      contradicted = true;
      ++check.wrong_loops_contradicted;
      wrong << "; truth contradicted by its own scans at scan " << keyframes[end].scan_index
            << ": ICP from it to keyframes on either side turns " << reference_check.before.turn * 180.0 / M_PI << " and "
            << reference_check.after.turn * 180.0 / M_PI << " deg and fits better by " << reference_check.before.fit_gain
            << " and " << reference_check.after.fit_gain;
    }
    wrong << "\n";
  }
  check.wrong_loop_lines = wrong.str();
  return check;
}

/// Each odometry step against the truth (with --evaluate): where a front end loses its way.
void writeStepErrors(const llc::SlamPipeline& slam, const std::vector<llc::OdometryStep>& steps,
                     const TruthCheck& truth, const std::string& path) {
  llc::AtomicTextFile out(path);
  out << "keyframe,scan_index,matched,overlap_share,dx,dy,dtheta,error_x,error_y,error_theta,sigma_x,sigma_y,sigma_theta,"
         "wheel_dx,wheel_dy,wheel_dtheta,ambiguous_shift_m,tracked\n";
  const auto& keyframes = slam.keyframes();
  for (std::size_t k = 1; k <= truth.step_errors.size(); ++k) {
    const llc::OdometryStep& step = steps[k];
    const Eigen::Vector3d& e = truth.step_errors[k - 1];
    const bool wheels = keyframes[k - 1].has_wheel_odometry && keyframes[k].has_wheel_odometry;
    const llc::Pose2 wheel = wheels ? llc::between(keyframes[k - 1].wheel_odometry, keyframes[k].wheel_odometry)
                                    : llc::Pose2{NAN, NAN, NAN};
    out << k << "," << keyframes[k].scan_index << "," << (step.matched ? 1 : 0) << "," << std::setprecision(4)
        << step.overlap_share << "," << step.motion.x << "," << step.motion.y << "," << step.motion.theta << "," << e(0)
        << "," << e(1) << "," << e(2) << "," << std::sqrt(step.covariance(0, 0)) << "," << std::sqrt(step.covariance(1, 1))
        << "," << std::sqrt(step.covariance(2, 2)) << "," << wheel.x << "," << wheel.y << "," << wheel.theta << ","
        << (step.widened_along_ambiguity ? step.ambiguous_shift : 0.0) << "," << (step.tracked ? 1 : 0) << "\n";
  }
  out.commit();
}

/// The truth the run was judged against, one row per scan (llc relations --keyframes truth.csv,
/// scripts/lib/*.py): matched 1 where --truth found the scan in the reference, 0 where its pose
/// was carried by odometry; 1 for every scan when the truth is the input's own (--evaluate, --drift).
void writeTruth(const llc::ScanSequence& sequence, const std::vector<bool>* matched, const std::string& path) {
  llc::AtomicTextFile out(path);
  out << "index,stamp,x,y,theta,matched\n";
  for (std::size_t i = 0; i < sequence.scans.size(); ++i) {
    const llc::LoggedScan& s = sequence.scans[i];
    out << i << "," << std::fixed << std::setprecision(6) << s.stamp << "," << s.truth.x << "," << s.truth.y << ","
        << s.truth.theta << "," << (!matched || (*matched)[i] ? 1 : 0) << "\n";
  }
  out.commit();
}

/// The back end's pose graph as g2o: the optimised keyframe poses and every constraint in the
/// order applied, each with the information it holds now (a robust loop's scaled by its
/// weight), so that llc graph --batch on the file solves the system the run ended with.
void writeFinalGraph(const llc::SlamPipeline& slam, const std::string& path) {
  llc::PoseGraph2 graph;
  graph.poses = slam.poses();
  graph.had_vertices = true;
  const llc::Esdf* esdf = slam.backEnd().esdf();
  graph.edges = esdf->constraints();
  const std::vector<double>& weights = esdf->constraintWeights();
  for (std::size_t i = 0; i < graph.edges.size() && i < weights.size(); ++i) graph.edges[i].information *= weights[i];
  llc::writeG2o(graph, path);
}

void writeOutputs(const llc::SlamPipeline& slam, const llc::OccupancyGridOptions& map_options, const std::string& dir) {
  const auto& keyframes = slam.keyframes();
  const auto& poses = slam.poses();
  llc::AtomicTextFile trajectory(dir + "/trajectory.csv");
  trajectory << "index,stamp,x,y,theta\n" << std::setprecision(10);
  for (std::size_t k = 0; k < keyframes.size(); ++k)
    trajectory << keyframes[k].scan_index << "," << std::fixed << std::setprecision(6) << keyframes[k].stamp << ","
               << poses[k].x << "," << poses[k].y << "," << poses[k].theta << "\n";
  llc::AtomicTextFile loops(dir + "/loops.csv");
  loops << "a,b,accepted,score,inlier_share,x,y,theta,innovation_chi2,by_consensus,refusal,reason\n";
  std::vector<llc::PictureLoop> picture_loops;
  for (const llc::LoopRecord& record : slam.loops()) {
    // Why it was refused, as one quoted CSV field (the stage first: "validation: ...",
    // "context: ...", "backend: ..."); empty when applied.
    std::string reason = record.applied ? "" : record.reject_reason;
    std::replace(reason.begin(), reason.end(), '"', '\'');
    std::replace(reason.begin(), reason.end(), '\n', ' ');
    loops << keyframes[record.loop.from].scan_index << "," << keyframes[record.loop.to].scan_index << ","
          << (record.applied ? 1 : 0) << "," << std::setprecision(4) << record.loop.score << "," << record.loop.inlier_share
          << ",";
    // The aligned pose (b in a's frame) and the gate's chi-square of a loop that reached the
    // back end: what one the gate refused claimed, to weigh it against the map afterwards.
    if (record.loop.accepted)
      loops << std::setprecision(6) << record.loop.pose.x << "," << record.loop.pose.y << "," << record.loop.pose.theta << ","
            << std::setprecision(4) << record.innovation_chi2;
    else
      loops << ",,,";
    loops << "," << (record.by_consensus ? 1 : 0) << "," << llc::loopRefusalName(record.refusal) << ",\"" << reason << "\"\n";
    // Candidates that alignment refused are many and say little in a picture (they are in loops.csv).
    if (record.loop.accepted)
      picture_loops.push_back({record.loop.from, record.loop.to, record.applied, record.by_consensus});
  }
  llc::AtomicTextFile scan_poses(dir + "/scans.csv");
  scan_poses << "scan,stamp,x,y,theta,keyframe\n" << std::fixed << std::setprecision(6);
  for (const llc::ScanPose& s : slam.scanPoses())
    scan_poses << s.scan_index << "," << s.stamp << "," << s.pose.x << "," << s.pose.y << "," << s.pose.theta << ","
          << s.keyframe << "\n";
  trajectory.commit();
  scan_poses.commit();
  loops.commit();
  writeMapFiles(keyframes, poses, picture_loops, map_options, dir);
}

/// report.txt's lines of a bag's odometry time offset estimate (the nodelets' estimate_odometry_time_offset).
std::string timeOffsetProbeLines(const llc::OdometryTimeOffsetProbeResult& r) {
  std::ostringstream lines;
  lines << std::setprecision(4) << "odometry_time_offset=" << r.offset
        << "  (s: each scan's wheels read at its stamp plus this, from scan " << r.decided_at_scan << " on)\n";
  if (!r.decided) {
    lines << "odometry_time_offset_estimate=none (" << r.moving_pairs << " of " << llc::OdometryTimeOffsetProbeOptions{}.pairs
          << " scan pairs in turns or changes of speed: --odometry-time-offset kept)\n";
    return lines.str();
  }
  lines << "odometry_time_offset_estimate=" << (r.estimate.ok ? r.estimate.reason : "none (" + r.estimate.reason + ")") << "\n";
  for (const llc::OdometryOffsetScore& s : r.estimate.scores)
    lines << "odometry_time_offset_tried: offset_s=" << s.offset * r.period << " pairs=" << s.pairs << " matched=" << s.matched
          << " mean_correction_m=" << s.mean_correction_m << " mean_correction_rad=" << s.mean_correction_rad << "\n";
  return lines.str();
}

}  // namespace

int runSlam(const Args& args) {
  if (args.has("lifelong")) {  // one map for months: the run joins the saved map as a fleet's robot would
    if (!args.has("save-session"))
      throw UsageError("--lifelong keeps a map at bounded size: give --save-session S (and --load-session S0 to extend one)");
    if (args.has("continue-odometry")) throw UsageError("--lifelong starts with no pose: --continue-odometry does not apply");
    if (args.has("load-session")) return runMultiRobotSlam(args);
  }
  if (args.all("log").size() + args.all("bag").size() > 1 || args.has("split")) return runMultiRobotSlam(args);
  if (args.has("start-scan")) throw UsageError("--start-scan is for a later day of a drive: --lifelong --load-session S");
  if (args.has("bag") == args.has("log")) throw UsageError("give --bag BAG or --log LOG (several of them: several robots)");
  const std::string input = args.has("bag") ? args.get("bag", "") : args.get("log", "");
  const std::string dir = args.required("out");
  // Every flag and output checked before the run starts, not after it.
  llc::LoopTruthOptions truth_options;
  truth_options.positive_distance = args.number("positive-distance", 1.5);
  truth_options.positive_heading = args.number("positive-heading-deg", 45.0) * M_PI / 180.0;
  if (!(truth_options.positive_distance > 0.0 && truth_options.positive_heading > 0.0))
    throw UsageError("--positive-distance and --positive-heading-deg must be > 0");
  truth_options.wrong_translation = args.number("wrong-loop-m", truth_options.wrong_translation);
  truth_options.wrong_rotation = args.number("wrong-loop-deg", truth_options.wrong_rotation * 180.0 / M_PI) * M_PI / 180.0;
  if (!(truth_options.wrong_translation > 0.0 && truth_options.wrong_rotation > 0.0))
    throw UsageError("--wrong-loop-m and --wrong-loop-deg must be > 0");
  const std::optional<llc::OdometryDrift> drift = odometryDrift(args);
  fixedOdometryOffset(args);  // checked now
  if (args.has("estimate-odometry-time-offset") && !args.has("bag"))
    throw UsageError("--estimate-odometry-time-offset is for a bag (a log's odometry offset: --odometry-offset)");
  args.boolean("estimate-odometry-time-offset", true);  // likewise
  driveReadOptions(input, args);  // likewise
  if (args.has("save-session")) checkOutputFile("save-session", args.get("save-session", ""));
  if (args.has("save-graph")) checkOutputFile("save-graph", args.get("save-graph", ""));
  const std::vector<llc::Relation> relations =
      args.has("relations") ? loadRelationsFile(args.get("relations", "")) : std::vector<llc::Relation>{};
  const llc::SystemOptions options = systemOptions(args);
  llc::ScanSequence reference;  // --truth: another log of the same drive with corrected poses
  if (args.has("truth")) {
    try {
      reference = llc::loadScanSequence(args.get("truth", ""));
    } catch (const std::exception& e) {
      throw ToolError(std::string("--truth: ") + e.what());
    }
  }
  prepareOutputFolder("out", dir);
  const std::string model_path = args.get("model", defaultModelPath());
  llc::ClassifierModel model;
  try {
    model = llc::loadClassifierModel(model_path);
  } catch (const llc::ModelError& e) {
    throw ToolError(e.what());
  }
  // With wheels, the scans the nodelets would get no odometry for are left out as they are
  // there (a bag's first scan before its first odometry message: FR079).
  // A bag's wheels read as the loop_closure nodelet reads them, offset estimated as the scans come.
  std::unique_ptr<llc::OdometryTimeOffsetProbe> time_offset_probe;
  if (args.has("bag") && !args.has("no-wheel-odometry") &&
      args.boolean("estimate-odometry-time-offset", !args.has("odometry-offset")))
    time_offset_probe = std::make_unique<llc::OdometryTimeOffsetProbe>(
        llc::ScanOdometry(options.slam.odometry), llc::ScanAligner(options.slam.aligner), args.number("odometry-time-offset", 0.0));
  llc::ScanSequence sequence = loadSequence(input, args, true, time_offset_probe.get());
  if (args.has("end-scan")) {  // the first part of a drive alone (a map to localise its rest on)
    const long end = args.integer("end-scan", 0);
    if (end < 2) throw UsageError("--end-scan must be 2 or more");
    if (std::size_t(end) < sequence.scans.size()) sequence.scans.resize(std::size_t(end));
  }
  const bool wheels = sequence.has_odometry && !args.has("no-wheel-odometry");
  // Decided before any odometry shift: a log whose true poses are its odometry has no truth
  // (unless its odometry is drifted below: then those poses are the truth).
  const bool has_truth = args.has("evaluate") || args.has("truth") || drift || hasTruthBesideOdometry(sequence);
  const OffsetChoice offset = chooseOdometryOffset(args, sequence, options.slam);
  llc::shiftOdometry(&sequence, offset.offset);
  // After the shift, so that the poses between matched scans are carried by the odometry
  // that belongs to each scan; before any drift, which must not reach the truth.
  std::string reference_lines;
  std::optional<llc::ReferenceTruthResult> reference_truth;
  if (args.has("truth")) {
    try {
      const llc::ReferenceTruthResult& r = reference_truth.emplace(llc::applyReferenceTruth(reference, &sequence));
      std::ostringstream lines;
      lines << "truth_from=" << args.get("truth", "") << "\n"
            << "truth_scans_matched=" << r.matched << "  (the reference's pose of the scan with the same ranges)\n"
            << "truth_scans_carried=" << r.carried << "  (by their odometry from the matched scans on either side)\n"
            << "truth_max_carry_scans=" << r.max_carry_scans << "\n"
            << "truth_stalled_odometry_scans=" << r.stalled_odometry
            << "  (a reading repeated, then a new one within 2 s: interpolated in time to carry the truth by)\n"
            << "truth_scans_ambiguous=" << r.ambiguous << "  (ranges met twice: left unmatched)\n";
      std::size_t doubtful = 0;
      for (std::size_t i = 0; i < r.gap_miss_m.size(); ++i)
        doubtful += !(r.gap_miss_m[i] <= truth_options.wrong_translation / 2 && r.gap_miss_rad[i] <= truth_options.wrong_rotation / 2);
      lines << "truth_scans_doubtful=" << doubtful << "  (carried across a gap whose odometry misses the reference by over half "
            << "the wrong-loop threshold, or before the first or after the last matched scan)\n";
      reference_lines = lines.str();
    } catch (const std::invalid_argument& e) {
      throw ToolError(std::string("--truth: ") + e.what());
    }
  }
  if (drift) {
    try {
      llc::driftOdometry(&sequence, *drift);
    } catch (const std::invalid_argument& e) {
      throw ToolError(e.what());
    }
    std::cout << "odometry_drift: scale_bias=" << drift->scale_bias << " heading_drift=" << drift->heading_drift
              << " noise_translation=" << drift->noise_translation << " noise_rotation=" << drift->noise_rotation
              << " noise_fraction=" << drift->noise_fraction << " seed=" << drift->seed << "\n";
  }

  const auto start = std::chrono::steady_clock::now();
  llc::SlamPipeline slam(model, options.slam);
  const bool restored = args.has("load-session");
  if (restored) {
    const std::string path = args.get("load-session", "");
    try {
      const std::string error = slam.restore(llc::loadSession(path), args.has("continue-odometry"));
      if (!error.empty()) throw ToolError(path + ": not restored: " + error);
    } catch (const llc::SessionError& e) {
      throw ToolError(e.what());
    }
    std::cerr << "restored " << slam.keyframes().size() << " keyframes and " << slam.loops().size() << " loops from "
              << path << (args.has("continue-odometry") ? " (odometry continues)\n" : " (a new chain)\n");
  }
  Progress progress(sequence.scans.size(), !args.has("quiet"));
  const std::size_t loops_before = slam.loops().size();  // a restored session's
  std::size_t first_skip_reported = 0, loosely_linked = 0, wheel_jumps = 0;
  std::map<std::string, std::size_t> odometry_reasons, loop_reasons;
  std::array<std::size_t, llc::kLoopRefusalKinds> refusals{};  // by llc::LoopRefusal
  std::vector<llc::OdometryStep> steps;  // per keyframe (the first one's is empty)
  std::vector<llc::LoopClosure> not_aligned;  // candidates the place gate skipped
  // Reasons without their numbers, so that alike ones are counted together.
  auto general = [](std::string reason) {
    const std::size_t digit = reason.find_first_of("0123456789");
    return digit == std::string::npos ? reason : reason.substr(0, digit) + "...";
  };
  for (std::size_t i = 0; i < sequence.scans.size(); ++i) {
    const llc::LoggedScan& logged = sequence.scans[i];
    const llc::SlamStepResult step = slam.addScan(logged.scan, i, wheels ? &logged.odometry : nullptr);
    if (!step.skip_reason.empty() && first_skip_reported++ == 0)
      std::cerr << "warning: scan " << i << " skipped: " << step.skip_reason << " (later skips are only counted)\n";
    if (step.keyframe) steps.push_back(step.odometry);
    if (!step.time_jump.empty()) std::cerr << "warning: scan " << i << ": " << step.time_jump << "\n";
    if (!step.wheel_jump.empty() && wheel_jumps++ == 0)
      std::cerr << "warning: scan " << i << ": " << step.wheel_jump << " (later ones are only counted)\n";
    if (step.keyframe && !step.back_end_note.empty() && loosely_linked++ == 0)
      std::cerr << "warning: keyframe " << step.keyframe_index << ": " << step.back_end_note << " (later ones are only counted)\n";
    if (step.keyframe && !step.odometry.reject_reason.empty()) ++odometry_reasons[general(step.odometry.reject_reason)];
    for (const llc::LoopClosure& skipped : step.loops.not_aligned) ++refusals[std::size_t(skipped.refusal)];
    not_aligned.insert(not_aligned.end(), step.loops.not_aligned.begin(), step.loops.not_aligned.end());
    progress.update(i + 1, slam.counters().keyframes, slam.counters().loops_accepted);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // This run's loops as they ended.
  for (std::size_t k = loops_before; k < slam.loops().size(); ++k) {
    const llc::LoopRecord& record = slam.loops()[k];
    if (record.applied) continue;
    ++loop_reasons[general(record.reject_reason)];
    ++refusals[std::size_t(record.refusal)];
  }
  writeOutputs(slam, options.map, dir);
  std::string session_lines;  // --lifelong: what pruning the saved session did
  if (args.has("save-session") && args.has("lifelong")) {
    session_lines = saveLifelongSession(slam.session(), options.lifelong, args.get("save-session", ""), dir);
  } else if (args.has("save-session")) {
    try {
      llc::saveSession(slam.session(), args.get("save-session", ""));
    } catch (const llc::SessionError& e) {
      throw ToolError(e.what());
    }
  }

  if (args.has("save-graph")) {
    try {
      writeFinalGraph(slam, args.get("save-graph", ""));
    } catch (const std::exception& e) {
      throw ToolError(e.what());
    }
  }

  const llc::SlamCounters& c = slam.counters();
  const double duration = sequence.scans.back().stamp - sequence.scans.front().stamp;
  // Restored keyframes come from another input: their scan indices do not name this one's.
  const TruthCheck truth = restored ? TruthCheck{} : checkAgainstTruth(slam, sequence, steps, not_aligned, truth_options, has_truth,
                                                                 reference_truth ? &*reference_truth : nullptr);
  if (truth.available) {
    writeStepErrors(slam, steps, truth, dir + "/odometry_steps.csv");
    writeTruth(sequence, reference_truth ? &reference_truth->matched_scans : nullptr, dir + "/truth.csv");
  }
  std::ostringstream report;
  report << std::setprecision(4);
  report << "input=" << input << "\n"
         << "scans=" << c.scans << "\n"
         << "skipped_scans=" << c.skipped_scans << "\n"
         << "keyframes=" << c.keyframes << "\n"
         << "keyframes_loosely_linked=" << loosely_linked << "  (odometry the back end could not use as given)\n"
         << "odometry_offset=" << offset.offset << "\n" << offset.table
         << (time_offset_probe ? timeOffsetProbeLines(time_offset_probe->result()) : std::string())
         << "odometry_steps_matched=" << c.matched_steps << "\n"
         << "odometry_steps_from_wheels=" << c.wheel_steps << "\n"
         << "time_jumps_back=" << c.time_jumps << "  (stamps back by more than restart_after_jump_back: new odometry chains)\n"
         << "wheel_odometry_jumps=" << c.wheel_jumps << "  (moved faster than max_speed: left out)\n"
         << "wheel_odometry_stalled_scans=" << c.stalled_wheel_scans
         << "  (a reading repeated while the laser said the robot moved: placed by the laser alone)\n"
         << "laser_fallback_steps=" << c.laser_fallback_steps
         << "  (placed by the laser: ICP failed from the predicted pose and held from the last scan's)\n"
         << "odometry_steps_realigned=" << c.realigned_steps
         << "  (keyframe steps whose ICP overlapped little, aligned with no guess: odometry/realign_below_overlap)\n"
         << "scans_placed_by_prediction=" << c.scans_placed_by_prediction
         << "  (scans between keyframes disputed with the wheels, placed by ICP from the laser's own prediction)\n"
         << "odometry_steps_ambiguous=" << c.ambiguous_steps
         << "  (laser-only keyframe steps widened along a direction the scans leave open: odometry/ambiguity_score_drop)\n"
         << "scans_counted_by_motion_clock=" << c.scans_counted
         << "  (stamps jittering beyond odometry/max_stamp_jitter: the motion model counted scans instead)\n"
         << "odometry_steps_disputed=" << c.disputed_steps << "  (ICP and wheels disagreed: covariance widened to hold both)\n"
         << "odometry_steps_recovered=" << c.recovered_steps << "  (the wheels doubted, the laser's motion from a correlative search taken)\n"
         << "odometry_steps_tracked=" << c.tracked_steps << "  (ICP from the tracked scans' pose fitted better than from the wheels', or both agreed: track_scans)\n"
         << "pairs_tested=" << c.pairs_classified << "\n"
         << "candidates=" << c.candidates << "\n"
         << "classifier_threshold=" << c.classifier_threshold << "  (K at the end; loops/calibration moves it)\n"
         << "calibration_pairs=" << c.calibration_pairs << "\n"
         << "candidates_not_aligned=" << c.not_aligned << "  (the place gate: the back end says not one place)\n"
         << "aligned=" << c.aligned << "\n"
         << "scans_prepared_again=" << slam.detector().preparedAgain()
         << "  (keyframes aligned after loops/prepared_cache let their prepared scan go; held now: "
         << slam.detector().heldPrepared() << ")\n"
         << "nearby_aligned=" << c.nearby_aligned << "  (of those, keyframes the map put near: loops/nearby_candidates)\n"
         << "nearby_found=" << c.nearby_found << "  (of those, aligned and shape-validated)\n"
         << "context_checked=" << c.context_checked << "  (shape-validated loops checked against the keyframes around them: loops/context)\n"
         << "context_unchecked=" << c.context_unchecked << "  (their context too small to check, e.g. restored keyframes)\n"
         << "loops_refused_by_context=" << c.refused_by_context << "  (shape-validated, then the context fitted better elsewhere)\n"
         << "loops_accepted=" << c.loops_accepted << "\n"
         << "loops_refused_by_alignment=" << c.refused_by_alignment << "\n"
         << "loops_refused_by_gate=" << c.refused_by_gate << "\n"
         << "loops_applied_by_consensus=" << c.applied_by_consensus << "  (of loops_accepted, refused by the gate, then applied with others that agree: consensus/)\n";
  // Every candidate not applied, by the stage that refused it (llc::LoopRefusal's names).
  for (std::size_t kind = 1; kind < refusals.size(); ++kind)
    report << "candidates_refused_" << llc::loopRefusalName(llc::LoopRefusal(kind)) << "=" << refusals[kind] << "\n";
  // Scans skipped and keyframe steps scan matching did not measure, by name (llc::ScanRefusal,
  // llc::OdometryRefusal); the text of each reason is counted at the end of the report.
  for (std::size_t kind = 1; kind < llc::kScanRefusalKinds; ++kind)
    report << "scans_skipped_" << llc::scanRefusalName(llc::ScanRefusal(kind)) << "=" << c.scans_skipped[kind] << "\n";
  for (std::size_t kind = 1; kind < llc::kOdometryRefusalKinds; ++kind)
    report << "odometry_steps_not_matched_" << llc::odometryRefusalName(llc::OdometryRefusal(kind)) << "="
           << c.steps_not_matched[kind] << "\n";
  report << session_lines;
  report << "seconds_odometry=" << c.seconds_odometry << "\n"
         << "seconds_classify=" << c.seconds_classify << "\n"
         << "seconds_align=" << c.seconds_align << "\n"
         << "seconds_context=" << c.seconds_context << "  (of seconds_align, in the context check)\n"
         << "seconds_backend=" << c.seconds_backend << "\n"
         << "input_seconds=" << duration << "\n"
         << "faster_than_real_time=" << (seconds > 0 ? duration / seconds : 0.0) << "\n";
  if (!relations.empty()) {  // --relations: the Kuemmerle et al. metric of the per-scan poses
    std::vector<std::pair<std::size_t, llc::Pose2>> poses;
    for (const llc::ScanPose& s : slam.scanPoses()) poses.emplace_back(s.scan_index, s.pose);
    const llc::RelationErrorResult result = evaluateRunRelations(relations, sequence, poses);
    reportRelations(result, report);
    writeRelationErrors(result, relations, dir + "/relation_errors.csv");
  }
  if (truth.available) {
    report << reference_lines
           << "path_length_m=" << truth.path_length << "\n"
           << "rms_error_m=" << truth.slam_rms << "\n"
           << "rms_error_odometry_m=" << truth.odometry_rms << "\n"
           << "true_loop_keyframes=" << truth.true_loop_keyframes << "\n"
           << "true_loop_keyframes_closed=" << truth.closed << "\n"
           << "wrong_loops_accepted=" << truth.wrong_loops << "\n"
           << "wrong_loops_truth_doubtful=" << truth.wrong_loops_doubtful << "  (of those, ones the --truth poses of their ends, carried by odometry, may be too far off to judge)\n"
           << "wrong_loops_truth_contradicted=" << truth.wrong_loops_contradicted << "  (of those, ones with an end whose truth pose its own scans contradict: ICP from it to one of the 3 keyframes on each side turns over 2.9 deg and fits better by 0.1)\n"
           << "wrong_loop_translation_m=" << truth_options.wrong_translation << "  (an applied loop off the truth by more is wrong)\n"
           << "wrong_loop_rotation_deg=" << truth_options.wrong_rotation * 180.0 / M_PI << "  (or by more than this)\n"
           << "true_pairs_not_aligned=" << truth.true_pairs_not_aligned << "  (candidates the place gate skipped that truly revisit)\n"
           << "open_revisits=" << truth.fates.open << "  (true-revisit keyframes not closed; where their best true candidate stopped:)\n"
           << "open_no_true_candidate=" << truth.fates.no_true_candidate << "\n"
           << "open_place_gate=" << truth.fates.place_gate << "\n"
           << "open_alignment=" << truth.fates.alignment << "\n"
           << "open_back_end_gate=" << truth.fates.back_end_gate << "\n"
           << "open_wrong_pose=" << truth.fates.wrong_pose << "\n"
           << truth.wrong_loop_lines
           << "odometry_step_error_rms_m=" << truth.step_rms_m << "\n"
           << "odometry_step_error_rms_rad=" << truth.step_rms_rad << "\n"
           << "odometry_step_nees=" << truth.step_nees << "  (3 when the step covariance is honest)\n"
           << "loop_nees=" << truth.loop_nees << "  (3 when the loop covariance is honest)\n";
  } else if (restored) {
    report << "ground_truth=not checked (a session was loaded)\n";
  } else {
    report << "ground_truth=none (the input's true poses equal its odometry; --evaluate compares anyway)\n";
  }
  for (const auto& reason : odometry_reasons) report << "odometry_not_matched: " << reason.first << " = " << reason.second << "\n";
  for (const auto& reason : loop_reasons) report << "loop_refused: " << reason.first << " = " << reason.second << "\n";
  report << "seconds=" << seconds << "\n";
  llc::writeFileAtomically(dir + "/report.txt", report.str());
  std::cout << report.str() << "Wrote " << dir << "/{trajectory.csv,loops.csv,map.pgm,map.yaml,map.png,report.txt" << (truth.available ? ",odometry_steps.csv,truth.csv" : "") << "}\n";
  return 0;
}

}  // namespace llc_tool
