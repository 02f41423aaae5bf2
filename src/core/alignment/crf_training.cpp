#include "laser_loop_closure/core/alignment/crf_training.hpp"
#include "laser_loop_closure/core/common/yaml_checks.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numeric>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/common/random.hpp"

namespace llc {

std::string CrfTrainingOptions::validate() const {
  if (epochs < 1) return "epochs must be >= 1";
  if (!(learning_rate > 0.0)) return "learning_rate must be > 0";
  if (!(truth_distance > 0.0)) return "truth_distance must be > 0";
  return "";
}

CrfTrainingResult trainCrfWeights(const std::vector<CrfTrainingPair>& pairs, const CrfMatchOptions& start,
                                  const CrfTrainingOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("crf training: " + error);
  CrfMatchOptions current = start;
  std::array<double, kCrfWeights> w = start.weights.asArray(), sum{};
  std::size_t steps = 0;
  std::vector<std::size_t> order(pairs.size());
  std::iota(order.begin(), order.end(), 0);
  Random random(options.seed);
  std::vector<std::vector<long>> truths(pairs.size());
  for (std::size_t p = 0; p < pairs.size(); ++p)
    truths[p] = crfTrueAssociation(*pairs[p].source, *pairs[p].target, pairs[p].truth, options.truth_distance);
  CrfTrainingResult result;
  for (int epoch = 0; epoch < options.epochs; ++epoch) {
    for (std::size_t k = order.size(); k > 1; --k) std::swap(order[k - 1], order[random.index(k)]);
    std::size_t wrong = 0, nodes = 0;
    for (std::size_t p : order) {
      current.weights = CrfWeights::fromArray(w);
      const CrfMatchResult predicted = matchCrf(*pairs[p].source, *pairs[p].target, current, &truths[p]);
      if (predicted.association.empty()) continue;
      nodes += truths[p].size();
      for (std::size_t i = 0; i < truths[p].size(); ++i) wrong += predicted.association[i] != truths[p][i];
      if (predicted.association != truths[p]) {
        const auto have = crfFeatureTotals(*pairs[p].source, *pairs[p].target, predicted.association);
        const auto want = crfFeatureTotals(*pairs[p].source, *pairs[p].target, truths[p]);
        const double scale = options.learning_rate / double(truths[p].size());
        for (std::size_t q = 0; q < kCrfWeights; ++q) w[q] = std::max(0.0, w[q] + scale * (have[q] - want[q]));
      }
      for (std::size_t q = 0; q < kCrfWeights; ++q) sum[q] += w[q];
      ++steps;
    }
    result.error_by_epoch.push_back(nodes ? double(wrong) / double(nodes) : 0.0);
  }
  if (steps > 0)
    for (double& v : sum) v /= double(steps);
  else
    sum = w;
  const double outlier = sum[kCrfLocalFeatures];
  if (outlier > 0.0)
    for (double& v : sum) v /= outlier;
  result.weights = CrfWeights::fromArray(sum);
  return result;
}

void saveCrfWeights(const CrfWeights& weights, const std::map<std::string, std::string>& provenance,
                    const std::string& path) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << "laser_loop_closure/crf_weights";
  out << YAML::Key << "version" << YAML::Value << kCrfWeightsVersion;
  out << YAML::Key << "local" << YAML::Value << YAML::Flow << std::vector<double>(weights.local.begin(), weights.local.end());
  out << YAML::Key << "outlier" << YAML::Value << weights.outlier;
  out << YAML::Key << "distance" << YAML::Value << weights.distance;
  out << YAML::Key << "order" << YAML::Value << weights.order;
  out << YAML::Key << "provenance" << YAML::Value << YAML::BeginMap;
  for (const auto& [key, value] : provenance) out << YAML::Key << key << YAML::Value << value;
  out << YAML::EndMap << YAML::EndMap;
  try {
    writeFileAtomically(path, std::string(out.c_str()) + "\n");
  } catch (const std::runtime_error& e) {
    throw CrfWeightsError(e.what());
  }
}

CrfWeights loadCrfWeights(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw CrfWeightsError(path + ": cannot read CRF weights file");
  } catch (const YAML::Exception& e) {
    throw CrfWeightsError(path + ": not valid YAML (" + e.what() + ")");
  }
  const std::string repeated = repeatedYamlKey(root);
  if (!repeated.empty()) throw CrfWeightsError(path + ": " + repeated);
  try {
    if (!root.IsMap() || root["format"].as<std::string>("") != "laser_loop_closure/crf_weights")
      throw CrfWeightsError(path + ": not a laser_loop_closure CRF weights file");
    const int version = root["version"].as<int>(-1);
    if (version != kCrfWeightsVersion)
      throw CrfWeightsError(path + ": CRF weights version " + std::to_string(version) + ", this build reads version " +
                            std::to_string(kCrfWeightsVersion));
    for (const char* key : {"local", "outlier", "distance", "order"})
      if (!root[key]) throw CrfWeightsError(path + ": missing '" + key + "' (truncated?)");
    const std::vector<double> local = root["local"].as<std::vector<double>>();
    if (local.size() != kCrfLocalFeatures)
      throw CrfWeightsError(path + ": 'local' must hold " + std::to_string(kCrfLocalFeatures) + " weights");
    CrfWeights w;
    std::copy(local.begin(), local.end(), w.local.begin());
    w.outlier = root["outlier"].as<double>();
    w.distance = root["distance"].as<double>();
    w.order = root["order"].as<double>();
    for (double v : w.asArray())
      if (!(std::isfinite(v) && v >= 0.0)) throw CrfWeightsError(path + ": weights must be finite and >= 0");
    return w;
  } catch (const YAML::Exception& e) {
    throw CrfWeightsError(path + ": malformed CRF weights (" + std::string(e.what()) + ")");
  }
}

}  // namespace llc
