// Sessions: the file round-trips every field and refuses what is not whole; a drive saved
// halfway and continued gives the map of the drive run at once; a restored map places a new
// chain (a second run, its own odometry frame) at its first loop closure.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "../test_util.hpp"

namespace {

llc::SlamSession handSession() {
  llc::SlamSession s;
  for (int k = 0; k < 3; ++k) {
    llc::Keyframe key;
    key.scan_index = std::size_t(10 * k + 1);
    key.stamp = 100.0 + k;
    key.scan = llc_test::ringScan({1.0, 2.0, std::numeric_limits<double>::infinity(), std::nan(""), -1.0});
    key.scan.stamp = key.stamp;
    key.has_wheel_odometry = k != 1;
    key.wheel_odometry = llc::Pose2{0.5 * k, -0.25 * k, 0.1 * k};
    s.keyframes.push_back(key);
    s.features.push_back({double(k), 1.5, -2.0});
    s.poses.push_back(llc::Pose2{1.0 * k, 0.0, 0.01 * k});
  }
  llc::PoseEdge odometry;
  odometry.from = 0, odometry.to = 1, odometry.measurement = llc::Pose2{1.0, 0.0, 0.01};
  odometry.information << 100, 1, 0, 1, 100, 0, 0, 0, 1000;
  s.constraints.push_back(odometry);
  odometry.from = 1, odometry.to = 2;
  s.constraints.push_back(odometry);
  llc::PoseEdge loop = odometry;
  loop.from = 0, loop.to = 2, loop.measurement = llc::Pose2{2.0, 0.01, 0.02};
  s.constraints.push_back(loop);
  llc::LoopRecord record;
  record.loop.from = 0, record.loop.to = 2, record.loop.score = 0.9, record.loop.pose = loop.measurement;
  record.loop.covariance = Eigen::Matrix3d::Identity() * 0.01;
  record.loop.inlier_share = 0.97, record.loop.accepted = true, record.loop.seconds = 0.003;
  record.applied = true, record.innovation_chi2 = 1.25, record.by_consensus = true;
  s.loops.push_back(record);
  record.by_consensus = false;
  record.applied = false, record.reject_reason = "backend: innovation chi2 99 > 16.27";
  record.refusal = llc::LoopRefusal::kBackEndGate;
  s.loops.push_back(record);
  return s;
}

bool samePose(const llc::Pose2& a, const llc::Pose2& b) { return a.x == b.x && a.y == b.y && a.theta == b.theta; }

TEST(SessionFile, RoundTripsEveryField) {
  llc_test::TempDir dir;
  const llc::SlamSession saved = handSession();
  llc::saveSession(saved, dir.file("s.llcsession"));
  const llc::SlamSession loaded = llc::loadSession(dir.file("s.llcsession"));
  ASSERT_EQ(loaded.keyframes.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const llc::Keyframe &a = saved.keyframes[k], &b = loaded.keyframes[k];
    EXPECT_EQ(a.scan_index, b.scan_index);
    EXPECT_EQ(a.stamp, b.stamp);
    EXPECT_EQ(a.has_wheel_odometry, b.has_wheel_odometry);
    EXPECT_TRUE(samePose(a.wheel_odometry, b.wheel_odometry));
    EXPECT_EQ(a.scan.full_circle, b.scan.full_circle);
    EXPECT_EQ(a.scan.bearings, b.scan.bearings);
    ASSERT_EQ(b.scan.ranges.size(), 5u);
    EXPECT_TRUE(std::isinf(b.scan.ranges[2]) && std::isnan(b.scan.ranges[3]) && b.scan.ranges[4] == -1.0);
    EXPECT_EQ(saved.features[k], loaded.features[k]);
    EXPECT_TRUE(samePose(saved.poses[k], loaded.poses[k]));
  }
  ASSERT_EQ(loaded.constraints.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(loaded.constraints[i].from, saved.constraints[i].from);
    EXPECT_EQ(loaded.constraints[i].to, saved.constraints[i].to);
    EXPECT_TRUE(samePose(loaded.constraints[i].measurement, saved.constraints[i].measurement));
    EXPECT_EQ(loaded.constraints[i].information, saved.constraints[i].information);
  }
  ASSERT_EQ(loaded.loops.size(), 2u);
  EXPECT_EQ(loaded.loops[1].reject_reason, saved.loops[1].reject_reason);
  EXPECT_EQ(loaded.loops[0].loop.covariance, saved.loops[0].loop.covariance);
  EXPECT_EQ(loaded.loops[0].innovation_chi2, 1.25);
  EXPECT_TRUE(loaded.loops[0].applied && !loaded.loops[1].applied);
  EXPECT_TRUE(loaded.loops[0].by_consensus && !loaded.loops[1].by_consensus);
  EXPECT_EQ(loaded.loops[0].refusal, llc::LoopRefusal::kNone);
  EXPECT_EQ(loaded.loops[1].refusal, llc::LoopRefusal::kBackEndGate);
  EXPECT_FALSE(std::ifstream(dir.file("s.llcsession.tmp")).good()) << "the temporary file stays behind";
}

/// FNV-1a over bytes, as docs/file_formats.md states the checksum (a reference, not the code's).
std::uint64_t fnv1aOf(const std::string& bytes) {
  std::uint64_t hash = 14695981039346656037ull;
  for (unsigned char c : bytes) hash = (hash ^ c) * 1099511628211ull;
  return hash;
}

template <class T>
std::string rawBytes(T value) {
  return std::string(reinterpret_cast<const char*>(&value), sizeof value);
}

TEST(SessionFile, VersionsOneToThreeStillLoadTheirRefusalsReadFromTheReasons) {
  // Version 3 is version 4 without each keyframe's robot, version 2 also without the two refusal
  // codes per loop record, version 1 also without the consensus flag per record: built from a
  // version-4 save as the layout in docs/file_formats.md says (magic, version, body length,
  // body, checksum).
  llc_test::TempDir dir;
  llc::SlamSession saved = handSession();
  // One more refused loop, by the aligner: its reason's first words say which stage, as the
  // stages of versions 1 and 2 wrote them.
  llc::LoopRecord validation = saved.loops[1];
  validation.loop.accepted = false, validation.loop.refusal = llc::LoopRefusal::kValidation;
  validation.loop.reject_reason = validation.reject_reason = "validation: inlier share 0.41 below 0.9";
  validation.refusal = llc::LoopRefusal::kValidation, validation.innovation_chi2 = 0.0;
  saved.loops.push_back(validation);
  llc::saveSession(saved, dir.file("v4.llcsession"));
  const std::string v4 = llc_test::readText(dir.file("v4.llcsession"));
  ASSERT_EQ(v4.substr(0, 12), "LLC-SESSION\n");
  ASSERT_EQ(v4.compare(12, 4, rawBytes(std::uint32_t(4))), 0);
  std::uint64_t length = 0;
  std::memcpy(&length, v4.data() + 16, sizeof length);
  ASSERT_EQ(v4.size(), 24 + length + 8);
  const std::size_t loops = saved.loops.size(), robots = 4 * saved.keyframes.size();
  for (std::uint32_t version : {1u, 2u, 3u}) {
    const std::string body = v4.substr(24, length - robots - loops * (version == 3 ? 0 : version == 2 ? 2 : 3));
    const std::string old = v4.substr(0, 12) + rawBytes(version) + rawBytes(std::uint64_t(body.size())) + body + rawBytes(fnv1aOf(body));
    const std::string path = dir.file("v" + std::to_string(version) + ".llcsession");
    std::ofstream(path, std::ios::binary) << old;
    const llc::SlamSession loaded = llc::loadSession(path);
    ASSERT_EQ(loaded.loops.size(), 3u);
    EXPECT_TRUE(loaded.loops[0].applied);
    EXPECT_EQ(loaded.loops[0].by_consensus, version >= 2) << "version 1 does not say: not by consensus";
    EXPECT_TRUE(loaded.robots.empty()) << "before version 4 every keyframe is robot 0's";
    EXPECT_EQ(loaded.loops[1].reject_reason, saved.loops[1].reject_reason);
    EXPECT_EQ(loaded.loops[0].refusal, llc::LoopRefusal::kNone);
    EXPECT_EQ(loaded.loops[1].refusal, llc::LoopRefusal::kBackEndGate);
    EXPECT_EQ(loaded.loops[2].refusal, llc::LoopRefusal::kValidation);
    EXPECT_EQ(loaded.loops[2].loop.refusal, llc::LoopRefusal::kValidation);
    EXPECT_EQ(loaded.keyframes.size(), 3u);
    // A newer body in an older file: bytes left over.
    const std::string with_codes = v4.substr(0, 12) + rawBytes(version) + v4.substr(16);
    std::ofstream(path, std::ios::binary) << with_codes;
    EXPECT_THROW(llc::loadSession(path), llc::SessionError);
  }
  // A refusal code this build does not know is refused, with the byte it is at.
  std::string body = v4.substr(24, length);
  body[body.size() - 1 - robots] = char(llc::kLoopRefusalKinds);
  std::ofstream(dir.file("code.llcsession"), std::ios::binary) << v4.substr(0, 24) + body + rawBytes(fnv1aOf(body));
  try {
    llc::loadSession(dir.file("code.llcsession"));
    ADD_FAILURE() << "an unknown refusal code loaded";
  } catch (const llc::SessionError& e) {
    EXPECT_NE(std::string(e.what()).find("a refusal code of 10"), std::string::npos) << e.what();
  }
}

TEST(SessionFile, EachKeyframesRobotSurvivesARoundTrip) {
  llc_test::TempDir dir;
  llc::SlamSession saved = handSession();
  saved.robots = {0, 2, 1};
  llc::saveSession(saved, dir.file("robots.llcsession"));
  EXPECT_EQ(llc::loadSession(dir.file("robots.llcsession")).robots, saved.robots);
  saved.robots = {0, 1};  // not one per keyframe
  EXPECT_NE(saved.validate().find("robots named"), std::string::npos) << saved.validate();
  EXPECT_THROW(llc::saveSession(saved, dir.file("bad.llcsession")), llc::SessionError);
  saved.robots.clear();  // one robot: written as robot 0 each
  llc::saveSession(saved, dir.file("one.llcsession"));
  EXPECT_EQ(llc::loadSession(dir.file("one.llcsession")).robots, std::vector<std::uint32_t>(3, 0));
}

TEST(SessionFile, RefusesMissingForeignTruncatedCorruptAndInconsistentFiles) {
  llc_test::TempDir dir;
  const std::string good = dir.file("good.llcsession");
  llc::saveSession(handSession(), good);
  const std::string bytes = llc_test::readText(good);
  auto refused = [&](const std::string& content, const std::string& expected) {
    const std::string path = dir.file("bad.llcsession");
    std::ofstream(path, std::ios::binary) << content;
    try {
      llc::loadSession(path);
    } catch (const llc::SessionError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << "the message names the file";
      return;
    }
    ADD_FAILURE() << "accepted: " << expected;
  };
  EXPECT_THROW(llc::loadSession(dir.file("missing")), llc::SessionError);
  refused("", "not a laser_loop_closure session");
  refused("VERTEX_SE2 0 0 0 0\n", "not a laser_loop_closure session");
  std::string other_version = bytes;
  other_version[12] = char(7);
  refused(other_version, "version 7");
  other_version[12] = char(0);
  refused(other_version, "version 0");
  for (std::size_t cut : {std::size_t(14), bytes.size() / 2, bytes.size() - 1}) refused(bytes.substr(0, cut), "truncated");
  refused(bytes + "x", "truncated");
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x40;
  refused(flipped, "checksum");

  // A count the bytes left cannot hold, with the length and checksum made right (as a crafted
  // file would): refused before anything is sized by it (3e7 keyframes took 3.3 GB before).
  for (const std::uint64_t count : {std::uint64_t(30000000), std::uint64_t(1) << 31}) {
    std::uint64_t length = 0;
    std::memcpy(&length, bytes.data() + 16, sizeof length);
    std::string body = bytes.substr(24, length);
    std::memcpy(&body[0], &count, sizeof count);
    refused(bytes.substr(0, 24) + body + rawBytes(fnv1aOf(body)), "that the");
  }

  llc::SlamSession inconsistent = handSession();
  inconsistent.poses.pop_back();
  EXPECT_THROW(llc::saveSession(inconsistent, dir.file("x")), llc::SessionError);
  inconsistent = handSession();
  inconsistent.constraints[2].to = 7;
  EXPECT_NE(inconsistent.validate(), "");
  inconsistent = handSession();
  inconsistent.constraints.resize(1);  // pose 2 never linked
  EXPECT_NE(inconsistent.validate(), "");
  inconsistent = handSession();
  inconsistent.loops[0].applied = false;  // but by_consensus
  EXPECT_NE(inconsistent.validate(), "");
  inconsistent = handSession();
  inconsistent.poses[1].x = std::nan("");
  EXPECT_NE(inconsistent.validate(), "");
}

TEST(SessionFile, AFailedSaveLeavesThePreviousFileWhole) {
  llc_test::TempDir dir;
  const std::string path = dir.file("s.llcsession");
  llc::saveSession(handSession(), path);
  ASSERT_EQ(mkdir((path + ".tmp").c_str(), 0755), 0);  // the temporary file cannot be written
  llc::SlamSession bigger = handSession();
  bigger.loops.clear();
  EXPECT_THROW(llc::saveSession(bigger, path), llc::SessionError);
  EXPECT_EQ(llc::loadSession(path).loops.size(), 2u);
}

struct Drive {
  llc::SimDriveOptions options;
  std::unique_ptr<llc::SimWorld> world;
  llc::SimDrive drive;
  Drive() {
    options.length_m = 500.0;
    world = std::make_unique<llc::SimWorld>(llc::simWorldOptions(options));
    drive = llc::simulateDrive(*world, options);
  }
  void run(llc::SlamPipeline* slam, std::size_t begin, std::size_t end) const {
    for (std::size_t i = begin; i < end; ++i)
      slam->addScan(llc_test::frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
  }
};

TEST(SlamSession, SavedHalfwayAndContinuedGivesTheMapOfOneRun) {
  llc_test::TempDir dir;
  const Drive d;
  const std::size_t n = d.drive.frames.size(), half = n / 2;
  llc::SlamPipeline whole(llc_test::defaultModel());
  d.run(&whole, 0, n);
  ASSERT_GT(whole.counters().loops_accepted, 3u) << "the drive must close loops";

  llc::SlamPipeline first(llc_test::defaultModel());
  d.run(&first, 0, half);
  llc::saveSession(first.session(), dir.file("half.llcsession"));
  llc::SlamPipeline second(llc_test::defaultModel());
  ASSERT_EQ(second.restore(llc::loadSession(dir.file("half.llcsession")), true), "");
  ASSERT_EQ(second.keyframes().size(), first.keyframes().size());
  for (std::size_t k = 0; k < first.poses().size(); ++k) {
    EXPECT_NEAR(second.poses()[k].x, first.poses()[k].x, 1e-6);
    EXPECT_NEAR(second.poses()[k].y, first.poses()[k].y, 1e-6);
  }
  d.run(&second, half, n);
  ASSERT_EQ(second.keyframes().size(), whole.keyframes().size());
  EXPECT_EQ(second.backEnd().counters().loops_accepted, whole.backEnd().counters().loops_accepted);
  double worst = 0.0;
  for (std::size_t k = 0; k < whole.poses().size(); ++k)
    worst = std::max(worst, std::hypot(second.poses()[k].x - whole.poses()[k].x, second.poses()[k].y - whole.poses()[k].y));
  EXPECT_LT(worst, 1e-3) << "m between the continued run and the run at once";
  // Who was who: the run that went on is the same robot (0), in the session saved again.
  const llc::SlamSession again = second.session();
  ASSERT_EQ(again.robots.size(), again.keyframes.size());
  for (const std::uint32_t robot : again.robots) EXPECT_EQ(robot, 0u);
}

TEST(SlamSession, WhoMadeEachKeyframeSurvivesALoadAndASave) {
  llc::SlamSession fleet;
  fleet.keyframes.resize(4);
  fleet.robots = {0, 2, 2, 1};
  // Started anew on it: a new run, robot 3; going on from its newest keyframe: robot 1's run.
  llc::KeyframeRobots fresh = llc::KeyframeRobots::afterRestore(fleet, false);
  EXPECT_EQ(fresh.of(6), (std::vector<std::uint32_t>{0, 2, 2, 1, 3, 3}));
  EXPECT_EQ(llc::KeyframeRobots::afterRestore(fleet, true).of(5), (std::vector<std::uint32_t>{0, 2, 2, 1, 1}));
  EXPECT_EQ(fresh.of(2), (std::vector<std::uint32_t>{0, 2}));
  fleet.robots.clear();  // a file before version 4: robot 0's
  EXPECT_EQ(llc::KeyframeRobots::afterRestore(fleet, false).of(5), (std::vector<std::uint32_t>{0, 0, 0, 0, 1}));
  EXPECT_EQ(llc::KeyframeRobots{}.of(2), (std::vector<std::uint32_t>{0, 0}));  // nothing restored

  // Through a pipeline: a map restored and started anew keeps its keyframes' robots, and its
  // new keyframes are a new robot's.
  const Drive d;
  llc::SlamPipeline mapped(llc_test::defaultModel());
  d.run(&mapped, 0, 200);
  llc::SlamSession session = mapped.session();
  ASSERT_GT(session.keyframes.size(), 4u);
  session.robots.assign(session.keyframes.size(), 4);
  session.robots[1] = 7;
  llc::SlamPipeline second(llc_test::defaultModel());
  ASSERT_EQ(second.restore(session, false), "");
  d.run(&second, 200, 300);
  const llc::SlamSession saved = second.session();
  ASSERT_GT(saved.keyframes.size(), session.keyframes.size());
  for (std::size_t k = 0; k < saved.keyframes.size(); ++k)
    EXPECT_EQ(saved.robots[k], k < session.keyframes.size() ? session.robots[k] : 8u) << k;
}

TEST(SlamSession, ARestoredMapPlacesANewChainAtItsFirstLoopClosure) {
  const Drive d;
  const std::size_t n = d.drive.frames.size();
  llc::SlamPipeline mapped(llc_test::defaultModel());
  d.run(&mapped, 0, n);
  llc::SlamPipeline second(llc_test::defaultModel());
  ASSERT_EQ(second.restore(mapped.session(), false), "");
  const std::size_t restored = second.keyframes().size();
  // A second run over the first 100 m, its odometry frame turned and moved (a new start).
  const llc::Pose2 new_odom_frame{-30.0, 12.0, 1.3};
  std::size_t applied_to_old = 0;
  for (std::size_t i = 0; i < n / 3; ++i) {
    const llc::Pose2 odometry = llc::compose(new_odom_frame, d.drive.frames[i].odometry);
    llc::Scan scan = llc_test::frameScan(d.drive, d.drive.frames[i]);
    const llc::SlamStepResult step = second.addScan(scan, i, &odometry);
    ASSERT_TRUE(step.skip_reason.empty()) << step.skip_reason;
    for (const llc::LoopRecord& r : step.records) applied_to_old += r.applied && r.loop.from < restored;
  }
  ASSERT_GT(applied_to_old, 0u) << "no loop joined the new chain to the restored map";
  // Every new keyframe lies where the old one of the same scan lies.
  std::map<std::size_t, llc::Pose2> old_pose;
  for (std::size_t k = 0; k < restored; ++k) old_pose[mapped.keyframes()[k].scan_index] = mapped.poses()[k];
  std::size_t compared = 0;
  double worst = 0.0;
  for (std::size_t k = restored; k < second.keyframes().size(); ++k) {
    const auto it = old_pose.find(second.keyframes()[k].scan_index);
    if (it == old_pose.end()) continue;
    ++compared;
    worst = std::max(worst, std::hypot(second.poses()[k].x - it->second.x, second.poses()[k].y - it->second.y));
  }
  EXPECT_GT(compared, 10u);
  EXPECT_LT(worst, 0.3) << "m between the new chain and the restored map";
}

}  // namespace

namespace {

TEST(SlamSession, FeaturesOfAnotherLengthAreRefusedNotThrown) {
  // The loop_closure nodelet assembles keyframes and features from session parts and gives them
  // to the front end directly: vectors of different lengths are a reason, never a throw.
  const Drive d;
  llc::SlamPipeline mapped(llc_test::defaultModel());
  d.run(&mapped, 0, d.drive.frames.size() / 4);
  llc::SlamSession session = mapped.session();
  ASSERT_GT(session.keyframes.size(), 3u);
  llc::SlamFrontEnd front(llc_test::defaultModel(), {}, {}, {});
  std::vector<std::vector<double>> features = session.features;
  features[2].push_back(1.0);
  std::string why;
  ASSERT_NO_THROW(why = front.restore(session.keyframes, features, false));
  EXPECT_NE(why.find("keyframe 2 has"), std::string::npos) << why;
  EXPECT_EQ(front.keyframeCount(), 0u) << "nothing changed";
  // All of another length (a model with other features): recomputed, restored.
  for (std::vector<double>& f : features) f.assign(7, 0.5);
  bool recomputed = false;
  EXPECT_EQ(front.restore(session.keyframes, features, false, &recomputed), "");
  EXPECT_TRUE(recomputed);
  EXPECT_EQ(front.keyframeCount(), session.keyframes.size());
  // The pipeline refuses a session whose keyframe lost a bearing, and says which.
  session.keyframes[1].scan.bearings.pop_back();
  llc::SlamPipeline second(llc_test::defaultModel());
  why = second.restore(session, false);
  EXPECT_NE(why.find("keyframe 1"), std::string::npos) << why;
  EXPECT_TRUE(second.keyframes().empty());
}

}  // namespace
