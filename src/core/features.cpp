#include "laser_loop_closure/core/features.hpp"

#include "laser_loop_closure/core/outline.hpp"
#include "laser_loop_closure/core/range_profile.hpp"
#include "laser_loop_closure/core/rank_selection.hpp"
#include "laser_loop_closure/core/vector_kernels.hpp"

#include <algorithm>
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

/// Writes kSignatureLevels quantiles (at (q + 0.5) / levels) of the selector's values; zeros when empty.
void writeQuantiles(RankSelector& values, double* out) {
  const std::size_t m = values.size();
  for (std::size_t q = 0; q < kSignatureLevels; ++q)
    out[q] = m == 0 ? 0.0 : values.at(std::min(m - 1, std::size_t((double(q) + 0.5) / kSignatureLevels * double(m))));
}

/// Plain Euclidean distance: std::hypot guards against overflow we cannot have here, slowly.
inline double pointDistance(double ax, double ay, double bx, double by) {
  return std::sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay));
}

double safeDiv(double num, double den) { return den != 0.0 ? num / den : 0.0; }

/// Sample standard deviation from a count, a sum and a sum of squared deviations.
double sampleStd(double sum_sq_dev, std::size_t n) {
  return n > 1 ? std::sqrt(std::max(0.0, sum_sq_dev / double(n - 1))) : 0.0;
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

FeatureExtractor::FeatureExtractor(const FeatureOptions& options) : options_(options) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("feature options: " + error);
}

void FeatureExtractor::updateTrigonometry(const std::vector<double>& bearings) {
  if (bearings == cached_bearings_) return;
  cached_bearings_ = bearings;
  const std::size_t n = bearings.size();
  cos_.resize(n);
  sin_.resize(n);
  half_sin_.assign(n, 0.0);
  sector_.resize(n);
  for (std::size_t i = 0; i < n; ++i) sector_[i] = profileSector(bearings[i]);
  for (std::size_t i = 0; i < n; ++i) {
    cos_[i] = std::cos(bearings[i]);
    sin_[i] = std::sin(bearings[i]);
    if (i + 1 < n) half_sin_[i] = std::sin(0.5 * (bearings[i + 1] - bearings[i]));
  }
  seam_half_sin_ = n > 0 ? std::sin(0.5 * (bearings[0] + 2.0 * M_PI - bearings[n - 1])) : 0.0;
}

std::vector<double> FeatureExtractor::extract(const Scan& scan) {
  std::vector<double> out(size());
  extract(scan, out.data());
  return out;
}

void FeatureExtractor::extract(const Scan& scan, double* out) {
  const double r_max = options_.r_max;
  const double gate = options_.g_max_dist;
  const std::size_t n = std::min(scan.ranges.size(), scan.bearings.size());
  std::fill(out, out + size(), 0.0);
  if (n == 0) return;
  updateTrigonometry(scan.bearings);
  const bool closed = options_.closed_ring && scan.full_circle && n >= 3;
  const std::size_t pair_count = closed ? n : n - 1;  // neighbour pairs (i, i+1 mod n)
  auto next = [n](std::size_t i) { return i + 1 == n ? 0 : i + 1; };

  // Beams: valid = finite return nearer than r_max; everything else counts as max-range and
  // is clipped to r_max where a feature needs a range (#1, #2, #11).
  clipped_.resize(n); x_.resize(n); y_.resize(n); valid_.resize(n);
  std::size_t valid_count = 0;
  double sum_x = 0.0, sum_y = 0.0, sum_r = 0.0, sum_clipped = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = scan.ranges[i];
    const bool valid = std::isfinite(r) && r > 0.0 && r < r_max;
    valid_[i] = valid;
    clipped_[i] = valid ? r : r_max;
    x_[i] = clipped_[i] * cos_[i];
    y_[i] = clipped_[i] * sin_[i];
    sum_clipped += clipped_[i];
    if (valid) {
      ++valid_count;
      sum_x += x_[i];
      sum_y += y_[i];
      sum_r += r;
    }
  }
  const double mean_x = safeDiv(sum_x, double(valid_count));
  const double mean_y = safeDiv(sum_y, double(valid_count));
  const double mean_r = safeDiv(sum_r, double(valid_count));

  // Distances between neighbours, computed once: step_[i] = |p[i+1] - p[i]| (the seam's too
  // on a closed ring), for #11 over every pair and for the segments between valid points.
  step_.resize(n);
  distancesAhead(x_.data(), y_.data(), n, 1, step_.data());
  step_[n - 1] = closed ? pointDistance(x_[n - 1], y_[n - 1], x_[0], y_[0]) : 0.0;

  // #1 area and #11 far distance run over every neighbour pair.
  double area = 0.0, far_distance = 0.0;
  for (std::size_t i = 0; i < pair_count; ++i) {
    const std::size_t j = next(i);
    area += clipped_[i] * clipped_[j] * (j == 0 ? seam_half_sin_ : half_sin_[i]);
    far_distance += step_[i];
  }

  // Segments between neighbouring valid points (-1 where either end is not valid).
  segment_.resize(n);
  double distance = 0.0, close_distance = 0.0, sum_seg_sq = 0.0;
  std::size_t segment_count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = next(i);
    if (i < pair_count && valid_[i] && valid_[j]) {
      const double d = step_[i];
      segment_[i] = d;
      distance += d;
      if (d < gate) close_distance += d;
      ++segment_count;
    } else {
      segment_[i] = -1.0;
    }
  }
  const double segment_mean = safeDiv(distance, double(segment_count));
  for (std::size_t i = 0; i < n; ++i)
    if (segment_[i] >= 0.0) sum_seg_sq += (segment_[i] - segment_mean) * (segment_[i] - segment_mean);

  // #8 #9 curvature and #15 angular difference over triples of neighbouring valid points.
  double sum_k = 0.0, angular = 0.0;
    const std::size_t triple_count = closed ? n : (n >= 2 ? n - 2 : 0);
  // |p[a+2] - p[a]|, with the two wrapped triples of a closed ring.
  skip2_.resize(n);
  distancesAhead(x_.data(), y_.data(), n, 2, skip2_.data());
  // The turn at every interior point (#15), likewise.
  turn_.resize(n);
  turnAngles(x_.data(), y_.data(), n, turn_.data());
  if (closed) {
    for (std::size_t a = n - 2; a < n; ++a) {
      const std::size_t b = next(a), c = next(b);
      skip2_[a] = pointDistance(x_[a], y_[a], x_[c], y_[c]);
      turn_[a] = angleBetween(x_[b] - x_[a], y_[b] - y_[a], x_[c] - x_[b], y_[c] - y_[b]);
    }
  }
  curvature_.resize(n);
  std::size_t curvature_count = 0;
  for (std::size_t a = 0; a < triple_count; ++a) {
    const std::size_t b = next(a), c = next(b);
    const double da = segment_[a], db = segment_[b];
    if (da <= 0.0 || db <= 0.0) continue;  // an end not valid, or a zero-length segment
    const double ux = x_[b] - x_[a], uy = y_[b] - y_[a];
    const double vx = x_[c] - x_[b], vy = y_[c] - y_[b];
    const double cross = ux * vy - uy * vx;
    angular += turn_[a];
    const double dc = skip2_[a];
    if (dc <= 0.0) continue;
    const double k = 2.0 * std::abs(cross) / (da * db * dc);  // 4 * triangle area / sides
    sum_k += k;
    curvature_[curvature_count++] = k;
  }
  const double k_mean = safeDiv(sum_k, double(curvature_count));
  double sum_k_sq_dev = 0.0;
  for (std::size_t i = 0; i < curvature_count; ++i) sum_k_sq_dev += (curvature_[i] - k_mean) * (curvature_[i] - k_mean);
  const double k_std = sampleStd(sum_k_sq_dev, curvature_count);

  // #12 #13 groups: runs of valid neighbours closer than the gate; with a closed ring the run
  // through the seam is one group.
  std::size_t group_count = 0, group_points = 0;
  double longest_group = 0.0, group_length_sum = 0.0;
  {
    auto linked = [&](std::size_t i) { return segment_[i] >= 0.0 && segment_[i] < gate; };
    // Start just after a break so a run never straddles the starting point.
    std::size_t start = 0;
    bool any_break = true;
    if (closed) {
      any_break = false;
      for (std::size_t i = 0; i < n; ++i)
        if (!linked(i)) { start = next(i); any_break = true; break; }
    }
    auto close_run = [&](std::size_t points, double length) {
      if (points > std::size_t(options_.g_min_size)) {
        ++group_count;
        group_points += points;
        group_length_sum += length;
        longest_group = std::max(longest_group, length);
      }
    };
    if (!any_break) {  // every neighbour linked around the whole ring
      close_run(n, distance);
    } else {
      std::size_t points = 0;
      double length = 0.0;
      for (std::size_t step = 0; step < n; ++step) {
        const std::size_t i = start + step < n ? start + step : start + step - n;
        if (!valid_[i]) { close_run(points, length); points = 0; length = 0.0; continue; }
        ++points;
        const bool last = step + 1 == n;
        if (!last && linked(i)) {
          length += segment_[i];
        } else {
          close_run(points, length);
          points = 0;
          length = 0.0;
        }
      }
    }
  }

  // Moments about the mean of the valid points: #3 #6 #7 #16 #19 #20 and principal axes.
  double suu = 0.0, svv = 0.0, suv = 0.0, suuu = 0.0, svvv = 0.0, suvv = 0.0, svuu = 0.0;
  double sum_dev = 0.0, sum_r_sq_dev = 0.0, close_area = 0.0;
  centre_distance_.resize(n);
  distancesFromCentred(x_.data(), y_.data(), n, mean_x, mean_y, 0.0, 0.0, centre_distance_.data());
  for (std::size_t i = 0; i < n; ++i) {
    if (!valid_[i]) continue;
    const double u = x_[i] - mean_x, v = y_[i] - mean_y;
    suu += u * u; svv += v * v; suv += u * v;
    suuu += u * u * u; svvv += v * v * v; suvv += u * v * v; svuu += v * u * u;
    sum_dev += centre_distance_[i];
    sum_r_sq_dev += (clipped_[i] - mean_r) * (clipped_[i] - mean_r);
    close_area += clipped_[i] * clipped_[i];
  }
  const double mean_dev = safeDiv(sum_dev, double(valid_count));
  // Least-squares (Kasa) circle in centred coordinates; degenerate (fewer than three points,
  // or collinear) gives radius 0 and residual 0.
  double circle_radius = 0.0, circle_residual = 0.0, cu = 0.0, cv = 0.0;
  const double det = suu * svv - suv * suv;
  const double trace = suu + svv;
  if (valid_count >= 3 && trace > 0.0 && det > 1e-12 * trace * trace) {
    const double bu = 0.5 * (suuu + suvv), bv = 0.5 * (svvv + svuu);
    cu = (bu * svv - bv * suv) / det;
    cv = (suu * bv - suv * bu) / det;
    circle_radius = std::sqrt(cu * cu + cv * cv + trace / double(valid_count));
  }
  double sum_dev_sq = 0.0;
  if (circle_radius > 0.0) {
    circle_distance_.resize(n);
    distancesFromCentred(x_.data(), y_.data(), n, mean_x, mean_y, cu, cv, circle_distance_.data());
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!valid_[i]) continue;
    const double d = centre_distance_[i] - mean_dev;
    sum_dev_sq += d * d;
    if (circle_radius > 0.0) {
      const double e = circle_radius - circle_distance_[i];
      circle_residual += e * e;
    }
  }
  // Angular step of the scanner for #4: the mean spacing of the beams.
  double angle_step = 0.0;
  if (closed) angle_step = 2.0 * M_PI / double(n);
  else if (n > 1) angle_step = (scan.bearings[n - 1] - scan.bearings[0]) / double(n - 1);

  out[0] = area;
  out[1] = sum_clipped / double(n);
  out[2] = std::hypot(mean_x, mean_y);
  out[3] = close_area * std::sin(0.5 * angle_step);
  out[4] = close_distance;
  out[5] = circle_radius;
  out[6] = circle_residual;
  out[7] = k_mean;
  out[8] = k_std;
  out[9] = distance;
  out[10] = far_distance;
  out[11] = double(group_count);
  out[12] = safeDiv(double(group_points), double(group_count));
  out[13] = double(n - valid_count);
  out[14] = angular;
  out[15] = mean_dev;
  out[16] = sampleStd(sum_seg_sq, segment_count);
  out[17] = double(valid_count);
  out[18] = sampleStd(sum_dev_sq, valid_count);
  out[19] = sampleStd(sum_r_sq_dev, valid_count);
  if (options_.feature_set == FeatureSet::kPaper) return;

  double* extra = out + kPaperNames.size();
  const double beams = double(n);
  extra[0] = double(valid_count) / beams;
  extra[1] = double(n - valid_count) / beams;
  extra[2] = out[12] / beams;
  // The valid ranges, bucketed once for the quantiles below and the range signature.
  std::size_t m = 0;
  work_.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {  // branch-free compaction
    work_[m] = clipped_[i];
    m += valid_[i];
  }
  ranks_.assign(work_.data(), m);
  // Quantiles of the valid ranges by nearest rank.
  if (m > 0) {
    auto rank = [m](double q) { return std::min(m - 1, std::size_t(q * double(m - 1) + 0.5)); };
    extra[3] = ranks_.at(rank(0.10));
    extra[4] = ranks_.at(rank(0.25));
    extra[5] = ranks_.at(rank(0.50));
    extra[6] = ranks_.at(rank(0.75));
    extra[7] = ranks_.at(rank(0.90));
  }
  // Principal axes of the valid points: square roots of the covariance eigenvalues.
  if (valid_count > 1) {
    const double a = suu / double(valid_count), b = suv / double(valid_count),
                 c = svv / double(valid_count);
    const double half_trace = 0.5 * (a + c);
    const double root = std::sqrt(std::max(0.0, 0.25 * (a - c) * (a - c) + b * b));
    const double major = std::sqrt(std::max(0.0, half_trace + root));
    const double minor = std::sqrt(std::max(0.0, half_trace - root));
    extra[8] = major;
    extra[9] = minor;
    extra[10] = safeDiv(minor, major);
  }
  // Gaps: runs of beams without a valid return, and the widest one's angle.
  {
    std::size_t gaps = 0;
    double widest = 0.0;
    std::size_t i = 0;
    // On a closed ring start after a valid beam so the run through the seam is counted once.
    std::size_t start = 0;
    if (closed && valid_count > 0 && valid_count < n) {
      while (valid_[start]) start = next(start);
      while (!valid_[start]) start = next(start);
    }
    const double step = angle_step;
    std::size_t run = 0;
    for (i = 0; i < n; ++i) {
      const std::size_t k = start + i < n ? start + i : start + i - n;
      if (!valid_[k]) { ++run; continue; }
      if (run > 0) { ++gaps; widest = std::max(widest, double(run) * step); }
      run = 0;
    }
    if (run > 0) { ++gaps; widest = std::max(widest, double(run) * step); }
    extra[11] = double(gaps);
    extra[12] = widest;
  }
  extra[13] = longest_group;
  extra[14] = safeDiv(group_length_sum, double(group_count));
  // Histogram of clipped ranges, as fractions of the beams (max-range beams in none of them).
  {
    // Counted as "valid and nearer than each edge" (branch-free sums), then differenced.
    std::size_t below[5] = {0, 0, 0, 0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      const double r = clipped_[i];
      const std::size_t v = valid_[i];
      below[0] += v & (r < 1.0);
      below[1] += v & (r < 2.0);
      below[2] += v & (r < 4.0);
      below[3] += v & (r < 8.0);
      below[4] += v & (r < 16.0);
    }
    const double hist[6] = {double(below[0]),
                            double(below[1] - below[0]),
                            double(below[2] - below[1]),
                            double(below[3] - below[2]),
                            double(below[4] - below[3]),
                            double(valid_count - below[4])};
    for (int b = 0; b < 6; ++b) extra[15 + b] = hist[b] / beams;
  }
  // Signatures: distributions of the ranges, of the distances to the centroid of the valid
  // points, and of chords (a cheap, shift-invariant cousin of Osada's D2 shape distribution).
  double* signature = out + signatureOffset(FeatureSet::kExtended);
  writeQuantiles(ranks_, signature);  // still the valid ranges
  m = 0;
  for (std::size_t i = 0; i < n; ++i) {
    work_[m] = centre_distance_[i];
    m += valid_[i];
  }
  ranks_.assign(work_.data(), m);
  writeQuantiles(ranks_, signature + kSignatureLevels);
  // Chords: distances between valid points an eighth, a quarter and a half of the beams
  // apart, over every beam (cyclically on a closed ring, so a shift changes nothing).
  m = 0;
  for (const std::size_t separation : {n / 8, n / 4, n / 2}) {
    if (separation == 0) continue;
    distancesAhead(x_.data(), y_.data(), n, separation, skip2_.data());
    for (std::size_t i = 0; i + separation < n; ++i) {  // branch-free compaction
      work_[m] = skip2_[i];
      m += valid_[i] & valid_[i + separation];
    }
    if (!closed) continue;
    for (std::size_t i = n - separation; i < n; ++i) {
      const std::size_t j = i + separation - n;
      if (valid_[i] && valid_[j]) work_[m++] = pointDistance(x_[i], y_[i], x_[j], y_[j]);
    }
  }
  ranks_.assign(work_.data(), m);
  writeQuantiles(ranks_, signature + 2 * kSignatureLevels);
  writeOutlineSignatures(closed, n, signature + 3 * kSignatureLevels);
  writeRangeProfileBySector(sector_.data(), clipped_.data(), n, out + profileOffset(FeatureSet::kExtended));
}

void FeatureExtractor::writeOutlineSignatures(bool closed, std::size_t n, double* out) {
  // Room for the points and, after them, the first half again: pairs (i, i + s mod k) are
  // then plain runs for distancesAhead.
  outline_x_.resize(kOutlineMaxPoints + kOutlineMaxPoints / 2);
  outline_y_.resize(outline_x_.size());
  double* px = outline_x_.data();
  double* py = outline_y_.data();
  const std::size_t k = resampleOutline(x_.data(), y_.data(), valid_.data(), step_.data(), n, closed, px, py);
  // D2: distances between points s apart along the outline (cyclically) for every odd s up to
  // k / 2: about a quarter of all pairs, an even sample of them whatever the outline's shape.
  std::copy(px, px + k / 2, px + k);
  std::copy(py, py + k / 2, py + k);
  std::size_t m = 0;
  outline_work_.resize(k * ((k / 2 + 1) / 2));
  for (std::size_t s = 1; s <= k / 2; s += 2) {
    distancesAhead(px, py, k + s, s, outline_work_.data() + m);
    m += k;
  }
  ranks_.assign(outline_work_.data(), m);
  writeQuantiles(ranks_, out);
  // Distances of the outline's points to their centroid.
  double cx = 0.0, cy = 0.0;
  for (std::size_t i = 0; i < k; ++i) cx += px[i], cy += py[i];
  cx = safeDiv(cx, double(k));
  cy = safeDiv(cy, double(k));
  outline_work_.resize(std::max(outline_work_.size(), k));
  distancesFromCentred(px, py, k, cx, cy, 0.0, 0.0, outline_work_.data());
  ranks_.assign(outline_work_.data(), k);
  writeQuantiles(ranks_, out + kSignatureLevels);
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
