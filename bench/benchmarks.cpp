// Google Benchmark: features of one scan, one pair classified, one query against N keyframes.
#include <benchmark/benchmark.h>

#include <Eigen/LU>
#include <malloc.h>

#include <cmath>
#include <stdexcept>
#include <cstdio>
#include <map>
#include <memory>

#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/classifier/keyframe_store.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/features/range_profile.hpp"
#include "laser_loop_closure/core/sim/carmen_writer.hpp"
#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/io/compact_scan.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/map/incremental_grid.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "laser_loop_closure/core/slam/localizer.hpp"
#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/slam/prepared_scan_cache.hpp"

namespace {

/// A room-like scan: smooth walls, depth edges and a few beams without return.
llc::Scan roomScan(std::size_t beams, std::uint64_t seed) {
  llc::Random random(seed);
  llc::Scan scan;
  scan.full_circle = beams > 361;
  const double span = scan.full_circle ? 2 * M_PI : M_PI;
  double r = 5.0;
  for (std::size_t i = 0; i < beams; ++i) {
    r = std::clamp(r + random.uniform(-0.1, 0.1), 0.5, 40.0);
    if (random.uniform() < 0.02) r = random.uniform(1.0, 30.0);
    scan.bearings.push_back(-span / 2 + span * double(i) / double(beams));
    scan.ranges.push_back(random.uniform() < 0.05 ? INFINITY : r);
  }
  return scan;
}

void BM_Features(benchmark::State& state, llc::FeatureSet set) {
  llc::FeatureOptions options;
  options.feature_set = set;
  llc::FeatureExtractor extractor(options);
  const llc::Scan scan = roomScan(std::size_t(state.range(0)), 1);
  std::vector<double> out(extractor.size());
  for (auto _ : state) {
    extractor.extract(scan, out.data());
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK_CAPTURE(BM_Features, paper, llc::FeatureSet::kPaper)->Arg(180)->Arg(361)->Arg(722)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Features, extended, llc::FeatureSet::kExtended)->Arg(180)->Arg(361)->Arg(722)->Unit(benchmark::kMicrosecond);

llc::StrongClassifier randomClassifier(std::size_t dim, int rounds) {
  llc::Random random(4);
  std::vector<llc::Stump> stumps;
  for (int t = 0; t < rounds; ++t)
    stumps.push_back({int(random.index(dim)), random.uniform() < 0.5 ? 1 : -1, random.uniform(0, 3), random.uniform(0.1, 2)});
  return llc::StrongClassifier(stumps, 0.6);
}

void BM_ClassifyPair(benchmark::State& state) {
  const llc::FeatureSet set = llc::FeatureSet::kExtended;
  const std::size_t dim = llc::featureCount(set);
  const llc::StrongClassifier classifier = randomClassifier(llc::pairFeatureCount(set), 50);
  llc::Random random(2);
  std::vector<double> a(dim), b(dim), pair(llc::pairFeatureCount(set));
  for (std::size_t i = 0; i < dim; ++i) a[i] = random.uniform(0, 5), b[i] = random.uniform(0, 5);
  for (auto _ : state) {
    llc::pairFeatures(set, a.data(), b.data(), pair.data());
    benchmark::DoNotOptimize(classifier.score(pair.data()));
  }
}
BENCHMARK(BM_ClassifyPair)->Unit(benchmark::kNanosecond);

/// The default model when the source tree is at hand, else a random 50-stump classifier.
llc::StrongClassifier queryClassifier() {
  try {
    return llc::loadClassifierModel(std::string(LLC_SOURCE_DIR) + "/config/classifier.yaml").classifier;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "benchmark: %s; using a random classifier\n", e.what());
    return randomClassifier(llc::pairFeatureCount(llc::FeatureSet::kExtended), 50);
  }
}

/// A store of `count` keyframes: the features of 1000 room-like scans (180 and 360 degrees),
/// each repeated with a few percent of noise, as a long drive through similar rooms gives.
const llc::KeyframeStore& roomStore(std::size_t count, std::vector<double>* query) {
  static std::map<std::size_t, llc::KeyframeStore> stores;
  static std::vector<std::vector<double>> base;
  llc::FeatureExtractor extractor;
  if (base.empty())
    for (std::uint64_t s = 0; s < 1001; ++s) base.push_back(extractor.extract(roomScan(s % 2 ? 361 : 722, 100 + s)));
  *query = base.back();
  auto found = stores.find(count);
  if (found != stores.end()) return found->second;
  llc::KeyframeStore& store = stores.emplace(count, llc::KeyframeStore(llc::FeatureSet::kExtended)).first->second;
  store.reserve(count);
  llc::Random random(3);
  std::vector<double> f;
  for (std::size_t k = 0; k < count; ++k) {
    f = base[k % 1000];
    for (double& v : f)
      if (v != llc::kProfileEmpty) v *= 1.0 + random.uniform(-0.03, 0.03);
    store.add(f.data());
  }
  return store;
}

void BM_QueryKeyframes(benchmark::State& state) {
  std::vector<double> query;
  const llc::KeyframeStore& store = roomStore(std::size_t(state.range(0)), &query);
  const llc::StrongClassifier classifier = queryClassifier();
  std::size_t found = 0;
  for (auto _ : state) {
    const auto candidates = store.query(classifier, query.data(), store.size(), 100, std::size_t(state.range(1)));
    found = candidates.size();
    benchmark::DoNotOptimize(candidates.data());
  }
  state.counters["candidates"] = double(found);
  // How many keyframes score >= K (an uncapped query, outside the timing): the store is harder
  // than a real map, where about 1% of the pairs do.
  state.counters["above_K"] = double(store.query(classifier, query.data(), store.size(), store.size(), 2).size());
  state.SetItemsProcessed(state.iterations() * std::int64_t(store.size()));
}
// Arguments: keyframes, threads (a query asks for the best 100).
BENCHMARK(BM_QueryKeyframes)
    ->ArgsProduct({{1000, 10000, 100000, 1000000}, {1, 2}})
    ->ArgNames({"keyframes", "threads"})
    ->Unit(benchmark::kMillisecond);

/// The same query wanting every keyframe above K: no bar above K to prune with, the cost of
/// a query before it took the best 100 only.
void BM_QueryKeyframesUncapped(benchmark::State& state) {
  std::vector<double> query;
  const llc::KeyframeStore& store = roomStore(std::size_t(state.range(0)), &query);
  const llc::StrongClassifier classifier = queryClassifier();
  for (auto _ : state) {
    const auto candidates = store.query(classifier, query.data(), store.size(), store.size(), std::size_t(state.range(1)));
    benchmark::DoNotOptimize(candidates.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(store.size()));
}
BENCHMARK(BM_QueryKeyframesUncapped)->Args({1000000, 2})->ArgNames({"keyframes", "threads"})->Unit(benchmark::kMillisecond);

/// Every stump on every keyframe, in the classifier's order: what query() saves.
void BM_ScoreAllKeyframes(benchmark::State& state) {
  std::vector<double> query, scores;
  const llc::KeyframeStore& store = roomStore(std::size_t(state.range(0)), &query);
  const llc::StrongClassifier classifier = queryClassifier();
  for (auto _ : state) {
    store.scoreAll(classifier, query.data(), store.size(), &scores);
    benchmark::DoNotOptimize(scores.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(store.size()));
}
BENCHMARK(BM_ScoreAllKeyframes)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace

/// 360-degree scans (722 beams, front and back merged) of a short simulated drive.
const llc::ScanSequence& simulatedScans() {
  static const llc::ScanSequence sequence = [] {
    llc::SimDriveOptions options;
    options.length_m = 300.0;
    const llc::SimWorld world(llc::simWorldOptions(options));
    const std::string path = "/tmp/llc_benchmark_sim.log";
    llc::writeCarmenLog(llc::simulateDrive(world, options), path);
    llc::ScanSequence s = llc::loadScanSequence(path);
    std::remove(path.c_str());
    return s;
  }();
  return sequence;
}

/// What a keyframe computes once for alignment: points, CRF nodes, k-d tree and normals.
/// Counter heap_kB: what one prepared scan keeps on the heap (glibc's mallinfo2 before and after
/// 100 of them are held): the biggest share of a keyframe's memory in the front end.
void BM_PrepareScanForAlignment(benchmark::State& state) {
  const llc::ScanAligner aligner;
  const llc::Scan& scan = simulatedScans().scans[100].scan;
  state.counters["beams"] = double(scan.size());
  {
    std::vector<std::shared_ptr<const llc::PreparedScan>> held;
    const std::size_t before = mallinfo2().uordblks;
    for (int k = 0; k < 100; ++k) held.push_back(aligner.prepare(simulatedScans().scans[std::size_t(k)].scan));
    state.counters["heap_kB"] = double(mallinfo2().uordblks - before) / 100.0 / 1024.0;
    const std::size_t scans_before = mallinfo2().uordblks;
    std::vector<llc::Scan> copies;
    for (int k = 0; k < 100; ++k) copies.push_back(simulatedScans().scans[std::size_t(k)].scan);
    state.counters["scan_heap_kB"] = double(mallinfo2().uordblks - scans_before) / 100.0 / 1024.0;
  }
  for (auto _ : state) benchmark::DoNotOptimize(aligner.prepare(scan));
}
BENCHMARK(BM_PrepareScanForAlignment)->Unit(benchmark::kMillisecond);

/// One candidate pair aligned with no initial guess (CRF-match, ICP from it and its
/// runners-up, shape validation): scans 1.4 m apart, the second turned by 150 degrees.
void BM_AlignPair(benchmark::State& state) {
  const llc::ScanAligner aligner;
  const auto& scans = simulatedScans().scans;
  const auto a = aligner.prepare(scans[100].scan);
  const auto b = aligner.prepare(llc::rotateScan(scans[102].scan, 150.0 * M_PI / 180.0));
  bool accepted = false;
  for (auto _ : state) {
    const llc::ScanAlignmentResult r = aligner.align(*a, *b);
    accepted = r.accepted;
    benchmark::DoNotOptimize(r.pose);
  }
  state.counters["accepted"] = accepted;
}
BENCHMARK(BM_AlignPair)->Unit(benchmark::kMillisecond);

/// CRF-match alone, both ways round as the aligner runs it on a poor fit: the pair of
/// BM_AlignPair (arg 1) and a look-alike (arg 0: the drive's last scan against scan 100, two
/// places, where a candidate of the lost robot's search usually is).
void BM_CrfMatch(benchmark::State& state) {
  const llc::ScanAligner aligner;
  const auto& scans = simulatedScans().scans;
  const auto a = aligner.prepare(scans[100].scan);
  const auto b = aligner.prepare(state.range(0) ? llc::rotateScan(scans[102].scan, 150.0 * M_PI / 180.0) : scans.back().scan);
  for (auto _ : state) {
    benchmark::DoNotOptimize(llc::matchCrf(b->crf, a->crf, aligner.options().crf).pose);
    benchmark::DoNotOptimize(llc::matchCrf(a->crf, b->crf, aligner.options().crf).pose);
  }
  state.counters["nodes"] = double(a->crf.nodes.size() + b->crf.nodes.size());
}
BENCHMARK(BM_CrfMatch)->Arg(1)->Arg(0)->ArgNames({"same_place"})->Unit(benchmark::kMillisecond);

/// The global search alone on the same pair (what it adds to an alignment when it runs,
/// before ICP from its starts); counts whether its best pose is within 0.3 m and 3 degrees
/// of the pose the whole aligner finds.
void BM_GlobalSearch(benchmark::State& state) {
  const llc::ScanAligner aligner;
  const auto& scans = simulatedScans().scans;
  const auto a = aligner.prepare(scans[100].scan);
  const auto b = aligner.prepare(llc::rotateScan(scans[102].scan, 150.0 * M_PI / 180.0));
  const llc::Pose2 aligned = aligner.align(*a, *b).pose;
  llc::GlobalSearchResult r;
  for (auto _ : state) {
    r = llc::searchGlobally(a->global, b->global, aligner.options().global);
    benchmark::DoNotOptimize(r.poses.data());
  }
  const llc::Pose2 error = r.poses.empty() ? llc::Pose2{1e9, 0, 0} : llc::between(aligned, r.poses[0]);
  state.counters["points"] = double(a->global.points.size() + b->global.points.size());
  state.counters["best_near"] = std::hypot(error.x, error.y) < 0.3 && std::abs(error.theta) < 3.0 * M_PI / 180.0;
}
BENCHMARK(BM_GlobalSearch)->Unit(benchmark::kMillisecond);

/// A keyframe added to a map of n keyframes whose prepared scans are held within the shipped
/// bound (loops/prepared_cache 300): the add lets go of the least recently asked one. Its cost
/// must not grow with the map (a walk over every keyframe per add did). One prepared scan is
/// shared by all entries (as many keyframes as a long drive, without the memory).
void BM_PreparedScanCacheAdd(benchmark::State& state) {
  const llc::ScanAligner aligner;
  const llc::Scan& scan = simulatedScans().scans[100].scan;
  const std::shared_ptr<const llc::PreparedScan> prepared = aligner.prepare(scan);
  llc::PreparedScanCache cache(300);
  for (long k = 0; k < state.range(0); ++k) cache.add(prepared, &scan);
  for (auto _ : state) cache.add(prepared, &scan);
  state.counters["held"] = double(cache.heldPrepared());
}
BENCHMARK(BM_PreparedScanCacheAdd)->Arg(1000)->Arg(100000)->ArgNames({"keyframes"})->Unit(benchmark::kMicrosecond);

/// Localisation's global search (Localizer, while lost): one new keyframe classified against a
/// map of n keyframes with no pose prior, and its best localization/global_candidates (20)
/// aligned with no guess and shape-validated (LoopDetector::detectScan). The map's keyframes
/// are the simulated drive's scans with a few percent of noise on their features, each
/// prepared scan shared by the keyframes repeating it (as many keyframes as a long drive,
/// without the memory). Arguments: map keyframes, threads of the classifier query, threads
/// of the alignments (localization/search_threads; the default 2), and whether the query's
/// place is mapped (1: a scan among the map's; 0: the drive's last scan, a place the map's
/// first stretch never saw, so every candidate is a look-alike: the dearest case, where
/// alignment goes on to the reverse match and the global search).
void BM_LocalizationGlobalSearch(benchmark::State& state) {
  const auto& scans = simulatedScans().scans;
  llc::SlamOptions options;
  options.loops.threads = std::size_t(state.range(1));
  const llc::ClassifierModel model = llc::loadClassifierModel(std::string(LLC_SOURCE_DIR) + "/config/classifier.yaml");
  const llc::LocalizerOptions localization;
  llc::LoopDetector map(model, llc::mapAlignerOptions(options.aligner, localization), options.loops);
  const std::size_t distinct = std::min<std::size_t>(scans.size(), 300);
  std::vector<std::shared_ptr<const llc::PreparedScan>> prepared;
  std::vector<std::vector<double>> features;
  for (std::size_t k = 0; k < distinct; ++k) {
    prepared.push_back(map.aligner().prepare(scans[k].scan));
    features.push_back(map.describe(scans[k].scan));
  }
  llc::Random random(7);
  for (std::size_t k = 0; k < std::size_t(state.range(0)); ++k) {
    std::vector<double> f = features[k % distinct];
    for (double& v : f)
      if (v != llc::kProfileEmpty) v *= 1.0 + random.uniform(-0.03, 0.03);
    map.addWithFeatures(f, prepared[k % distinct]);
  }
  const llc::Scan& query_scan = state.range(3) ? scans[distinct / 2 + 1].scan : scans.back().scan;
  const auto query = map.aligner().prepare(query_scan);
  const std::vector<double> query_features = map.describe(query_scan);
  std::size_t aligned = 0, accepted = 0;
  for (auto _ : state) {
    const llc::LoopDetectionResult r = map.detectScan(query_features, *query, 0, localization.global_candidates,
                                                      localization.score_threshold, std::size_t(state.range(2)));
    aligned = r.aligned.size(), accepted = 0;
    for (const llc::LoopClosure& loop : r.aligned) accepted += loop.accepted;
    benchmark::DoNotOptimize(r.aligned.data());
  }
  state.counters["aligned"] = double(aligned);
  state.counters["accepted"] = double(accepted);
}
BENCHMARK(BM_LocalizationGlobalSearch)
    ->Args({10000, 2, 2, 1})
    ->Args({100000, 2, 2, 1})
    ->Args({100000, 2, 1, 1})
    ->Args({100000, 2, 2, 0})
    ->Args({100000, 2, 1, 0})
    ->ArgNames({"keyframes", "threads", "search_threads", "mapped"})
    ->Unit(benchmark::kMillisecond);

/// A back end's scan at rest for the map (mapScanAtRest at the shipped map_scan_step, 0.5 mm):
/// packing one when its keyframe comes (arg 0) and reading it back when it is drawn (arg 1).
/// Counter bytes: what the packed scan holds. The simulated drive's scans, in single precision
/// as a ROS message carries them.
void BM_MapScanAtRest(benchmark::State& state) {
  llc::Scan scan = simulatedScans().scans[100].scan;
  for (double& r : scan.ranges) r = double(float(r));
  for (double& b : scan.bearings) b = double(float(b));
  const std::shared_ptr<const llc::CompactScan> packed = llc::mapScanAtRest(scan, 0.0005, nullptr);
  if (!packed->isPacked()) throw std::runtime_error("benchmark scan: not packed");
  state.counters["beams"] = double(scan.size());
  state.counters["bytes"] = double(packed->bytes());
  if (state.range(0) == 0)
    for (auto _ : state) benchmark::DoNotOptimize(llc::mapScanAtRest(scan, 0.0005, nullptr));
  else
    for (auto _ : state) benchmark::DoNotOptimize(packed->scan());
}
BENCHMARK(BM_MapScanAtRest)->Arg(0)->Arg(1)->ArgNames({"unpack"})->Unit(benchmark::kMicrosecond);

/// An ESDF of n poses: a noisy square-ish random walk with a loop closure every 50 poses to a
/// pose 25..1000 steps back, solved once (the state a long-running robot reaches).
std::unique_ptr<llc::Esdf> esdfOf(std::size_t n) {
  llc::Random random(5);
  auto esdf = std::make_unique<llc::Esdf>();
  const Eigen::Matrix3d odometry = Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal();
  const Eigen::Matrix3d loop = Eigen::Vector3d(0.04, 0.04, 0.004).asDiagonal();
  for (std::size_t k = 1; k < n; ++k) {
    esdf->augment(llc::Pose2{1.0 + random.normal(0, 0.01), random.normal(0, 0.01), random.normal(0, 0.05)}, odometry);
    if (k % 50 == 0) {
      const std::size_t back = std::min<std::size_t>(k, 25 + random.index(975));
      const std::size_t a = k - back;
      // Measured as the current estimate says: consistent, so the gate would pass it.
      const llc::EsdfUpdateResult update = esdf->updateWithInformation(
          llc::PoseEdge{a, k, llc::between(esdf->mean()[a], esdf->mean()[k]), loop.inverse()}, false, k + 50 >= n);
      if (!update.applied) throw std::runtime_error("benchmark graph: a consistent loop was refused: " + update.reject_reason);
    }
  }
  return esdf;
}

/// One loop-closure update (the mean current afterwards) at 1e4 and 1e5 poses.
void BM_EsdfLoopUpdate(benchmark::State& state) {
  const auto esdf = esdfOf(std::size_t(state.range(0)));
  const std::size_t last = esdf->size() - 1;
  const Eigen::Matrix3d loop = Eigen::Vector3d(0.04, 0.04, 0.004).asDiagonal();
  std::size_t back = 100;
  for (auto _ : state) {
    const std::size_t a = last - back;
    back = back % 900 + 37;
    const llc::EsdfUpdateResult r = esdf->update(a, last, llc::between(esdf->mean()[a], esdf->mean()[last]), loop, false);
    benchmark::DoNotOptimize(r.applied);
  }
}
BENCHMARK(BM_EsdfLoopUpdate)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->Iterations(5);

/// The whole system relinearised and factorised afresh (what a loop that moves many poses
/// costs): solveFrom at the current means, at 1e4 and 1e5 poses; the factorisation's share
/// (analysis included) in its own counter.
void BM_EsdfRebuild(benchmark::State& state) {
  const auto esdf = esdfOf(std::size_t(state.range(0)));
  const double before = esdf->timings().factorizations;
  const int factorizations_before = esdf->factorizations();
  for (auto _ : state) benchmark::DoNotOptimize(esdf->solveFrom(esdf->mean()));
  const double per = double(state.iterations());
  state.counters["factorize_ms"] = 1e3 * (esdf->timings().factorizations - before) / double(esdf->factorizations() - factorizations_before);
  state.counters["factorizations"] = double(esdf->factorizations() - factorizations_before) / per;
}
BENCHMARK(BM_EsdfRebuild)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->Iterations(3);

/// Marginal covariance of the newest pose, and the joint of an old and the newest pose.
void BM_EsdfMarginal(benchmark::State& state) {
  const auto esdf = esdfOf(std::size_t(state.range(0)));
  const std::size_t last = esdf->size() - 1;
  for (auto _ : state) benchmark::DoNotOptimize(esdf->marginalCovariance(last));
}
BENCHMARK(BM_EsdfMarginal)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

void BM_EsdfJointMarginal(benchmark::State& state) {
  const auto esdf = esdfOf(std::size_t(state.range(0)));
  const std::size_t last = esdf->size() - 1;
  for (auto _ : state) benchmark::DoNotOptimize(esdf->jointCovariance(last / 2, last));
}
BENCHMARK(BM_EsdfJointMarginal)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

/// A map of N keyframes of 722 beams, 1.4 m apart along a square city block's streets.
struct DrawnMap {
  std::vector<std::shared_ptr<const llc::CompactScan>> scans;
  std::vector<llc::Pose2> poses;
  llc::IncrementalOccupancyGrid grid{llc::OccupancyGridOptions{}};
};
std::unique_ptr<DrawnMap> drawnMap(std::size_t keyframes) {
  auto map = std::make_unique<DrawnMap>();
  for (std::size_t k = 0; k < keyframes; ++k) {
    const double s = 1.4 * double(k), side = 1000.0;  // around a 1 km square, then again
    const int edge = int(std::fmod(s, 4 * side) / side);
    const double along = std::fmod(s, side);
    const double x[4] = {along, side, side - along, 0.0}, y[4] = {0.0, along, side, side - along};
    map->poses.push_back(llc::Pose2{x[edge], y[edge], edge * M_PI / 2});
    map->scans.push_back(std::make_shared<const llc::CompactScan>(roomScan(722, k + 1)));
  }
  map->grid.update(map->scans, map->poses);
  return map;
}

/// One /map update after a loop moved every keyframe: max_draws_per_update (100) redrawn.
void BM_MapUpdateAfterALoop(benchmark::State& state) {
  const auto map = drawnMap(std::size_t(state.range(0)));
  const std::size_t max_draws = std::size_t(llc::OccupancyGridOptions{}.max_draws_per_update);
  double shift = 0.1;
  for (auto _ : state) {
    state.PauseTiming();
    for (llc::Pose2& pose : map->poses) pose.x += shift;
    shift = -shift;
    state.ResumeTiming();
    benchmark::DoNotOptimize(map->grid.update(map->scans, map->poses, max_draws).redrawn);
  }
  state.counters["grid_MB"] = double(map->grid.bytes()) / 1e6;
}
BENCHMARK(BM_MapUpdateAfterALoop)->Arg(700)->Arg(7000)->Unit(benchmark::kMillisecond);

/// The whole /map (sent when it grows or someone subscribes).
void BM_MapWhole(benchmark::State& state) {
  const auto map = drawnMap(std::size_t(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(map->grid.region(map->grid.bounds()).cells.data());
  state.counters["cells_M"] = map->grid.bounds().cells() / 1e6;
}
BENCHMARK(BM_MapWhole)->Arg(700)->Arg(7000)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
