// Google Benchmark: features of one scan, one pair classified, one query against N keyframes.
#include <benchmark/benchmark.h>

#include <cmath>

#include "laser_loop_closure/core/features.hpp"
#include "laser_loop_closure/core/keyframe_store.hpp"
#include "laser_loop_closure/core/random.hpp"

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

void BM_QueryKeyframes(benchmark::State& state) {
  const llc::FeatureSet set = llc::FeatureSet::kExtended;
  const std::size_t dim = llc::featureCount(set);
  const std::size_t count = std::size_t(state.range(0));
  llc::KeyframeStore store(set);
  store.reserve(count);
  llc::Random random(3);
  std::vector<double> f(dim);
  for (std::size_t k = 0; k < count; ++k) {
    for (double& v : f) v = random.uniform(0, 5);
    store.add(f.data());
  }
  const llc::StrongClassifier classifier = randomClassifier(llc::pairFeatureCount(set), 50);
  std::vector<double> scores;
  for (auto _ : state) {
    store.scoreAll(classifier, f.data(), count, &scores);
    benchmark::DoNotOptimize(scores.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(count));
}
BENCHMARK(BM_QueryKeyframes)->RangeMultiplier(10)->Range(1000, 1000000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
