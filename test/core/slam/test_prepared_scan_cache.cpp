// PreparedScanCache and LoopDetector's prepared_cache: at most `capacity` keyframes stay
// prepared, one let go is prepared again into the same PreparedScan (the same alignment to the
// bit), a reference asked for during a step survives the add that ends it, several threads
// asking at once get one object, released and unknown keyframes throw; and a SLAM run with a
// cache of 4 keyframes gives the same map, loop for loop, as one that keeps every keyframe prepared.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <set>
#include <thread>
#include <vector>

#include "../test_util.hpp"
#include "laser_loop_closure/core/slam/prepared_scan_cache.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"

namespace {

struct Scans {
  llc::ScanAligner aligner;
  std::vector<std::shared_ptr<const llc::Scan>> scans;
  const llc::Scan* at(std::size_t k) const { return scans[k].get(); }
  explicit Scans(std::size_t count) {
    const llc::SimDrive drive = llc_test::simulatedDrive(80.0);
    for (std::size_t k = 0; k < count; ++k)
      scans.push_back(std::make_shared<const llc::Scan>(llc_test::frameScan(drive, drive.frames[k * drive.frames.size() / count])));
  }
};

void expectSamePreparation(const llc::PreparedScan& a, const llc::PreparedScan& b) {
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) EXPECT_EQ(a.points[i], b.points[i]) << i;
  ASSERT_EQ(a.icp_target.normals.size(), b.icp_target.normals.size());
  for (std::size_t i = 0; i < a.icp_target.normals.size(); ++i) EXPECT_EQ(a.icp_target.normals[i], b.icp_target.normals[i]) << i;
}

TEST(PreparedScanCache, KeepsAtMostItsCapacityAndPreparesTheSameAgain) {
  Scans s(10);
  llc::PreparedScanCache cache(3);
  std::vector<std::shared_ptr<const llc::PreparedScan>> first;
  for (const auto& scan : s.scans) {
    first.push_back(s.aligner.prepare(*scan));
    cache.add(first.back(), scan.get());
    EXPECT_LE(cache.heldPrepared(), 3u);  // nothing asked for between adds: only the new one is protected
  }
  EXPECT_EQ(cache.size(), 10u);
  EXPECT_EQ(cache.preparedAgain(), 0u);
  // Keyframe 0 was let go: asked for, it is prepared again, the same as at first.
  const llc::PreparedScan& again = cache.get(0, s.aligner);
  EXPECT_NE(&again, first[0].get());
  EXPECT_EQ(cache.preparedAgain(), 1u);
  expectSamePreparation(again, *first[0]);
  const llc::ScanAlignmentResult from_cache = s.aligner.align(cache.get(0, s.aligner), cache.get(9, s.aligner));
  const llc::ScanAlignmentResult from_first = s.aligner.align(*first[0], *first[9]);
  EXPECT_EQ(from_cache.accepted, from_first.accepted);
  EXPECT_EQ(from_cache.pose.x, from_first.pose.x);
  EXPECT_EQ(from_cache.pose.y, from_first.pose.y);
  EXPECT_EQ(from_cache.pose.theta, from_first.pose.theta);
  // Asked for again while held: no preparation.
  cache.get(0, s.aligner);
  EXPECT_EQ(cache.preparedAgain(), 1u);

  // Capacity 0: every one kept prepared, as handed in, nothing prepared twice.
  llc::PreparedScanCache all;
  for (std::size_t k = 0; k < s.scans.size(); ++k) all.add(first[k], nullptr);
  EXPECT_EQ(all.heldPrepared(), 10u);
  EXPECT_EQ(&all.get(0, s.aligner), first[0].get());
}

/// The rule written out plainly (what trim() did before it kept an index): after each call,
/// which entries are prepared, and how many were prepared again.
struct ReferenceCache {
  std::size_t capacity;
  struct Entry {
    bool prepared, scan, released = false;
    std::uint64_t last_asked;
  };
  std::vector<Entry> entries;
  std::uint64_t clock = 0, trimmed_at = 0;
  std::size_t prepared_again = 0;
  std::size_t held() const {
    std::size_t n = 0;
    for (const Entry& e : entries) n += e.prepared;
    return n;
  }
  void add(bool prepared, bool scan) {
    entries.push_back({prepared, scan, false, ++clock});
    trim();
  }
  void get(std::size_t k) {
    if (!entries[k].prepared) entries[k].prepared = true, ++prepared_again;
    entries[k].last_asked = ++clock;
  }
  void release(std::size_t k) { entries[k] = {false, false, true, entries[k].last_asked}; }
  void trim() {
    std::vector<std::pair<std::uint64_t, std::size_t>> idle;
    for (std::size_t k = 0; k < entries.size(); ++k)
      if (entries[k].prepared && entries[k].scan && entries[k].last_asked <= trimmed_at) idle.emplace_back(entries[k].last_asked, k);
    std::sort(idle.begin(), idle.end());
    for (std::size_t i = 0; i < idle.size() && capacity > 0 && held() > capacity; ++i) entries[idle[i].second].prepared = false;
    trimmed_at = clock;
  }
};

TEST(PreparedScanCache, LetsGoOfTheSameEntriesAsTheRuleWrittenOutPlainly) {
  // Random adds (some kept prepared for ever: no scan), asks, releases and trims; after each,
  // the cache holds as many prepared and has prepared as many again as the plain rule says,
  // and an entry the rule let go is prepared again when asked (preparedAgain rises by one).
  Scans s(6);
  llc::PreparedScanCache cache(4);
  ReferenceCache reference{4, {}};
  llc::Random random(5);
  for (int step = 0; step < 400; ++step) {
    const double u = random.uniform(0.0, 1.0);
    const std::size_t n = cache.size();
    if (n < 3 || u < 0.25) {
      const bool keep_scan = random.uniform(0.0, 1.0) < 0.9;
      const llc::Scan* scan = s.at(n % s.scans.size());
      cache.add(s.aligner.prepare(*scan), keep_scan ? scan : nullptr);
      reference.add(true, keep_scan);
    } else if (u < 0.85) {
      const std::size_t k = std::size_t(random.uniform(0.0, double(n) - 1e-9));
      if (reference.entries[k].released) continue;
      if (!reference.entries[k].prepared && !reference.entries[k].scan) continue;
      cache.get(k, s.aligner);
      reference.get(k);
    } else if (u < 0.9) {
      const std::size_t k = std::size_t(random.uniform(0.0, double(n) - 1e-9));
      cache.release(k);
      reference.release(k);
    } else {
      cache.trim();
      reference.trim();
    }
    ASSERT_EQ(cache.heldPrepared(), reference.held()) << "step " << step;
    ASSERT_EQ(cache.preparedAgain(), reference.prepared_again) << "step " << step;
  }
  EXPECT_GT(reference.prepared_again, 20u);  // the walk did let go of and prepare again many
}

TEST(PreparedScanCache, AScanOfSinglePrecisionValuesKeptAsFloatsComesBackTheSame) {
  // A ROS message's scan (float32 values, no return +inf, NaN): kept in half the bytes; a
  // scan with values no float holds (a text log's) kept as it is. Both prepared again the same.
  Scans s(2);
  llc::Scan single = *s.scans[0];
  for (double& r : single.ranges) r = double(float(r));
  for (double& b : single.bearings) b = double(float(b));
  single.ranges[1] = std::numeric_limits<double>::infinity();
  single.ranges[2] = std::numeric_limits<double>::quiet_NaN();
  llc::Scan precise = *s.scans[1];
  precise.ranges[3] = 1.0 + 1e-12;  // no float holds it
  llc::PreparedScanCache cache(1);
  cache.add(nullptr, &single);
  cache.add(nullptr, &precise);
  expectSamePreparation(cache.get(0, s.aligner), *s.aligner.prepare(single));
  expectSamePreparation(cache.get(1, s.aligner), *s.aligner.prepare(precise));
}

TEST(PreparedScanCache, AReferenceAskedForDuringAStepSurvivesTheAddThatEndsIt) {
  Scans s(4);
  llc::PreparedScanCache cache(1);
  cache.add(nullptr, s.at(0));  // prepared when first asked for
  EXPECT_EQ(cache.heldPrepared(), 0u);
  const llc::PreparedScan& held = cache.get(0, s.aligner);
  EXPECT_EQ(cache.preparedAgain(), 1u);
  cache.add(s.aligner.prepare(*s.scans[1]), s.at(1));  // ends the step: 0 was asked for in it
  EXPECT_EQ(&cache.get(0, s.aligner), &held);
  EXPECT_EQ(held.points.size(), s.aligner.prepare(*s.scans[0])->points.size());
  cache.add(s.aligner.prepare(*s.scans[2]), s.at(2));  // 0 asked for in this step too: still there
  EXPECT_EQ(&cache.get(0, s.aligner), &held);
  cache.trim();  // a step in which nothing was asked for: down to the capacity
  cache.add(s.aligner.prepare(*s.scans[3]), s.at(3));
  EXPECT_EQ(cache.heldPrepared(), 1u);
  EXPECT_TRUE(cache.has(0));  // let go, but its scan is kept
  // A prepared scan handed in without a scan can never be prepared again: it is kept.
  llc::PreparedScanCache no_scans(1);
  for (const auto& scan : s.scans) no_scans.add(s.aligner.prepare(*scan), nullptr);
  EXPECT_EQ(no_scans.heldPrepared(), 4u);
}

TEST(PreparedScanCache, ThreadsAskingAtOnceGetOneObjectAndBadIndicesThrow) {
  Scans s(3);
  llc::PreparedScanCache cache(1);
  for (const auto& scan : s.scans) cache.add(nullptr, scan.get());
  std::vector<const llc::PreparedScan*> got(4, nullptr);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < got.size(); ++t) threads.emplace_back([&, t] { got[t] = &cache.get(1, s.aligner); });
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(std::set<const llc::PreparedScan*>(got.begin(), got.end()).size(), 1u);
  EXPECT_EQ(cache.preparedAgain(), 1u);

  cache.release(2);
  cache.release(99);  // unknown: ignored
  EXPECT_FALSE(cache.has(2));
  EXPECT_THROW(cache.get(2, s.aligner), std::out_of_range);
  EXPECT_THROW(cache.get(3, s.aligner), std::out_of_range);
  EXPECT_THROW(cache.add(nullptr, nullptr), std::invalid_argument);
}

TEST(PreparedScanCache, ASlamRunWithFourKeptPreparedGivesTheSameMapLoopForLoop) {
  const llc::SimDrive drive = llc_test::simulatedDrive(500.0);
  auto run = [&](std::size_t cache) {
    llc::SlamOptions options;
    options.loops.prepared_cache = cache;
    auto slam = std::make_unique<llc::SlamPipeline>(llc_test::defaultModel(), options);
    for (std::size_t i = 0; i < drive.frames.size(); ++i)
      slam->addScan(llc_test::frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
    return slam;
  };
  const auto all = run(0), few = run(4);
  ASSERT_GT(all->counters().loops_accepted, 3u) << "the drive must close loops";
  EXPECT_EQ(few->counters().loops_accepted, all->counters().loops_accepted);
  EXPECT_EQ(few->counters().aligned, all->counters().aligned);
  EXPECT_EQ(few->counters().refused_by_context, all->counters().refused_by_context);
  ASSERT_EQ(few->poses().size(), all->poses().size());
  for (std::size_t k = 0; k < all->poses().size(); ++k) {
    EXPECT_EQ(few->poses()[k].x, all->poses()[k].x) << k;
    EXPECT_EQ(few->poses()[k].y, all->poses()[k].y) << k;
    EXPECT_EQ(few->poses()[k].theta, all->poses()[k].theta) << k;
  }
  EXPECT_GT(few->detector().preparedAgain(), 0u) << "the small cache must have let keyframes go and prepared them again";
  // The bound, and those asked for in the last step (the local map of the newest keyframes, the context of its loops).
  EXPECT_LT(few->detector().heldPrepared(), all->poses().size() / 10);
  EXPECT_EQ(all->detector().preparedAgain(), 0u);
  EXPECT_EQ(all->detector().heldPrepared(), all->poses().size());
  std::cout << all->poses().size() << " keyframes; a cache of 4 prepared " << few->detector().preparedAgain()
            << " scans again and holds " << few->detector().heldPrepared() << "\n";
}

}  // namespace
