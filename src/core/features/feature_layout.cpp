// The layout of the feature vectors: names, counts and offsets of the scan features, and the
// pair features the classifier sees (features.hpp).
#include "laser_loop_closure/core/features/features.hpp"

#include "laser_loop_closure/core/features/range_profile.hpp"

#include <cmath>
#include <stdexcept>

namespace llc {
namespace {

const std::vector<std::string> kPaperNames = {
    "area",              "average_range",    "centroid",          "close_area",
    "close_distance",    "circle_radius",    "circle_residual",   "curvature_mean",
    "curvature_std",     "distance",         "far_distance",      "group_count",
    "group_size_mean",   "max_range_count",  "angular_difference", "mean_deviation",
    "regularity",        "size",             "deviation_std",     "range_std"};

// The project's additions. Counts are normalised by the beam count so that a model carries
// over between scanners of different resolution; the rest are distributions and shape.
const std::vector<std::string> kExtraNames = {
    "valid_fraction",      "max_range_fraction",  "group_size_fraction",
    "range_q10",           "range_q25",           "range_q50",
    "range_q75",           "range_q90",           "principal_sigma_major",
    "principal_sigma_minor", "anisotropy",        "gap_count",
    "widest_gap_angle",    "longest_group_length", "group_length_mean",
    "range_hist_0_1",      "range_hist_1_2",      "range_hist_2_4",
    "range_hist_4_8",      "range_hist_8_16",     "range_hist_16_max"};

std::vector<std::string> concat(const std::vector<std::string>& a,
                                const std::vector<std::string>& b) {
  std::vector<std::string> all = a;
  all.insert(all.end(), b.begin(), b.end());
  return all;
}

// Signatures: distributions kept as kSignatureLevels quantiles, compared as distributions.
const char* const kSignatureNames[kSignatureCount] = {"range_distribution", "centroid_distance_distribution",
                                                       "chord_distribution", "outline_d2_distribution",
                                                       "outline_centroid_distance_distribution"};

std::vector<std::string> signatureValueNames() {
  std::vector<std::string> names;
  for (const char* signature : kSignatureNames)
    for (std::size_t q = 0; q < kSignatureLevels; ++q) names.push_back(std::string(signature) + "_" + std::to_string(q));
  return names;
}

std::vector<std::string> profileValueNames() {
  std::vector<std::string> names;
  for (std::size_t s = 0; s < kProfileSectors; ++s) names.push_back("range_profile_" + std::to_string(s));
  return names;
}

}  // namespace

const char* toString(FeatureSet set) { return set == FeatureSet::kPaper ? "paper" : "extended"; }

bool parseFeatureSet(const std::string& text, FeatureSet* set) {
  if (text == "paper") *set = FeatureSet::kPaper;
  else if (text == "extended") *set = FeatureSet::kExtended;
  else return false;
  return true;
}

std::string FeatureOptions::validate() const {
  if (!(std::isfinite(r_max) && r_max > 0.0)) return "r_max must be a positive number of metres";
  if (!(std::isfinite(g_max_dist) && g_max_dist > 0.0))
    return "g_max_dist must be a positive number of metres";
  if (g_min_size < 0) return "g_min_size must be zero or more points";
  return {};
}

bool FeatureOptions::operator==(const FeatureOptions& o) const {
  return r_max == o.r_max && g_max_dist == o.g_max_dist && g_min_size == o.g_min_size &&
         closed_ring == o.closed_ring && feature_set == o.feature_set;
}

std::size_t scalarFeatureCount(FeatureSet set) {
  return set == FeatureSet::kPaper ? kPaperNames.size()
                                   : kPaperNames.size() + kExtraNames.size() + kSignatureCount * kSignatureLevels;
}

std::size_t featureCount(FeatureSet set) {
  return scalarFeatureCount(set) + (set == FeatureSet::kPaper ? 0 : kProfileSectors);
}

std::size_t profileOffset(FeatureSet set) { return scalarFeatureCount(set); }

std::size_t signatureOffset(FeatureSet set) {
  return set == FeatureSet::kPaper ? scalarFeatureCount(set) : kPaperNames.size() + kExtraNames.size();
}

std::size_t signatureCount(FeatureSet set) { return set == FeatureSet::kPaper ? 0 : kSignatureCount; }

const std::vector<std::string>& featureNames(FeatureSet set) {
  static const std::vector<std::string> extended =
      concat(concat(concat(kPaperNames, kExtraNames), signatureValueNames()), profileValueNames());
  return set == FeatureSet::kPaper ? kPaperNames : extended;
}

std::size_t pairFeatureCount(FeatureSet set) {
  return set == FeatureSet::kPaper ? scalarFeatureCount(set)
                                   : 2 * scalarFeatureCount(set) + 2 * signatureCount(set) + 1;
}

std::size_t profilePairFeature(FeatureSet set) {
  return set == FeatureSet::kPaper ? pairFeatureCount(set) : pairFeatureCount(set) - 1;
}

const std::vector<std::string>& pairFeatureNames(FeatureSet set) {
  static const std::vector<std::string> extended = [] {
    const std::vector<std::string>& all = featureNames(FeatureSet::kExtended);
    std::vector<std::string> names(all.begin(), all.begin() + long(scalarFeatureCount(FeatureSet::kExtended)));
    for (std::size_t i = 0, n = names.size(); i < n; ++i) names.push_back(names[i] + "_relative");
    for (const char* signature : kSignatureNames) names.push_back(std::string(signature) + "_w1");
    for (const char* signature : kSignatureNames) names.push_back(std::string(signature) + "_w1_relative");
    names.push_back("range_profile_distance");
    return names;
  }();
  return set == FeatureSet::kPaper ? featureNames(set) : extended;
}

double signatureMagnitude(const double* signature) {
  double sum = 0.0;
  for (std::size_t q = 0; q < kSignatureLevels; ++q) sum += signature[q] < 0 ? -signature[q] : signature[q];
  return sum;
}

double signatureDistance(std::size_t index, const double* a, const double* b) {
  double distance = 0.0;
  for (std::size_t q = 0; q < kSignatureLevels; ++q) distance += a[q] > b[q] ? a[q] - b[q] : b[q] - a[q];
  if (index == 0) return distance / double(kSignatureLevels);
  const double scale = signatureMagnitude(a) + signatureMagnitude(b);
  return scale > 0.0 ? distance / scale : 0.0;
}

void pairFeatures(FeatureSet set, const double* a, const double* b, double* out) {
  const std::size_t n = scalarFeatureCount(set);
  for (std::size_t i = 0; i < 2 * n && i < pairFeatureCount(set); ++i) out[i] = pairFeatureValue(i, n, a[i % n], b[i % n]);
  const std::size_t signatures = signatureCount(set), offset = signatureOffset(set);
  for (std::size_t k = 0; k < signatures; ++k) {
    const std::size_t at = offset + k * kSignatureLevels;
    out[2 * n + k] = signatureDistance(0, a + at, b + at);
    out[2 * n + signatures + k] = signatureDistance(1, a + at, b + at);
  }
  if (set != FeatureSet::kPaper)
    out[profilePairFeature(set)] = profileDistance(a + profileOffset(set), b + profileOffset(set));
}

std::vector<double> pairFeatures(FeatureSet set, const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != featureCount(set) || b.size() != featureCount(set))
    throw std::invalid_argument("pairFeatures: feature vectors of the wrong size");
  std::vector<double> out(pairFeatureCount(set));
  pairFeatures(set, a.data(), b.data(), out.data());
  return out;
}

}  // namespace llc
