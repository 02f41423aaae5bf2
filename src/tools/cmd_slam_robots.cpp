// llc slam with several inputs (--log A --log B ..., or one input --split N): each input is a
// robot with its own odometry frame and no relative prior; MultiRobotSlam joins them into
// robot 0's map (with --load-session, a saved map that every input joins). Writes one map, the
// trajectories with a robot column, and a report.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include "commands.hpp"
#include "input_preparation.hpp"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/core/map/map_picture.hpp"
#include "laser_loop_closure/core/sim/odometry_drift.hpp"
#include "laser_loop_closure/core/slam/multi_robot_slam.hpp"

namespace llc_tool {
namespace {

struct RobotInput {
  std::string source;
  llc::ScanSequence sequence;  ///< its scans; index = the scan's index in its input file
  std::vector<std::size_t> input_index;  ///< per scan of `sequence`: its index in the input file
  bool wheels = true;
  bool has_truth = false;
};

/// The inputs as robots: every --log, then every --bag; or one input cut into --split N parts.
std::vector<RobotInput> loadRobots(const Args& args, const llc::SlamOptions& slam) {
  std::vector<std::string> paths = args.all("log");
  for (const std::string& bag : args.all("bag")) paths.push_back(bag);
  const long split = args.integer("split", 1);
  if (split < 1 || split > 64) throw UsageError("--split must be 1 to 64");
  if (split > 1 && paths.size() != 1) throw UsageError("--split N cuts one input into N robots: give exactly one --log or --bag");
  const std::optional<llc::OdometryDrift> drift = odometryDrift(args);
  llc::Random random(std::uint64_t(args.integer("seed", 1)));
  std::vector<RobotInput> robots;
  for (const std::string& path : paths) {
    driveReadOptions(path, args);  // checked before anything is read
    llc::ScanSequence whole = loadSequence(path, args, true);
    if (whole.scans.size() < 2) throw ToolError(path + ": fewer than 2 scans");
    const bool truth = args.has("evaluate") || drift || hasTruthBesideOdometry(whole);
    llc::shiftOdometry(&whole, chooseOdometryOffset(args, whole, slam).offset);
    // --lifelong on a part of a drive (a day of it): scans start-scan .. end-scan - 1, each
    // keeping its number in the input.
    const long first = args.integer("start-scan", 0), last = args.integer("end-scan", long(whole.scans.size()));
    if (first < 0 || last > long(whole.scans.size()) || last - first < 2)
      throw UsageError("--start-scan and --end-scan must leave 2 scans or more of the input's " + std::to_string(whole.scans.size()));
    if (first > 0 || last < long(whole.scans.size())) {
      whole.scans.erase(whole.scans.begin() + last, whole.scans.end());
      whole.scans.erase(whole.scans.begin(), whole.scans.begin() + first);
    }
    const std::size_t parts = std::size_t(split), per_part = whole.scans.size() / parts;
    if (per_part < 2) throw UsageError("--split: fewer than 2 scans per robot");
    for (std::size_t p = 0; p < parts; ++p) {
      RobotInput robot;
      robot.source = path;
      robot.sequence.source = whole.source;
      robot.sequence.has_odometry = whole.has_odometry;
      const std::size_t end = p + 1 == parts ? whole.scans.size() : (p + 1) * per_part;
      for (std::size_t i = p * per_part; i < end; ++i) {
        robot.sequence.scans.push_back(whole.scans[i]);
        robot.input_index.push_back(i + std::size_t(first));
      }
      robot.wheels = whole.has_odometry && !args.has("no-wheel-odometry");
      robot.has_truth = truth;
      robots.push_back(std::move(robot));
    }
  }
  if (robots.size() < 2 && !args.has("lifelong"))
    throw UsageError("several robots need two inputs or more (--log A --log B), or --split N");
  for (std::size_t r = 0; r < robots.size(); ++r) {
    RobotInput& robot = robots[r];
    if (drift) {  // each robot's wheels drift their own way
      llc::OdometryDrift own = *drift;
      own.seed = drift->seed + r;
      try {
        llc::driftOdometry(&robot.sequence, own);
      } catch (const std::invalid_argument& e) {
        throw ToolError(e.what());
      }
    }
    if (split > 1 && r > 0) {  // a part of one drive: its odometry in a frame of its own, anywhere
      const llc::Pose2 frame{random.uniform(-500.0, 500.0), random.uniform(-500.0, 500.0), random.uniform(-M_PI, M_PI)};
      for (llc::LoggedScan& s : robot.sequence.scans) s.odometry = llc::compose(frame, s.odometry);
    }
  }
  return robots;
}

/// The order in which the robots' scans are fed: by stamp, or (--simultaneous) by time since
/// each robot's first scan, as if all had started together.
std::vector<std::pair<std::size_t, std::size_t>> feedOrder(const std::vector<RobotInput>& robots, bool simultaneous) {
  std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> order;
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const auto& scans = robots[r].sequence.scans;
    for (std::size_t i = 0; i < scans.size(); ++i)
      order.push_back({simultaneous ? scans[i].stamp - scans.front().stamp : scans[i].stamp, {r, i}});
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::pair<std::size_t, std::size_t>> feed;
  for (const auto& o : order) feed.push_back(o.second);
  return feed;
}

struct RobotTruth {
  double rms_m = std::numeric_limits<double>::quiet_NaN();  ///< its keyframes, in the map's alignment when joined
  double first_overlap_m = -1.0;  ///< truth path to its join/min_keyframes-th keyframe within 1.5 m of one another robot mapped earlier
  double joined_m = -1.0;         ///< truth path to the keyframe that joined it
  double shared_to_join_m = -1.0; ///< of that path, the steps to keyframes sharing a view with another robot's earlier ones
};

/// Per keyframe of robot r: whether it is within 1.5 m of a keyframe another robot made
/// earlier in the feed (turned by less than 45 degrees unless 360-degree scans), a place the
/// two could share.
std::vector<bool> sharedViews(const llc::MultiRobotSlam& slam, std::size_t r, const std::vector<std::vector<llc::Pose2>>& truths,
                              const std::vector<std::vector<std::size_t>>& made_at) {
  const auto& keyframes = slam.robot(r).keyframes();  // no saved map here: robot r is input r
  std::vector<bool> shared(keyframes.size(), false);
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    const llc::Pose2& q = truths[r][k];
    for (std::size_t o = 0; o < truths.size() && !shared[k]; ++o) {
      if (o == r) continue;
      for (std::size_t j = 0; j < made_at[o].size() && made_at[o][j] < made_at[r][k]; ++j) {
        const llc::Pose2& u = truths[o][j];
        if (std::hypot(q.x - u.x, q.y - u.y) <= 1.5 &&
            (keyframes[k].scan.full_circle || std::abs(llc::normalizeAngle(q.theta - u.theta)) <= M_PI / 4)) {
          shared[k] = true;
          break;
        }
      }
    }
  }
  return shared;
}

/// The true path from keyframe 0 to each keyframe.
std::vector<double> truePathTo(const std::vector<llc::Pose2>& truth) {
  std::vector<double> path(truth.size(), 0.0);
  for (std::size_t k = 1; k < truth.size(); ++k)
    path[k] = path[k - 1] + std::hypot(truth[k].x - truth[k - 1].x, truth[k].y - truth[k - 1].y);
  return path;
}

/// Every input robot against its truth (input r is the map's robot r + `offset`: 1 after a
/// saved map, whose keyframes have no truth here): the joined inputs' keyframes in the map laid
/// onto it in one alignment (its RMS in *map_rms), each joined robot's RMS within that
/// alignment, an unjoined one's in its own.
std::vector<RobotTruth> judgeAgainstTruth(const llc::MultiRobotSlam& slam, const std::vector<std::vector<llc::Pose2>>& truths,
                                          const std::vector<std::vector<std::size_t>>& made_at,
                                          const std::vector<std::size_t>& joined_by, std::size_t min_keyframes, double* map_rms,
                                          std::size_t offset) {
  const llc::SlamBackEnd& map = slam.map();
  std::vector<llc::Pose2> estimate, reference;
  for (std::size_t m = 0; m < map.keyframes().size(); ++m) {
    const llc::RobotKeyframe& k = slam.mapKeyframe(m);
    if (k.robot < offset) continue;
    estimate.push_back(map.poses()[m]);
    reference.push_back(truths[k.robot - offset][k.keyframe]);
  }
  llc::Pose2 alignment;
  *map_rms = estimate.empty() ? std::numeric_limits<double>::quiet_NaN() : llc::alignedRmsError(estimate, reference, &alignment);
  std::vector<RobotTruth> judged(truths.size());
  for (std::size_t r = 0; r < truths.size(); ++r) {
    RobotTruth& t = judged[r];
    const std::size_t keyframes = truths[r].size();
    const std::size_t robot = r + offset;
    if (slam.joined(robot)) {
      double sum = 0.0;
      for (std::size_t k = 0; k < keyframes; ++k) {
        const llc::Pose2 p = llc::compose(alignment, map.poses()[slam.mapIndex(robot, k)]);
        sum += (p.x - truths[r][k].x) * (p.x - truths[r][k].x) + (p.y - truths[r][k].y) * (p.y - truths[r][k].y);
      }
      t.rms_m = keyframes == 0 ? 0.0 : std::sqrt(sum / double(keyframes));
    } else {
      t.rms_m = llc::alignedRmsError(slam.robot(robot).poses(), truths[r]);
    }
    if (robot == 0) continue;
    // Places of a saved map have no truth here: no overlap is measured against them.
    const std::vector<double> path = truePathTo(truths[r]);
    const std::vector<bool> shared = offset == 0 ? sharedViews(slam, r, truths, made_at) : std::vector<bool>();
    std::size_t overlapping = 0;
    for (std::size_t k = 0; k < shared.size() && t.first_overlap_m < 0.0; ++k)
      if (shared[k] && ++overlapping == min_keyframes) t.first_overlap_m = path[k];
    if (slam.joined(robot)) {
      const std::size_t join = keyframes == 0 ? 0 : std::min(joined_by[r], keyframes - 1);
      t.joined_m = keyframes == 0 ? 0.0 : path[join];
      if (offset == 0) {
        t.shared_to_join_m = 0.0;
        for (std::size_t k = 1; k <= join; ++k)
          if (shared[k]) t.shared_to_join_m += path[k] - path[k - 1];
      }
    }
  }
  return judged;
}

}  // namespace

int runMultiRobotSlam(const Args& args) {
  for (const char* flag : {"save-graph", "relations", "truth", "continue-odometry", "estimate-odometry-time-offset"})
    if (args.has(flag)) throw UsageError(std::string("--") + flag + " is for one robot (one input, no --split)");
  for (const char* flag : {"start-scan", "end-scan"})
    if (args.has(flag) && !args.has("lifelong")) throw UsageError(std::string("--") + flag + " is for one robot (one input, no --split)");
  const std::string dir = args.required("out");
  const double wrong_m = args.number("wrong-loop-m", 1.0), wrong_rad = args.number("wrong-loop-deg", 5.73) * M_PI / 180.0;
  if (!(wrong_m > 0.0 && wrong_rad > 0.0)) throw UsageError("--wrong-loop-m and --wrong-loop-deg must be > 0");
  if (args.has("save-session")) checkOutputFile("save-session", args.get("save-session", ""));
  const llc::SystemOptions options = systemOptions(args);
  std::vector<RobotInput> robots = loadRobots(args, options.slam);
  prepareOutputFolder("out", dir);
  llc::ClassifierModel model;
  try {
    model = llc::loadClassifierModel(args.get("model", defaultModelPath()));
  } catch (const llc::ModelError& e) {
    throw ToolError(e.what());
  }
  // --load-session: a saved map (yesterday's fleet) is the map's robot 0, every input joins it.
  std::optional<llc::SlamSession> saved;
  if (args.has("load-session")) {
    try {
      saved = llc::loadSession(args.get("load-session", ""));
    } catch (const llc::SessionError& e) {
      throw ToolError(e.what());
    }
  }
  const std::size_t offset = saved ? 1 : 0;  // input r is the map's robot r + offset
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<llc::MultiRobotSlam> slam_made;
  try {
    slam_made = std::make_unique<llc::MultiRobotSlam>(model, robots.size() + offset, options.slam, options.multi_robot,
                                                      saved ? &*saved : nullptr);
  } catch (const std::invalid_argument& e) {
    throw ToolError(e.what());
  }
  llc::MultiRobotSlam& slam = *slam_made;
  const std::vector<std::pair<std::size_t, std::size_t>> feed = feedOrder(robots, args.has("simultaneous"));
  // Per robot and keyframe: when (in the feed) it was made, and which keyframe joined the robot.
  std::vector<std::vector<std::size_t>> made_at(robots.size());
  std::vector<std::size_t> joined_by(robots.size(), 0);
  std::size_t done = 0, skipped = 0;
  for (const auto& [r, i] : feed) {
    const llc::LoggedScan& s = robots[r].sequence.scans[i];
    const llc::RobotStep step = slam.addScan(r + offset, s.scan, robots[r].input_index[i], robots[r].wheels ? &s.odometry : nullptr);
    skipped += !step.slam.skip_reason.empty();
    if (step.slam.keyframe) made_at[r].push_back(done);
    for (std::size_t joined : step.joined_robots) {  // itself, or robots this robot's keyframe found
      const std::size_t input = joined - offset;
      joined_by[input] = slam.robot(joined).keyframes().size() - 1;
      if (!args.has("quiet"))
        std::cerr << "robot " << input << " joined the map at its keyframe " << joined_by[input] << " after "
                  << slam.joinedAtPath(joined) << " m of its path" << (input == r ? "" : " (found by robot " + std::to_string(r) + ")")
                  << "\n";
    }
    ++done;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // Each robot's keyframes' truths (a keyframe's scan index names its scan in the input file).
  std::vector<std::vector<llc::Pose2>> truths(robots.size());
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const auto& index = robots[r].input_index;
    for (const llc::Keyframe& k : slam.robot(r + offset).keyframes())
      truths[r].push_back(robots[r].sequence.scans[std::size_t(std::lower_bound(index.begin(), index.end(), k.scan_index) - index.begin())].truth);
  }
  const bool truth = std::all_of(robots.begin(), robots.end(), [](const RobotInput& r) { return r.has_truth; });

  // Outputs: the map's keyframes (joined robots, map frame), then the unjoined robots' own.
  const llc::SlamBackEnd& map = slam.map();
  llc::AtomicTextFile trajectory(dir + "/trajectory.csv");
  trajectory << "robot,index,stamp,x,y,theta,joined\n" << std::fixed << std::setprecision(6);
  for (std::size_t m = 0; m < map.keyframes().size(); ++m) {
    const llc::Pose2& p = map.poses()[m];
    const llc::RobotKeyframe& k = slam.mapKeyframe(m);
    trajectory << slam.sessionRobot(k.robot, k.keyframe) << "," << map.keyframes()[m].scan_index << "," << map.keyframes()[m].stamp << ","
               << p.x << "," << p.y << "," << p.theta << ",1\n";
  }
  for (std::size_t r = 0; r < robots.size(); ++r) {
    if (slam.joined(r + offset)) continue;
    const auto& keyframes = slam.robot(r + offset).keyframes();
    for (std::size_t k = 0; k < keyframes.size(); ++k) {
      const llc::Pose2& p = slam.robot(r + offset).poses()[k];
      trajectory << slam.sessionRobot(r + offset, k) << "," << keyframes[k].scan_index << "," << keyframes[k].stamp << "," << p.x << "," << p.y << ","
                 << p.theta << ",0\n";
    }
  }
  trajectory.commit();
  llc::AtomicTextFile scans(dir + "/scans.csv");
  scans << "robot,scan,stamp,x,y,theta,joined\n" << std::fixed << std::setprecision(6);
  for (std::size_t r = 0; r < robots.size(); ++r)
    for (const llc::ScanPose& s : slam.scanPoses(r + offset))
      scans << slam.sessionRobot(r + offset, 0) << "," << s.scan_index << "," << s.stamp << "," << s.pose.x << "," << s.pose.y
            << "," << s.pose.theta << "," << (slam.joined(r + offset) ? 1 : 0) << "\n";
  scans.commit();
  // The map's loops (own and cross-robot), with wrong ones counted against the truth.
  std::size_t wrong_loops = 0, wrong_cross = 0, wrong_joining = 0, applied_loops = 0, not_judged = 0;
  std::ostringstream wrong_lines;
  std::set<std::pair<std::size_t, std::size_t>> joining;  // map (from, to) of the loops that joined a robot
  for (const llc::CrossRobotLoop& loop : slam.crossLoops())
    if (loop.joining) joining.insert({loop.record.loop.from, loop.record.loop.to});
  llc::AtomicTextFile loops(dir + "/loops.csv");
  loops << "robot_a,a,robot_b,b,applied,score,inlier_share,x,y,theta,innovation_chi2,refusal\n";
  std::vector<llc::PictureLoop> picture_loops;
  for (const llc::LoopRecord& record : map.loops()) {
    const llc::RobotKeyframe& a = slam.mapKeyframe(record.loop.from);
    const llc::RobotKeyframe& b = slam.mapKeyframe(record.loop.to);
    loops << slam.sessionRobot(a.robot, a.keyframe) << "," << map.keyframes()[record.loop.from].scan_index << ","
          << slam.sessionRobot(b.robot, b.keyframe) << ","
          << map.keyframes()[record.loop.to].scan_index << "," << (record.applied ? 1 : 0) << "," << std::setprecision(4)
          << record.loop.score << "," << record.loop.inlier_share << "," << std::setprecision(6) << record.loop.pose.x << ","
          << record.loop.pose.y << "," << record.loop.pose.theta << "," << std::setprecision(4) << record.innovation_chi2 << ","
          << llc::loopRefusalName(record.refusal) << "\n";
    picture_loops.push_back({record.loop.from, record.loop.to, record.applied, record.by_consensus});
    if (!record.applied) continue;
    ++applied_loops;
    if (!truth) continue;
    if (a.robot < offset || b.robot < offset) {  // a keyframe of the saved map: no truth here
      ++not_judged;
      continue;
    }
    const llc::Pose2 e = llc::between(llc::between(truths[a.robot - offset][a.keyframe], truths[b.robot - offset][b.keyframe]),
                                      record.loop.pose);
    if (std::hypot(e.x, e.y) > wrong_m || std::abs(e.theta) > wrong_rad) {
      const bool joined_by_it = joining.count({record.loop.from, record.loop.to}) > 0;
      ++wrong_loops;
      wrong_cross += a.robot != b.robot;
      wrong_joining += joined_by_it;
      wrong_lines << "wrong_loop: robot " << a.robot - offset << " scan " << map.keyframes()[record.loop.from].scan_index
                  << " -> robot " << b.robot - offset << " scan " << map.keyframes()[record.loop.to].scan_index << ", off the truth by "
                  << std::hypot(e.x, e.y) << " m " << e.theta * 180.0 / M_PI << " deg" << (joined_by_it ? ", one that joined the robot" : "")
                  << "\n";
    }
  }
  loops.commit();
  writeMapFiles(map.keyframes(), map.poses(), picture_loops, options.map, dir);

  std::string session_lines;  // --lifelong: what pruning the saved session did
  if (args.has("save-session") && args.has("lifelong")) {
    session_lines = saveLifelongSession(slam.session(), options.lifelong, args.get("save-session", ""), dir);
  } else if (args.has("save-session")) {  // the map: every joined robot, each keyframe's robot named
    try {
      llc::saveSession(slam.session(), args.get("save-session", ""));
    } catch (const llc::SessionError& e) {
      throw ToolError(e.what());
    }
  }

  double map_rms = std::numeric_limits<double>::quiet_NaN();
  const std::vector<RobotTruth> robot_truth =
      truth ? judgeAgainstTruth(slam, truths, made_at, joined_by, options.multi_robot.join.min_keyframes, &map_rms, offset)
            : std::vector<RobotTruth>(robots.size());

  const llc::MultiRobotCounters& c = slam.counters();
  std::ostringstream report;
  report << std::setprecision(4) << "robots=" << robots.size() << "\n";
  if (saved)
    report << "saved_map=" << args.get("load-session", "") << " keyframes " << saved->keyframes.size()
           << "  (the map's frame; every input joins it, and is named after its robots in the outputs)\n"
           << "robots_joined=" << c.robots_joined - 1 << "  (inputs in the saved map)\n";
  else
    report << "robots_joined=" << c.robots_joined << "  (in robot 0's map frame, robot 0 included)\n";
  report
         << "cross_robot_loops=" << c.cross_robot_loops << "  (applied to the map, the joining ones included)\n"
         << "robot_links=" << c.robot_links << "  (pairs of robots, neither in the map, whose loops agreed: one follows the other in)\n"
         << "cross_robot_aligned=" << c.cross_aligned << "\n"
         << "cross_robot_not_aligned=" << c.cross_not_aligned << "  (candidates of a joined robot the map's place gate kept from alignment)\n"
         << "cross_robot_validated=" << c.cross_validated << "  (shape-validated; those the context check let through were offered to a join, or to the map's gate)\n"
         << "cross_robot_refused_by_context=" << c.cross_refused_by_context
         << "  (shape-validated, then the keyframes around each end, by their own robots' odometry, fitted better elsewhere)\n"
         << "cross_robot_refused_by_gate=" << c.cross_refused_by_gate << "\n"
         << "map_keyframes=" << map.keyframes().size() << "\n"
         << "map_loops_applied=" << applied_loops << "\n"
         << "scans_skipped=" << skipped << "\n";
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const std::string p = "robot_" + std::to_string(r) + "_";
    const std::size_t robot = r + offset;
    report << p << "input=" << robots[r].source << " scans " << robots[r].input_index.front() << "-"
           << robots[r].input_index.back() << "\n"
           << p << "keyframes=" << slam.robot(robot).keyframes().size() << "\n"
           << p << "joined=" << (slam.joined(robot) ? 1 : 0) << "\n";
    if (robot > 0 && slam.joined(robot)) report << p << "joined_after_odometry_m=" << slam.joinedAtPath(robot) << "\n";
    if (!truth) continue;
    report << p << "rms_error_m=" << robot_truth[r].rms_m << (slam.joined(robot) ? "" : "  (in its own frame: not joined)") << "\n";
    if (robot == 0 || saved) continue;
    report << p << "first_overlap_m=" << robot_truth[r].first_overlap_m
           << "  (its true path until it has made multi_robot/join/min_keyframes = " << options.multi_robot.join.min_keyframes
           << " keyframes within 1.5 m of one another robot made earlier, as many as a join needs; -1: never)\n";
    if (slam.joined(robot) && robot_truth[r].first_overlap_m >= 0.0)
      report << p << "joined_after_overlap_m=" << robot_truth[r].joined_m - robot_truth[r].first_overlap_m
             << "  (true path from that keyframe to the one that joined it; negative: joined from farther than 1.5 m)\n";
    else if (slam.joined(robot))
      report << p << "joined_after_overlap_m=none  (joined, from places never within 1.5 m of another robot's)\n";
    if (slam.joined(robot))
      report << p << "shared_path_to_join_m=" << robot_truth[r].shared_to_join_m
             << "  (of its true path until it joined, the steps to keyframes within 1.5 m of one another robot made"
                " earlier: the overlap its join had to find loops in)\n";
  }
  if (truth)
    report << "rms_error_m=" << map_rms
           << (saved ? "  (the joined inputs' keyframes in the map, one alignment to the truth)\n"
                     : "  (the map's keyframes, every joined robot, one alignment to the truth)\n")
           << "wrong_loops_accepted=" << wrong_loops << "  (applied to the map, off the truth by over " << wrong_m << " m or "
           << wrong_rad * 180.0 / M_PI << " deg)\n"
           << "wrong_cross_robot_loops=" << wrong_cross << "\n"
           << "wrong_joining_loops=" << wrong_joining << "  (of those, loops that joined a robot to the map)\n"
           << (saved ? "loops_with_the_saved_map_not_judged=" + std::to_string(not_judged) + "  (its keyframes have no truth here)\n"
                     : std::string())
           << wrong_lines.str();
  else
    report << "ground_truth=none (--evaluate or --drift compares against the inputs' poses)\n";
  report << session_lines << "seconds_cross_robot_search=" << c.seconds_search << "\n" << "seconds=" << seconds << "\n";
  llc::writeFileAtomically(dir + "/report.txt", report.str());
  std::cout << report.str() << "Wrote " << dir << "/{trajectory.csv,scans.csv,loops.csv,map.pgm,map.yaml,map.png,report.txt}\n";
  return 0;
}

}  // namespace llc_tool
