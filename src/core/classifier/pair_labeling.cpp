#include "laser_loop_closure/core/classifier/pair_labeling.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/common/random.hpp"

namespace llc {

std::string PairLabelingOptions::validate() const {
  if (!(positive_max_distance > 0.0)) return "positive_max_distance must be positive";
  if (!(positive_max_heading > 0.0)) return "positive_max_heading must be positive";
  if (!(negative_min_distance >= positive_max_distance))
    return "negative_min_distance must not be below positive_max_distance";
  if (max_pairs_per_class == 0) return "max_pairs_per_class must be at least 1";
  return {};
}

PairLabelingResult labelPairs(const std::vector<Pose2>& poses, const PairLabelingOptions& options) {
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw std::invalid_argument("pair labelling: " + invalid);
  PairLabelingResult result;
  const std::size_t n = poses.size();
  std::vector<LabeledPair> positives;
  std::uint64_t negative_total = 0;
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      const double d = std::hypot(poses[b].x - poses[a].x, poses[b].y - poses[a].y);
      if (d > options.negative_min_distance) {
        ++negative_total;
      } else if (d < options.positive_max_distance && b - a >= options.min_index_gap &&
                 (options.full_circle ||
                  std::abs(normalizeAngle(poses[b].theta - poses[a].theta)) <= options.positive_max_heading)) {
        positives.push_back({a, b, 1});
      }
    }
  }
  result.positive_candidates = positives.size();
  Random random(options.seed);
  random.shuffle(positives);
  const std::size_t count = std::min({options.max_pairs_per_class, positives.size(),
                                      std::size_t(negative_total)});
  positives.resize(count);
  // Negatives by rejection: uniform over all pairs, kept when far enough and new.
  std::set<std::pair<std::size_t, std::size_t>> taken;
  std::vector<LabeledPair> negatives;
  while (negatives.size() < count) {
    std::size_t a = random.index(n), b = random.index(n);
    if (a == b) continue;
    if (a > b) std::swap(a, b);
    const double d = std::hypot(poses[b].x - poses[a].x, poses[b].y - poses[a].y);
    if (d > options.negative_min_distance && taken.insert({a, b}).second)
      negatives.push_back({a, b, 0});
  }
  result.pairs = positives;
  result.pairs.insert(result.pairs.end(), negatives.begin(), negatives.end());
  std::sort(result.pairs.begin(), result.pairs.end(), [](const LabeledPair& x, const LabeledPair& y) {
    return std::tie(x.a, x.b, x.label) < std::tie(y.a, y.b, y.label);
  });
  return result;
}

std::vector<LabeledPair> sampleNegativePairs(const std::vector<Pose2>& poses, double min_distance, std::size_t count,
                                             std::uint64_t seed) {
  const std::size_t n = poses.size();
  auto far = [&](std::size_t a, std::size_t b) {
    return std::hypot(poses[b].x - poses[a].x, poses[b].y - poses[a].y) > min_distance;
  };
  std::size_t total = 0;
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b) total += far(a, b);
  Random random(seed);
  std::vector<LabeledPair> negatives;
  if (2 * count >= total) {  // most of them: list all, shuffle, keep count
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = a + 1; b < n; ++b)
        if (far(a, b)) negatives.push_back({a, b, 0});
    random.shuffle(negatives);
    negatives.resize(std::min(count, negatives.size()));
    return negatives;
  }
  std::set<std::pair<std::size_t, std::size_t>> taken;  // few of many: rejection
  while (negatives.size() < count) {
    std::size_t a = random.index(n), b = random.index(n);
    if (a == b) continue;
    if (a > b) std::swap(a, b);
    if (far(a, b) && taken.insert({a, b}).second) negatives.push_back({a, b, 0});
  }
  return negatives;
}

void writePairs(const std::string& path, const std::vector<LabeledPair>& pairs) {
  AtomicTextFile out(path);
  out << "a,b,label\n";
  for (const LabeledPair& p : pairs) out << p.a << ',' << p.b << ',' << p.label << '\n';
  try {
    out.commit();
  } catch (const std::runtime_error& e) {
    throw PairFileError(e.what());
  }
}

std::vector<LabeledPair> readPairs(const std::string& path, std::size_t scan_count) {
  std::ifstream in(path);
  if (!in) throw PairFileError(path + ": cannot open");
  std::string line;
  std::size_t number = 0;
  auto fail = [&](const std::string& why) {
    throw PairFileError(path + ":" + std::to_string(number) + ": " + why);
  };
  if (!std::getline(in, line)) fail("empty file (expected the header a,b,label)");
  ++number;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line.rfind("a,b,label", 0) != 0) fail("the header must start with a,b,label");
  std::vector<LabeledPair> pairs;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::istringstream fields(line);
    std::string a, b, label;
    if (!std::getline(fields, a, ',') || !std::getline(fields, b, ',') || !std::getline(fields, label, ','))
      fail("expected a,b,label");
    auto index = [&](const std::string& text) {
      char* end = nullptr;
      const unsigned long long value = std::strtoull(text.c_str(), &end, 10);
      if (text.empty() || *end != '\0' || text[0] == '-') fail("'" + text + "' is not a scan index");
      if (scan_count != SIZE_MAX && value >= scan_count)
        fail("scan index " + text + " out of range (the log has " + std::to_string(scan_count) + " scans)");
      return std::size_t(value);
    };
    LabeledPair pair{index(a), index(b), 0};
    if (label == "1") pair.label = 1;
    else if (label != "0") fail("label must be 0 or 1, not '" + label + "'");
    pairs.push_back(pair);
  }
  return pairs;
}

}  // namespace llc
