// llc localize: a log or bag localised on a saved session with no initial pose (the
// Localizer, as localize.launch runs it); writes each scan's pose and state and a report.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>

#include "commands.hpp"
#include "input_preparation.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/core/sim/kidnap.hpp"
#include "laser_loop_closure/core/sim/odometry_drift.hpp"
#include "laser_loop_closure/core/slam/localization_evaluation.hpp"
#include "laser_loop_closure/core/slam/localizer.hpp"
#include "laser_loop_closure/core/slam/odometry_offset.hpp"
#include "laser_loop_closure/core/slam/reference_check.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"

namespace llc_tool {
namespace {

/// The map frame laid onto the truth's: each session keyframe's true pose from REF (the
/// recording the session was mapped from: its scan of the keyframe's index, same stamp).
struct MapTruth {
  llc::MapWithTruth frame;  ///< the keyframes found in REF: map poses, true poses, truth_from_map
  double rms_m = 0.0;       ///< of the map's keyframes after that alignment
  std::size_t matched = 0;  ///< keyframes found in REF
};

/// The same scan (a session keeps its keyframes' scans as read): ranges equal to 1 mm.
bool sameRanges(const llc::Scan& a, const llc::Scan& b) {
  if (a.ranges.size() != b.ranges.size()) return false;
  for (std::size_t i = 0; i < a.ranges.size(); ++i) {
    const double x = a.ranges[i], y = b.ranges[i];
    if (std::isfinite(x) != std::isfinite(y) || (std::isfinite(x) && std::abs(x - y) > 1e-3)) return false;
  }
  return true;
}

MapTruth mapTruth(const llc::SlamSession& session, const llc::ScanSequence& reference) {
  std::vector<llc::Pose2> map, truth;
  for (std::size_t k = 0; k < session.keyframes.size(); ++k) {
    const llc::Keyframe& keyframe = session.keyframes[k];
    if (keyframe.scan_index >= reference.scans.size()) continue;
    const llc::LoggedScan& scan = reference.scans[keyframe.scan_index];
    if (std::abs(scan.stamp - keyframe.stamp) > 1e-3 || !sameRanges(scan.scan, keyframe.scan)) continue;
    map.push_back(session.poses[k]);
    truth.push_back(scan.truth);
  }
  if (map.size() < 3)
    throw ToolError("--truth: only " + std::to_string(map.size()) + " of the session's " +
                    std::to_string(session.keyframes.size()) +
                    " keyframes have a scan of the same index, stamp and ranges in it (give the recording the session was mapped from)");
  MapTruth result;
  result.matched = map.size();
  result.rms_m = llc::alignedRmsError(map, truth, &result.frame.truth_from_map);
  result.frame.poses = map;
  result.frame.truth = truth;
  return result;
}

llc::ClassifierModel loadModel(const Args& args) {
  try {
    return llc::loadClassifierModel(args.get("model", defaultModelPath()));
  } catch (const llc::ModelError& e) {
    throw ToolError(e.what());
  }
}

/// One localisation from a start scan.
struct Run {
  std::string rows;    ///< poses.csv
  std::string events;  ///< report lines: each fix and loss
  std::string searches;  ///< search.csv: each keyframe classified against the whole map
  std::string candidates;  ///< candidates.csv: each candidate those searches aligned
  std::vector<llc::LocalizedScan> scored;
  double compute = 0.0;
  long first_fix_scan = -1;
  double first_fix_compute = -1.0, first_fix_travel = -1.0;
  double kidnap_lost_seconds = -1.0;  ///< s from the kidnap to being reported lost (-1: never)
  std::size_t kidnap_lost_row = 0;    ///< index into scored of that scan
};

/// Feeds scans first .. end-1 (stopping once `max_travel` m past the start when > 0).
Run localize(llc::Localizer& localizer, const llc::ScanSequence& sequence, const std::vector<std::size_t>& input_index,
             std::size_t first, std::size_t end, bool wheels, std::size_t kidnap_row, double max_travel, bool rows,
             const MapTruth* truth = nullptr) {
  Run run;
  std::ostringstream csv, events, searches, candidates;
  candidates << std::setprecision(6) << "scan,map_keyframe,score,accepted,inlier_share,x,y,theta,error_m,error_deg,why_not\n";
  csv << std::setprecision(10) << "scan,stamp,x,y,theta,state\n";
  searches << std::setprecision(5) << "scan,path_m,candidates,loops,agreeing_keyframes,rival_keyframes,joined,recent_fit,why_not\n";
  std::size_t lost_lines = 0;
  for (std::size_t i = first; i < end; ++i) {
    const llc::LoggedScan& logged = sequence.scans[i];
    const llc::LocalizationStep step = localizer.addScan(logged.scan, wheels ? &logged.odometry : nullptr);
    run.compute += step.seconds;
    if (step.fixed) {
      if (run.first_fix_scan < 0)
        run.first_fix_scan = long(input_index[i]), run.first_fix_compute = run.compute, run.first_fix_travel = localizer.pathLength();
      events << "fix: scan " << input_index[i] << " after " << localizer.pathLength() << " m of path\n";
    }
    if (step.searched && rows)
      searches << input_index[i] << "," << localizer.pathLength() << "," << step.candidates << "," << step.loops_to_map << ","
               << step.join.keyframes << "," << step.join.rival_keyframes << "," << step.join.joined << "," << step.fit << ",\""
               << step.join.why_not << "\"\n";
    if (step.searched && rows)
      for (const llc::LoopClosure& c : step.search_results) {
        // Where this candidate puts the keyframe in the map, and (with --truth) how far that is
        // from where the map has the place.
        const llc::Pose2 placed = llc::compose(localizer.mapPoses().at(c.from), c.pose);
        const llc::Pose2 error = truth ? llc::between(llc::whereTheMapHasIt(truth->frame, logged.truth), placed) : llc::Pose2{};
        const double nan = std::numeric_limits<double>::quiet_NaN();
        candidates << input_index[i] << "," << c.from << "," << c.score << "," << c.accepted << "," << c.inlier_share << ","
                   << placed.x << "," << placed.y << "," << placed.theta << "," << (truth ? std::hypot(error.x, error.y) : nan)
                   << "," << (truth ? std::abs(error.theta) * 180.0 / M_PI : nan) << ",\"" << c.reject_reason << "\"\n";
      }
    if (step.lost) {
      if (lost_lines++ < 100) events << "lost: scan " << input_index[i] << ": " << step.why_lost << "\n";
      if (i >= kidnap_row && run.kidnap_lost_seconds < 0.0) {
        run.kidnap_lost_seconds = logged.stamp - sequence.scans[kidnap_row].stamp;
        run.kidnap_lost_row = run.scored.size();
      }
    }
    if (rows) {
      csv << input_index[i] << "," << std::fixed << std::setprecision(6) << logged.stamp << std::defaultfloat << std::setprecision(10) << ",";
      if (step.has_pose) csv << step.pose.x << "," << step.pose.y << "," << step.pose.theta;
      else csv << "nan,nan,nan";
      csv << "," << llc::localizationStateName(step.state) << "\n";
    }
    run.scored.push_back({step.has_pose, step.fixed, step.pose, logged.truth});
    if (max_travel > 0.0 && localizer.pathLength() > max_travel) break;
  }
  run.rows = csv.str();
  run.events = events.str();
  run.searches = searches.str();
  run.candidates = candidates.str();
  return run;
}

/// Whether the reference pose of a scan judged wrong is itself contradicted by the drive's
/// scans (a SLAM-corrected log's glitch: csail's scans 397-399 are turned about 11 degrees
/// against their neighbours), as llc slam checks its wrong loops' ends: checkReferencePose
/// against the input's scans on either side, spaced as keyframes. Cached per input scan.
class ReferenceJudge {
 public:
  ReferenceJudge(const llc::ScanAlignerOptions& aligner, const llc::ScanOdometryOptions& odometry, const llc::ScanSequence& sequence)
      : aligner_(aligner), spacing_m_(odometry.keyframe_distance), spacing_rad_(odometry.keyframe_angle), sequence_(sequence) {
    for (const llc::LoggedScan& s : sequence.scans) truth_.push_back(s.truth);
  }

  bool contradicted(std::size_t i) {
    const auto known = verdicts_.find(i);
    if (known != verdicts_.end()) return known->second;
    const llc::ReferenceNeighbourIndices near = llc::referenceNeighbourIndices(truth_, i, spacing_m_, spacing_rad_);
    std::vector<std::shared_ptr<const llc::PreparedScan>> held;
    auto neighbours = [&](const std::vector<std::size_t>& indices) {
      std::vector<llc::ReferenceNeighbour> out;
      for (std::size_t k : indices) {
        held.push_back(aligner_.prepare(sequence_.scans[k].scan));
        out.push_back({held.back().get(), truth_[k]});
      }
      return out;
    };
    const std::vector<llc::ReferenceNeighbour> before = neighbours(near.before), after = neighbours(near.after);
    const bool verdict = llc::checkReferencePose(aligner_, *aligner_.prepare(sequence_.scans[i].scan), truth_[i], before, after).contradicted;
    return verdicts_[i] = verdict;
  }

  /// Marks the run's wrong localized scans (rows from sequence index `first` on) whose
  /// reference is contradicted; judged with no distance limit, as wrong_poses_all is.
  void mark(std::vector<llc::LocalizedScan>* scored, std::size_t first, const llc::MapWithTruth& map, double wrong_m,
            double wrong_rad) {
    for (std::size_t k = 0; k < scored->size(); ++k) {
      llc::LocalizedScan& s = (*scored)[k];
      if (s.localized && llc::wrongPose(llc::scanError(s, map).against_map, wrong_m, wrong_rad))
        s.reference_contradicted = contradicted(first + k);
    }
  }

 private:
  const llc::ScanAligner aligner_;
  const double spacing_m_, spacing_rad_;
  const llc::ScanSequence& sequence_;
  std::vector<llc::Pose2> truth_;
  std::map<std::size_t, bool> verdicts_;
};

/// errors.csv (with --truth): each localized scan against where the map has its place and
/// against the truth, with how far its truth lies from the nearest map keyframe's (judged
/// within --judge-within-m) and whether its reference is contradicted (wrong ones only).
std::string errorRows(const std::vector<llc::LocalizedScan>& scored, const std::vector<std::size_t>& input_index,
                      std::size_t first, const llc::MapWithTruth& map) {
  std::ostringstream csv;
  csv << std::setprecision(6) << "scan,error_m,error_deg,global_error_m,global_error_deg,nearest_map_keyframe_m,truth_contradicted\n";
  for (std::size_t k = 0; k < scored.size(); ++k) {
    const llc::LocalizedScan& s = scored[k];
    if (!s.localized) continue;
    const llc::ScanError e = llc::scanError(s, map);
    const llc::Pose2 &error = e.against_map, &global = e.against_truth;
    csv << input_index[first + k] << "," << std::hypot(error.x, error.y) << "," << std::abs(error.theta) * 180.0 / M_PI << ","
        << std::hypot(global.x, global.y) << "," << std::abs(global.theta) * 180.0 / M_PI << ","
        << e.nearest_map_keyframe_m << "," << s.reference_contradicted << "\n";
  }
  return csv.str();
}

void reportRun(const Run& run, std::ostream& report) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const bool fixed = run.first_fix_scan >= 0;
  report << "first_fix_scan=" << run.first_fix_scan << "  (-1: never fixed)\n"
         << "first_fix_travel_m=" << (fixed ? run.first_fix_travel : nan) << "  (driven since the start, by odometry)\n"
         << "first_fix_compute_s=" << (fixed ? run.first_fix_compute : nan) << "  (computation from the start to the fix)\n";
}

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

/// --starts and what scores them, read and checked once, before anything is loaded.
struct StartsOptions {
  long count = 20;
  double travel = 100.0, fix_within = 10.0, near_map = 1.0, seen_heading = M_PI / 4.0;
};

StartsOptions startsOptions(const Args& args) {
  StartsOptions o;
  o.count = args.integer("starts", o.count);
  o.travel = args.number("start-travel", o.travel), o.fix_within = args.number("fix-within-m", o.fix_within);
  o.near_map = args.number("near-map-m", o.near_map);
  o.seen_heading = args.number("seen-heading-deg", o.seen_heading * 180.0 / M_PI) * M_PI / 180.0;
  if (o.count < 1 || !(o.travel > 0.0) || !(o.fix_within > 0.0) || !(o.near_map > 0.0))
    throw UsageError("--starts, --start-travel, --fix-within-m and --near-map-m must be > 0");
  if (!(o.seen_heading > 0.0 && o.seen_heading <= M_PI)) throw UsageError("--seen-heading-deg must be in (0, 180]");
  return o;
}

/// --starts N: N localisations from random scans whose first 10 m pass within 1 m of the
/// map (their truth against the map's keyframes'), each --start-travel m long; starts.csv
/// holds one row each, report.txt the summary.
template <class MakeLocalizer>
void runStarts(const Args& args, const StartsOptions& starts, const llc::ScanSequence& sequence,
               const std::vector<std::size_t>& input_index, std::size_t end, const MapTruth& map_truth,
               MakeLocalizer&& makeLocalizer, bool wheels, double wrong_m, double wrong_rad, double judge_m,
               ReferenceJudge& references, std::ostream& report) {
  const long count = starts.count;
  const double travel = starts.travel, fix_within = starts.fix_within, near_map = starts.near_map;
  const double seen_heading = starts.seen_heading;
  std::vector<llc::Pose2> truth;
  for (std::size_t i = 0; i < end; ++i) truth.push_back(sequence.scans[i].truth);
  const std::vector<bool> near = llc::startsNearMap(truth, map_truth.frame.truth, fix_within, near_map);
  // Of those, the starts that pass a mapped place heading as the map did there (what a scanner
  // of less than the full circle can know again): scored apart.
  const std::vector<bool> seen = llc::startsNearMap(truth, map_truth.frame.truth, fix_within, near_map, seen_heading);
  // A start needs fix_within m of true path ahead (the input ending sooner could not be fixed
  // within them), so the path left from each scan, by the truth.
  std::vector<double> path_left(end, 0.0);
  for (std::size_t i = end; i-- > 1;)  // a scan without a finite truth adds no path, and hides none behind it
    path_left[i - 1] = path_left[i] + (llc::isFinite(truth[i]) && llc::isFinite(truth[i - 1])
                                           ? std::hypot(truth[i].x - truth[i - 1].x, truth[i].y - truth[i - 1].y)
                                           : 0.0);
  std::vector<std::size_t> eligible;
  for (std::size_t i = std::size_t(args.integer("start-scan", 0)); i < end; ++i)
    if (near[i] && path_left[i] >= fix_within) eligible.push_back(i);
  if (eligible.empty())
    throw ToolError("--starts: no scan of the input passes near the map early enough, with --fix-within-m of path after it (--near-map-m, --fix-within-m)");
  llc::Random random(std::uint64_t(args.integer("seed", 1)));
  random.shuffle(eligible);  // without repeats while there are enough
  std::ostringstream csv;
  csv << std::setprecision(6) << "start_scan,fixed_within,first_fix_scan,first_fix_travel_m,first_fix_compute_s,fixes,lost_events,"
                                 "localized_scans,wrong_fixes,wrong_poses,rms_m,seen_heading,wrong_fixes_truth_contradicted\n";
  std::vector<double> travels, computes;
  std::vector<llc::LocalizedScan> pooled;
  std::size_t fixed_within = 0, seen_starts = 0, seen_fixed_within = 0;
  for (long k = 0; k < count; ++k) {
    const std::size_t start = eligible[std::size_t(k) % eligible.size()];
    llc::Localizer localizer = makeLocalizer();
    Run run = localize(localizer, sequence, input_index, start, end, wheels, std::size_t(-1), travel, false);
    references.mark(&run.scored, start, map_truth.frame, wrong_m, wrong_rad);
    const llc::LocalizationScore score = llc::scoreLocalization(run.scored, map_truth.frame, wrong_m, wrong_rad, judge_m);
    const bool in_time = run.first_fix_scan >= 0 && run.first_fix_travel <= fix_within;
    fixed_within += in_time;
    seen_starts += seen[start], seen_fixed_within += seen[start] && in_time;
    if (run.first_fix_scan >= 0) travels.push_back(run.first_fix_travel), computes.push_back(run.first_fix_compute);
    pooled.insert(pooled.end(), run.scored.begin(), run.scored.end());
    csv << input_index[start] << "," << in_time << "," << run.first_fix_scan << "," << run.first_fix_travel << ","
        << run.first_fix_compute << "," << localizer.counters().fixes << "," << localizer.counters().lost_events << ","
        << score.localized << "," << score.wrong_fixes << "," << score.wrong_poses << "," << score.rms_m << "," << seen[start]
        << "," << score.wrong_fixes_contradicted << "\n";
  }
  llc::writeFileAtomically(args.required("out") + "/starts.csv", csv.str());
  const llc::LocalizationScore all = llc::scoreLocalization(pooled, map_truth.frame, wrong_m, wrong_rad, judge_m);
  const llc::LocalizationScore everywhere = llc::scoreLocalization(pooled, map_truth.frame, wrong_m, wrong_rad);
  report << "truth_map_rms_m=" << map_truth.rms_m << "  (the session's keyframes against their truth: the map's own error)\n"
         << "starts=" << count << "  (drawn at random, --seed " << args.integer("seed", 1) << ", among the "
         << eligible.size() << " of " << end << " scans whose first " << fix_within << " m pass within " << near_map
         << " m of the map's keyframes, the input going on for " << fix_within << " m at least)\n"
         << "start_travel_m=" << travel << "  (each start localised over this much of its own path)\n"
         << "fixed_within_share=" << double(fixed_within) / double(count) << "  (first fix within " << fix_within << " m)\n"
         << "fixed_share=" << double(travels.size()) / double(count) << "  (fixed at all)\n"
         << "seen_heading_starts=" << seen_starts << "  (of the starts, those whose first " << fix_within
         << " m pass within " << near_map << " m of a map keyframe heading within " << seen_heading * 180.0 / M_PI
         << " deg of it)\n"
         << "fixed_within_share_seen_heading="
         << (seen_starts ? double(seen_fixed_within) / double(seen_starts) : std::numeric_limits<double>::quiet_NaN())
         << "  (of those, fixed within " << fix_within << " m)\n"
         << "median_first_fix_travel_m=" << median(travels) << "\n"
         << "median_first_fix_compute_s=" << median(computes) << "\n"
         << "wrong_fixes=" << all.wrong_fixes << "  (off where the map has the place by more than " << wrong_m << " m or "
         << wrong_rad * 180.0 / M_PI << " deg)\n"
         << "wrong_poses=" << all.wrong_poses << "\n"
         << "wrong_fixes_truth_contradicted=" << all.wrong_fixes_contradicted
         << "  (of the wrong fixes, those whose scan's reference pose its own scans contradict: ICP from it to the input's scans on either side turns and fits better)\n"
         << "wrong_poses_truth_contradicted=" << all.wrong_poses_contradicted << "\n"
         << "beyond_map_poses=" << all.beyond_map << "  (localized scans whose truth lies over --judge-within-m " << judge_m
         << " m from every map keyframe's: carried by odometry where the map has no place to judge by; not judged)\n"
         << "rms_error_localized_m=" << all.rms_m << "  (all starts' judged localized scans, against the map)\n"
         << "wrong_poses_all=" << everywhere.wrong_poses << "  (every localized scan judged, off the map too)\n"
         << "rms_error_all_m=" << everywhere.rms_m << "  (the same; off the map, the nearest map keyframe's error is carried over the distance)\n"
         << "max_error_localized_m=" << all.max_m << "\n"
         << "wrong_fixes_global=" << all.wrong_fixes_global << "  (against the truth itself: the map's own bending included)\n"
         << "rms_error_localized_global_m=" << all.rms_global_m << "\n";
}

}  // namespace

int runLocalize(const Args& args) {
  if (args.has("bag") == args.has("log")) throw UsageError("give exactly one of --bag BAG and --log LOG");
  const std::string input = args.has("bag") ? args.get("bag", "") : args.get("log", "");
  const std::string dir = args.required("out");
  const std::string session_path = args.required("session");
  const long start_scan = args.integer("start-scan", 0);
  if (start_scan < 0) throw UsageError("--start-scan must be zero or more");
  if (args.has("kidnap-at") != args.has("kidnap-to")) throw UsageError("give both --kidnap-at SCAN and --kidnap-to SCAN, or neither");
  const long kidnap_at = args.integer("kidnap-at", 0), kidnap_to = args.integer("kidnap-to", 0);
  if (args.has("kidnap-at") && (kidnap_at <= start_scan || kidnap_to <= 0))
    throw UsageError("--kidnap-at must be after --start-scan and --kidnap-to above 0");
  const double wrong_m = args.number("wrong-fix-m", 1.0), wrong_rad = args.number("wrong-fix-deg", 5.73) * M_PI / 180.0;
  if (!(wrong_m > 0.0 && wrong_rad > 0.0)) throw UsageError("--wrong-fix-m and --wrong-fix-deg must be > 0");
  if (args.has("judge-within-m") && !(args.number("judge-within-m", 0.0) > 0.0)) throw UsageError("--judge-within-m must be > 0");
  const StartsOptions starts = startsOptions(args);
  const std::optional<llc::OdometryDrift> drift = odometryDrift(args);
  fixedOdometryOffset(args);  // checked now
  driveReadOptions(input, args);  // likewise
  const llc::SystemOptions options = systemOptions(args);
  // Poses are judged where the map has keyframes near (as the ACES rostest judges them): beyond,
  // "where the map has the place" would be the nearest keyframe's bending carried over metres.
  const double judge_m = args.number("judge-within-m", options.localization.track_radius);
  prepareOutputFolder("out", dir);
  const llc::ClassifierModel model = loadModel(args);
  llc::SlamSession session;
  try {
    session = llc::loadSession(session_path);
  } catch (const llc::SessionError& e) {
    throw ToolError(e.what());
  }
  std::optional<MapTruth> map_truth;
  if (args.has("truth")) map_truth = mapTruth(session, loadSequence(args.get("truth", ""), args, true));

  llc::ScanSequence sequence = loadSequence(input, args, true);
  if (args.has("end-scan")) {  // before a kidnap: scan numbers name the input's scans
    const long end = args.integer("end-scan", 0);
    if (end <= start_scan) throw UsageError("--end-scan must be after --start-scan");
    if (std::size_t(end) < sequence.scans.size()) sequence.scans.resize(std::size_t(end));
  }
  const bool wheels = sequence.has_odometry && !args.has("no-wheel-odometry");
  const OffsetChoice offset = chooseOdometryOffset(args, sequence, options.slam);
  llc::shiftOdometry(&sequence, offset.offset);
  if (drift) {
    try {
      llc::driftOdometry(&sequence, *drift);
    } catch (const std::invalid_argument& e) {
      throw ToolError(e.what());
    }
  }
  // Each scan's index in the input (what poses.csv names it by), kidnapped or not.
  std::vector<std::size_t> input_index(sequence.scans.size());
  for (std::size_t i = 0; i < input_index.size(); ++i) input_index[i] = i;
  if (args.has("kidnap-at")) {
    try {
      const llc::ScanSequence moved = llc::kidnapped(sequence, std::size_t(kidnap_at), std::size_t(kidnap_to));
      input_index.resize(std::size_t(kidnap_at));
      for (std::size_t i = std::size_t(kidnap_to); i < sequence.scans.size(); ++i) input_index.push_back(i);
      sequence = moved;
    } catch (const std::invalid_argument& e) {
      throw UsageError(e.what());
    }
  }

  const std::size_t end_scan = sequence.scans.size();
  if (std::size_t(start_scan) >= end_scan) throw UsageError("--start-scan must be before the input's end");
  auto makeLocalizer = [&]() {
    try {
      return llc::Localizer(model, options.slam, session, options.localization);
    } catch (const std::invalid_argument& e) {
      throw ToolError(session_path + ": " + e.what());
    }
  };
  std::ostringstream report;
  report << std::setprecision(4) << "input=" << input << "\n"
         << "session=" << session_path << "\n"
         << "map_keyframes=" << session.keyframes.size() << "\n"
         << "odometry_offset=" << offset.offset << "\n" << offset.table
         << "wheel_odometry=" << (wheels ? "used" : "not used") << "\n";
  if (args.has("starts")) {
    if (!map_truth) throw UsageError("--starts needs --truth (starts are drawn near the map, and scored)");
    ReferenceJudge references(options.slam.aligner, options.slam.odometry, sequence);
    runStarts(args, starts, sequence, input_index, end_scan, *map_truth, makeLocalizer, wheels, wrong_m, wrong_rad, judge_m,
              references, report);
    llc::writeFileAtomically(dir + "/report.txt", report.str());
    std::cout << report.str() << "Wrote " << dir << "/{starts.csv,report.txt}\n";
    return 0;
  }
  const auto load_start = std::chrono::steady_clock::now();
  llc::Localizer localizer = makeLocalizer();
  const double load_seconds = llc::secondsSince(load_start);
  const std::size_t kidnap_row = args.has("kidnap-at") ? std::size_t(kidnap_at) : std::size_t(-1);
  Run run = localize(localizer, sequence, input_index, std::size_t(start_scan), end_scan, wheels, kidnap_row, -1.0, true,
                     map_truth ? &*map_truth : nullptr);
  if (map_truth) {
    ReferenceJudge references(options.slam.aligner, options.slam.odometry, sequence);
    references.mark(&run.scored, std::size_t(start_scan), map_truth->frame, wrong_m, wrong_rad);
    llc::writeFileAtomically(dir + "/errors.csv", errorRows(run.scored, input_index, std::size_t(start_scan), map_truth->frame));
  }
  llc::writeFileAtomically(dir + "/poses.csv", run.rows);
  llc::writeFileAtomically(dir + "/search.csv", run.searches);
  llc::writeFileAtomically(dir + "/candidates.csv", run.candidates);
  const llc::LocalizerCounters& c = localizer.counters();
  report << "map_load_seconds=" << load_seconds << "  (features checked; the map scans prepared for alignment, unless more than loops/prepared_cache: then each when first aligned)\n"
         << "start_scan=" << start_scan << "\n"
         << "scans=" << c.scans << "\n"
         << "keyframes=" << c.keyframes << "\n"
         << "path_m=" << localizer.pathLength() << "  (by the robot's own odometry)\n";
  reportRun(run, report);
  report << "fixes=" << c.fixes << "\n"
         << "lost_events=" << c.lost_events << "\n"
         << "relocalizations=" << c.relocalizations << "\n"
         << "searched_keyframes=" << c.searched_keyframes << "  (classified against the whole map while lost)\n"
         << "loops_to_map=" << c.loops_to_map << "  (their shape-validated loops, look-alikes included)\n"
         << "tracked_keyframes=" << c.tracked_keyframes << "\n"
         << "misfit_keyframes=" << c.misfit_keyframes << "  (near mapped keyframes, fitting none: localization/min_track_fit)\n"
         << "disagreeing_keyframes=" << c.disagreeing_keyframes
         << "  (fitting, but where the odometry's prediction rules out: localization/max_track_chi2; carried by odometry)\n"
         << "off_map_keyframes=" << c.off_map_keyframes << "  (no map keyframe within localization/track_radius)\n"
         << "fixes_refused=" << c.fixes_refused << "  (the loops agreed, the recent keyframes did not fit there: localization/fix_min_fitting_share)\n"
         << "fixes_dropped=" << c.fixes_dropped << "  (a keyframe on probation did not fit: localization/confirm_keyframes)\n"
         << "seconds_front_end=" << c.seconds_front_end << "\n"
         << "seconds_search=" << c.seconds_search << "\n"
         << "seconds_track=" << c.seconds_track << "\n"
         << "seconds=" << run.compute << "\n";
  if (args.has("kidnap-at"))
    report << "kidnapped_at_scan=" << kidnap_at << "  (carried to scan " << kidnap_to << ", odometry running on)\n"
           << "kidnap_lost_after_s=" << run.kidnap_lost_seconds << "  (-1: never reported lost)\n";
  if (map_truth) {
    const llc::LocalizationScore score = llc::scoreLocalization(run.scored, map_truth->frame, wrong_m, wrong_rad, judge_m);
    report << "truth_map_keyframes_matched=" << map_truth->matched << "\n"
           << "truth_map_rms_m=" << map_truth->rms_m << "  (the session's keyframes against their truth: the map's own error)\n"
           << "localized_scans=" << score.localized << "  (judged: truth within --judge-within-m " << judge_m
           << " m of a map keyframe's)\n"
           << "beyond_map_poses=" << score.beyond_map << "  (localized scans farther from the map: not judged)\n"
           << "wrong_fixes=" << score.wrong_fixes << "  (a fix off where the map has its place by more than " << wrong_m
           << " m or " << wrong_rad * 180.0 / M_PI << " deg: its truth from the map keyframe truly nearest)\n"
           << "wrong_poses=" << score.wrong_poses << "  (localized scans as far off)\n"
           << "wrong_fixes_truth_contradicted=" << score.wrong_fixes_contradicted
           << "  (of those fixes, the ones whose scan's reference pose its own scans contradict: ICP from it to the input's scans on either side turns and fits better)\n"
           << "wrong_poses_truth_contradicted=" << score.wrong_poses_contradicted << "\n"
           << "rms_error_localized_m=" << score.rms_m << "\n"
           << "max_error_localized_m=" << score.max_m << "\n"
           << "wrong_fixes_global=" << score.wrong_fixes_global << "  (the same against the truth itself: the map's bending included)\n"
           << "wrong_poses_global=" << score.wrong_poses_global << "\n"
           << "rms_error_localized_global_m=" << score.rms_global_m << "\n";
    if (run.kidnap_lost_seconds >= 0.0) {
      const std::vector<llc::LocalizedScan> after(run.scored.begin() + std::ptrdiff_t(run.kidnap_lost_row), run.scored.end());
      const llc::LocalizationScore later = llc::scoreLocalization(after, map_truth->frame, wrong_m, wrong_rad);
      report << "wrong_poses_after_kidnap_lost=" << later.wrong_poses << "  (of " << later.localized
             << " localized scans after the kidnap was noticed)\n"
             << "rms_error_after_kidnap_lost_m=" << later.rms_m << "\n";
    }
  }
  report << run.events;
  if (map_truth)  // each fix against the map and the truth
    for (std::size_t k = 0; k < run.scored.size(); ++k) {
      if (!run.scored[k].fixed) continue;
      const llc::LocalizationScore one = llc::scoreLocalization({run.scored[k]}, map_truth->frame, wrong_m, wrong_rad);
      report << "fix_error: scan " << input_index[std::size_t(start_scan) + k] << " off where the map has it by " << one.rms_m
             << " m (off the truth by " << one.rms_global_m << " m)" << (one.wrong_fixes ? ", wrong" : "")
             << (one.wrong_fixes_contradicted ? ", by a reference pose its own scans contradict" : "") << "\n";
    }
  llc::writeFileAtomically(dir + "/report.txt", report.str());
  std::cout << report.str() << "Wrote " << dir << "/{poses.csv,search.csv,candidates.csv,report.txt"
            << (map_truth ? ",errors.csv" : "") << "}\n";
  return 0;
}

}  // namespace llc_tool
