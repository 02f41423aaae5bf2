// llc: the offline command-line tool. Each subcommand lives in its own cmd_*.cpp file.
#include <algorithm>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include "commands.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "tool_common.hpp"

namespace {

struct Command {
  const char* name;
  int (*run)(const llc_tool::Args&);
  std::vector<std::string> options, flags;
  const char* usage;
};

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

const std::vector<Command>& commands() {
  using llc_tool::kFeatureFlags;
  using llc_tool::kInputFlags;
  static const std::vector<Command> list = {
      {"pairs", llc_tool::runPairs,
       with({"log", "out", "positive-distance", "positive-heading-deg", "min-gap", "negative-distance",
             "max-per-class", "seed"},
            kInputFlags),
       {"full-circle", "partial"},
       "pairs --log LOG --out PAIRS.csv [--positive-distance 1.5] [--positive-heading-deg 45]\n"
       "      [--min-gap 30] [--negative-distance 10] [--max-per-class 200] [--seed 1]\n"
       "      [--full-circle|--partial]   (default: full circle when every scan is 360 degrees)"},
      {"features", llc_tool::runFeatures, with(with({"log", "out", "augment"}, kFeatureFlags), kInputFlags), {},
       "features --log LOG --out FEATURES.csv [feature options]\n"
       "      [--augment half-beams|double-beams]   (the scans as a scanner of half/double the beams records them)"},
      {"train", llc_tool::runTrain,
       with(with({"data", "model", "rounds", "k", "target-false-alarm", "folds", "repeats", "seed", "from-session",
                  "loops/min_keyframe_gap", "augment", "exclude-features"},
                 kFeatureFlags),
            kInputFlags),
       {},
       "train --data LOG:PAIRS [--data LOG:PAIRS ...] --model MODEL.yaml [--rounds 50]\n"
       "      [--k K | --target-false-alarm 0.01 --folds 10 --repeats 1] [feature options]\n"
       "      [--augment none|half-beams,double-beams]   (each --data pair also as a scanner of half/double the beams)\n"
       "      [--exclude-features NAME,...]   (pair features no stump may use: a feature study)\n"
       "      [--from-session SESSION [--loops/min_keyframe_gap 30]]   (self-training: adds the session's keyframe\n"
       "       pairs labelled by its optimised map; --data may then be left out)"},
      {"evaluate", llc_tool::runEvaluate,
       with(with({"data", "out", "folds", "repeats", "rounds", "seed", "curve-max-rounds", "curve-repeats", "augment", "exclude-features",
                  "ablation-repeats", "target-false-alarm", "false-alarm-negatives", "calibration-pairs",
                  "calibration-targets", "loops/calibration/target_false_alarm", "loops/calibration/raise_only",
                  "loops/calibration/min_distance", "loops/calibration/drift_per_metre", "loops/calibration/max_path"},
                 with(with(kFeatureFlags, llc_tool::kAlignerFlags), llc_tool::kDriftFlags)),
            kInputFlags),
       {"no-curve", "no-ablation", "no-rotation", "validate", "leave-one-log-out"},
       "evaluate --data LOG:PAIRS [...] --out DIR [--folds 10] [--repeats 10] [--rounds 50]\n"
       "      [--seed 1] [--curve-max-rounds 1000] [--curve-repeats 1]\n"
       "      [--ablation-repeats 1] [--no-curve] [--no-ablation] [--no-rotation] [feature options]\n"
       "      [--validate [alignment options]]   (adds alignment + shape validation after the classifier)\n"
       "  llc evaluate --leave-one-log-out --data LOG:PAIRS --data LOG:PAIRS [...] --out DIR [--rounds 50]\n"
       "      [--folds 10 --repeats 1 --target-false-alarm 0.01] [--seed 1] [--false-alarm-negatives 0] [feature options]\n"
       "      [--augment none|half-beams,double-beams]   (the training logs' pairs also augmented; never the held-out log's)\n"
       "      [--exclude-features NAME,...]   (pair features no stump may use)\n"
       "      [--calibration-pairs 0 [--loops/calibration/target_false_alarm 0.015 | --calibration-targets T1,T2,...]\n"
       "       [--loops/calibration/raise_only true] [--loops/calibration/min_distance 10]\n"
       "       [--loops/calibration/drift_per_metre 0.3] [--loops/calibration/max_path 50] [--drift moderate|strong ...]]\n"
       "      [--validate [alignment options]]   (the loop stage held out: pairs at or above K aligned, validated)\n"
       "      (each log scored by a model, stumps and K, trained on the other logs only; with calibration\n"
       "       pairs, K is also fitted again on the held-out log's own surely-different pairs by its odometry;\n"
       "       --calibration-targets chooses its target per held-out log on the other logs, each scored by a\n"
       "       model that saw neither: the smallest target keeping them all within 0.5-2% false alarm)"},
      {"score", llc_tool::runScore, with({"model", "data", "out", "augment"}, kInputFlags), {},
       "score [--model MODEL.yaml] --data LOG:PAIRS --out SCORES.csv\n"
       "      [--augment half-beams|double-beams]   (the pairs as a scanner of half/double the beams sees them)"},
      {"simulate", llc_tool::runSimulate,
       {"out", "seed", "route-seed", "length-m", "scanners", "rate-hz", "parking-mean-s", "start-frame", "end-frame",
        "kidnap-at", "kidnap-to", "robots", "robot-seed"},
       {"robots-in-turn"},
       "simulate --out DIR [--seed 1] [--route-seed 0] [--length-m 2000] [--scanners front,back|front] [--rate-hz 10]\n"
       "      [--parking-mean-s 1800] [--start-frame S --end-frame E] [--kidnap-at A --kidnap-to B]\n"
       "      (--route-seed N > 0: another route and noise through the city of --seed; frames S .. E-1 of the drive\n"
       "      are written, and with a kidnapping frames S .. A-1 then B .. E-1, odometry and stamps running on)\n"
       "      [--robots N [--robot-seed 1] [--robots-in-turn]]   (also fleet.bag: the drive cut into N parts driven at\n"
       "      once by robots r1 .. rN (in turn: one after the other), topics and frames under their namespaces, parts\n"
       "      after the first in a random odometry frame)"},
      {"align", llc_tool::runAlign,
       with(with({"data", "out", "model", "tolerance-m", "tolerance-deg"}, llc_tool::kAlignerFlags), kInputFlags),
       {"compare-pcl", "truth-check"},
       "align --data LOG:PAIRS [...] --out ALIGN.csv [--model MODEL.yaml] [--compare-pcl] [--truth-check]\n"
       "      [--tolerance-m 0.2] [--tolerance-deg 2] [alignment options]"},
      {"graph", llc_tool::runGraph, with({"g2o", "out", "latency-csv"}, llc_tool::kEsdfFlags),
       {"incremental", "batch", "gate", "least-squares"},
       "graph --g2o IN.g2o --out OUT.g2o [--incremental|--batch] [--gate] [--least-squares] [--latency-csv STEPS.csv] [--esdf/PARAMETER VALUE ...]\n"
       "      (a graph with loops is solved again from the start with robust loops, esdf/robust_loop_chi2 at\n"
       "       esdf/loop_chi2_threshold, and the lower robust cost kept; --least-squares: never)\n"
       "      (--latency-csv: each incremental step's wall time, `step,edge_from,edge_to,ms`, for scripts/bench_graphs --plot)\n"
       "      (--esdf/robust_loop_chi2 W > 0: robust loops, each misfitting by chi2 X > W counts (2W/(W+X))^2 of its\n"
       "       information; a batch run is solved from two starts and an incremental one re-solved so at the end)"},
      {"slam", llc_tool::runSlam,
       with({"bag", "log", "out", "model", "config", "positive-distance", "positive-heading-deg", "load-session",
             "save-session", "save-graph", "odometry-offset", "drift", "drift-scale-bias", "drift-heading", "drift-noise-m",
             "drift-noise-rad", "drift-noise-share", "drift-seed", "relations", "truth", "wrong-loop-m",
             "wrong-loop-deg", "seq-reorder-scans", "estimate-odometry-time-offset", "end-scan", "start-scan", "split", "seed"},
            with(kInputFlags, llc::systemParameterNames())),
       {"no-wheel-odometry", "quiet", "evaluate", "continue-odometry", "simultaneous", "lifelong"},
       "slam (--bag BAG | --log LOG) --out DIR [--model MODEL.yaml] [--config config/slam.yaml]\n"
       "      [--SECTION/FIELD VALUE ...]   (any pipeline parameter, named as in config/slam.yaml; after --config)\n"
       "      [--no-wheel-odometry] [--quiet] [--evaluate]   (writes trajectory.csv, scans.csv, loops.csv,\n"
       "       map.pgm/.yaml/.png, report.txt)\n"
       "      [--relations R]   (the Kuemmerle et al. relations metric of scans.csv against R, in report.txt,\n"
       "       each relation's error in relation_errors.csv)\n"
       "      [--truth REFERENCE.log]   (truth from another log of the same drive: scans with the same ranges\n"
       "       take its poses, the rest are carried by odometry; then as --evaluate)\n"
       "      [--wrong-loop-m 1.0] [--wrong-loop-deg 5.73]   (an applied loop off the truth by more is wrong)\n"
       "      [--load-session FILE [--continue-odometry]] [--save-session FILE]\n"
       "      [--end-scan N]   (scans from N on are left out: a map of a drive's first part, llc localize for the rest)\n"
       "      [--save-graph FILE.g2o]   (the back end's pose graph at the end: its optimised keyframe poses and every\n"
       "       constraint it applied, odometry and loops, with their information; llc graph reads it)\n"
       "      [--odometry-offset 0|N|auto]   (each scan takes the odometry of the scan N later; auto, the default for\n"
       "       a log, estimates N from the scans, with its reason in report.txt; a bag's default 0)\n"
       "      [--estimate-odometry-time-offset true]   (a bag with wheels, no --odometry-offset: its odometry time offset\n"
       "       found as the scans come, as the loop_closure nodelet's estimate_odometry_time_offset; --odometry-time-offset\n"
       "       until then; the choice in report.txt)"
       "      [--drift moderate|strong] [--drift-scale-bias 0.015] [--drift-heading 0.005] [--drift-noise-m 0.01]\n"
       "      [--drift-noise-rad 0.002] [--drift-noise-share 0.02] [--drift-seed 1]   (degrades the odometry first,\n"
       "       keeping the truth: moderate as written, strong twice each figure)\n"
       "      [--seq-reorder-scans 20]   (a bag mapped without wheel odometry: its scans in header.seq order, as the\n"
       "       loop_closure nodelet's seq_reorder_scans; 0: off)\n"
       "   several robots, one map: slam --log A --log B [...] (and/or several --bag; logs first) --out DIR, or one\n"
       "      input --split N (N consecutive parts, each a robot; parts after the first in a random odometry frame,\n"
       "      --seed 1); each robot its own odometry frame, no relative prior; --drift per robot (seed + robot);\n"
       "      [--simultaneous]   (fed as if every robot started at once; default: by stamp)\n"
       "      (trajectory.csv and scans.csv with robot and joined columns, loops.csv with robot_a/robot_b,\n"
       "       one map of the joined robots, report.txt: robots, robots_joined, cross_robot_loops, per robot;\n"
       "       --save-session: the map with each keyframe's robot)\n"
       "      [--load-session FILE]   (a saved map of the fleet: every input joins it, its frame the map's; the\n"
       "       outputs keep its keyframes' robots and number the inputs after them)\n"
       "   one map for months: slam (--log LOG | --bag BAG) [--load-session S] --lifelong --save-session S2 --out DIR\n"
       "      (the run starts with no pose and joins the saved map at its first confirmed fix, as a robot of a fleet;\n"
       "       S2: the map extended by it, loops between old and new, at bounded size: per place and heading\n"
       "       (lifelong/*) the oldest keyframes kept, the others marginalised into them; DIR/session_keyframes.csv\n"
       "       lists what S2 keeps; written atomically, S2 may be S. Without --load-session: the first day's map)\n"
       "      [--start-scan N] [--end-scan M]   (with --load-session: scans N .. M-1 of the input alone, a later day of a drive)"},
      {"localize", llc_tool::runLocalize,
       with({"bag", "log", "out", "session", "model", "config", "start-scan", "truth", "kidnap-at", "kidnap-to",
             "wrong-fix-m", "wrong-fix-deg", "judge-within-m", "end-scan", "starts", "start-travel", "fix-within-m", "near-map-m", "seen-heading-deg", "seed", "odometry-offset", "drift", "drift-scale-bias", "drift-heading", "drift-noise-m",
             "drift-noise-rad", "drift-noise-share", "drift-seed", "seq-reorder-scans"},
            with(kInputFlags, llc::systemParameterNames())),
       {"no-wheel-odometry"},
       "localize --session SESSION (--log LOG | --bag BAG) --out DIR [--start-scan 0] [--model MODEL.yaml]\n"
       "      [--config config/slam.yaml] [--SECTION/FIELD VALUE ...] [--no-wheel-odometry] [--drift ... as llc slam]\n"
       "      (finds the robot on the saved map with no initial pose and tracks it; writes poses.csv: scan, stamp,\n"
       "       x, y, theta, state (localized|lost; nan while lost) in the session's map frame, and report.txt)\n"
       "      [--truth REF]   (REF: the recording the session was mapped from; the map's frame is laid onto the\n"
       "       truth by its keyframes, then each localized pose checked against its scan's own truth:\n"
       "       wrong_fixes, rms_error_localized_m)\n"
       "      [--wrong-fix-m 1.0] [--wrong-fix-deg 5.73]   (a fix or pose off its truth by more is wrong)\n"
       "      [--judge-within-m M]   (poses whose truth lies farther from every map keyframe's are counted, not judged:\n"
       "       beyond_map_poses; default localization/track_radius, 8; the kidnapping's figures judge every pose)\n"
       "      [--kidnap-at SCAN --kidnap-to SCAN]   (the robot carried from scan SCAN-1 to scan SCAN of the input\n"
       "       while its odometry runs on: kidnap_lost_after_s, wrong_poses_after_kidnap_lost)\n"
       "      [--end-scan N]   (scans from N on are left out)\n"
       "      [--starts 20 --truth REF [--start-travel 100] [--fix-within-m 10] [--near-map-m 1] [--seed 1]]   (that many\n"
       "       localisations, each from a random scan whose true path passes within --near-map-m m of a map keyframe in\n"
       "       its first --fix-within-m m (and goes on that far), over\n"
       "       --start-travel m of its path: starts.csv, and in report.txt the share fixed within --fix-within-m m,\n"
       "       median travel and computation to the first fix, wrong fixes, RMS)\n"
       "      [--seen-heading-deg 45]   (also the share fixed within --fix-within-m m of the starts that pass a map keyframe\n"
       "       heading within this of it: what a scanner of less than 360 degrees can know again)"},
      {"relations", llc_tool::runRelations, with({"log", "poses", "keyframes", "relations", "out", "mount-from"}, kInputFlags), {},
       "relations --log LOG (--poses DIR/scans.csv | --keyframes CSV) --relations R [--out ERRORS.csv]\n"
       "      [--mount-from BAG]\n"
       "      (the Kuemmerle et al. 2009 relations metric: mean, std and largest translational (m) and\n"
       "      rotational (deg) error of the scanner's motion, each pose composed with its scan's front mount;\n"
       "      --keyframes: poses by stamp, a CSV naming stamp, x, y, theta|yaw such as llc slam's\n"
       "      trajectory.csv or the nodelets' path.csv; a scan without a pose is carried from the nearest one\n"
       "      with a pose by the log's odometry; --mount-from: the front mount of BAG's /tf_static in place of\n"
       "      LOG's own, for poses made on BAG but carried by LOG's odometry)"},
      {"train-crf", llc_tool::runTrainCrf,
       with(with({"data", "out", "epochs", "seed"}, llc_tool::kAlignerFlags), kInputFlags), {},
       "train-crf --data LOG:PAIRS [...] --out CRF.yaml [--epochs 8] [--seed 1] [alignment options]"},
  };
  return list;
}

bool takes(const Command& c, const std::vector<std::string>& names) {
  for (const std::string& name : names)
    if (std::find(c.options.begin(), c.options.end(), name) != c.options.end()) return true;
  return false;
}

void alignmentOptionsHelp(std::ostream& out) {
  out << "alignment options: [--aligner/PARAMETER VALUE ...] (every aligner/ parameter of config/slam.yaml;\n"
         "  llc align --help lists them with defaults) [--crf-weights CRF.yaml]\n";
}

void inputHelp(std::ostream& out) {
  out << "LOG is a CARMEN log (.log, .log.gz) or a rosbag (.bag); for a bag: [--front-topic /scan_front]\n"
         "  [--back-topic /scan_back] [--odom-topic /odom] [--truth-topic /ground_truth]\n"
         "  [--odometry-time-offset 0]   (s added to each scan's stamp where its odometry is read, in [-1, 1])\n";
}

void usage(std::ostream& out) {
  out << "usage: llc SUBCOMMAND [options]   (llc SUBCOMMAND --help: that one's options and defaults)\n";
  for (const Command& c : commands()) out << "  llc " << c.usage << "\n";
  alignmentOptionsHelp(out);
  inputHelp(out);
  out << "exit codes: 0 done, 1 a file or the data could not be read or written, 2 bad usage\n";
}

/// llc SUBCOMMAND --help: its usage with the defaults, and the option groups it takes.
void commandHelp(const Command& c, std::ostream& out) {
  out << "usage: llc " << c.usage << "\n";
  const bool slam = std::string(c.name) == "slam" || std::string(c.name) == "localize";  // every pipeline parameter: below
  if (!slam && takes(c, llc_tool::kAlignerFlags)) {
    alignmentOptionsHelp(out);
    llc_tool::systemParametersHelp(out, "aligner/");
  }
  if (!slam && takes(c, llc_tool::kEsdfFlags)) llc_tool::systemParametersHelp(out, "esdf/");
  if (takes(c, llc_tool::kFeatureFlags)) {
    const llc::FeatureOptions d;  // the defaults, as the model file's keys
    out << "feature options (the keys of a model file's features, docs/file_formats.md):\n"
        << "  --features/set " << llc::toString(d.feature_set) << "   paper (the paper's 20) or extended\n"
        << "  --features/r_max " << d.r_max << "   m; beams at or beyond it (or with no finite return) are max-range\n"
        << "  --features/g_max_dist " << d.g_max_dist << "   m; gate on the distance between consecutive points\n"
        << "  --features/g_min_size " << d.g_min_size << "   points; a cluster is a group only with more than this\n"
        << "  --features/closed_ring " << (d.closed_ring ? "true" : "false")
        << "   the last beam of a 360-degree scan neighbours the first\n";
  }
  if (takes(c, llc_tool::kInputFlags)) inputHelp(out);
  if (slam) llc_tool::systemParametersHelp(out);
  out << "exit codes: 0 done, 1 a file or the data could not be read or written, 2 bad usage\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "help")) {
    usage(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? 2 : 0;
  }
  const std::string name = argv[1];
  for (const Command& c : commands()) {
    if (name != c.name) continue;
    for (int i = 2; i < argc; ++i)
      if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h")) {
        commandHelp(c, std::cout);
        return 0;
      }
    try {
      const llc_tool::Args args(argc - 2, argv + 2, c.options, c.flags);
      return c.run(args);
    } catch (const llc_tool::UsageError& e) {
      std::cerr << "llc " << name << ": error: " << e.what() << "\n  (llc " << name << " --help lists its options)\n";
      return 2;
    } catch (const std::exception& e) {
      std::cerr << "llc " << name << ": error: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << "llc: unknown subcommand '" << name << "'\n";
  usage(std::cerr);
  return 2;
}
