#include "laser_loop_closure/core/features/features.hpp"

#include "laser_loop_closure/core/features/feature_kernels.hpp"
#include "laser_loop_closure/core/features/outline.hpp"
#include "laser_loop_closure/core/features/range_profile.hpp"
#include "laser_loop_closure/core/common/rank_selection.hpp"
#include "laser_loop_closure/core/common/vector_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace llc {
namespace {

/// Writes kSignatureLevels quantiles (at (q + 0.5) / levels, nearest rank) of the selector's values; zeros when empty.
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
  // A beam whose bearing is NaN or infinite gets cosine and sine 0, which prepareBeams takes as
  // no return (they are never both 0 otherwise); sines of half steps next to it are 0 too.
  auto finiteOrZero = [](double value) { return std::isfinite(value) ? value : 0.0; };
  for (std::size_t i = 0; i < n; ++i) {
    cos_[i] = finiteOrZero(std::cos(bearings[i]));
    sin_[i] = finiteOrZero(std::sin(bearings[i]));
    if (i + 1 < n) half_sin_[i] = finiteOrZero(std::sin(0.5 * (bearings[i + 1] - bearings[i])));
  }
  seam_half_sin_ = n > 0 ? finiteOrZero(std::sin(0.5 * (bearings[0] + 2.0 * M_PI - bearings[n - 1]))) : 0.0;
}

std::vector<double> FeatureExtractor::extract(const Scan& scan) {
  std::vector<double> out(size());
  extract(scan, out.data());
  return out;
}

/// What the blocks of one extraction share: the beams' layout and the sums each block leaves
/// for the ones after it (the per-beam values stay in the extractor's work arrays).
struct FeatureExtractor::Shape {
  std::size_t n = 0;        ///< beams
  bool closed = false;      ///< a full circle whose last beam neighbours the first
  double angle_step = 0.0;  ///< rad; the mean spacing of the beams
  BeamSums beams;           ///< measureBeams
  double mean_x = 0.0, mean_y = 0.0, mean_r = 0.0;  ///< of the valid points and their ranges
  NeighbourSums pairs;      ///< measureNeighbours
  double segment_std = 0.0;
  TripleSums triples;       ///< measureTriples
  double curvature_mean = 0.0, curvature_std = 0.0;
  std::size_t group_count = 0, group_points = 0;  ///< measureGroups
  double longest_group = 0.0, group_length_sum = 0.0;
  MomentSums moments;       ///< measureMoments
  double mean_deviation = 0.0, deviation_sum_sq = 0.0, circle_radius = 0.0, circle_residual = 0.0;

  std::size_t next(std::size_t i) const { return i + 1 == n ? 0 : i + 1; }
  /// Beams in the run first..last, through the seam when last < first.
  std::size_t runLength(std::size_t first, std::size_t last) const {
    return (last >= first ? last - first : last + n - first) + 1;
  }
  double groupSizeMean() const { return safeDiv(double(group_points), double(group_count)); }
};

void FeatureExtractor::extract(const Scan& scan, double* out) {
  std::fill(out, out + size(), 0.0);
  Shape shape = measureBeams(scan);
  if (shape.n == 0) return;
  measureNeighbours(shape);
  measureTriples(shape);
  measureGroups(shape);
  measureMoments(shape);
  writePaperFeatures(shape, out);
  if (options_.feature_set == FeatureSet::kPaper) return;
  writeExtraFeatures(shape, out);
  double* signature = out + signatureOffset(FeatureSet::kExtended);
  auto signatureSlot = [signature](Signature kind) { return signature + std::size_t(kind) * kSignatureLevels; };
  writeRangeDistribution(shape, out);
  rankValid(shape, centre_distance_.data());
  writeQuantiles(ranks_, signatureSlot(Signature::kCentroidDistance));
  writeChordSignature(shape, signatureSlot(Signature::kChord));
  writeOutlineSignatures(shape.closed, shape.n, signatureSlot(Signature::kOutlineD2));
  writeRangeProfileBySector(sector_.data(), clipped_.data(), shape.n, out + profileOffset(FeatureSet::kExtended));
}

/// Beams: valid = finite return nearer than r_max; everything else counts as max-range and is
/// clipped to r_max where a feature needs a range (#1, #2, #11). The points get room after
/// them for a closed ring's first half again (the chords).
FeatureExtractor::Shape FeatureExtractor::measureBeams(const Scan& scan) {
  Shape shape;
  const std::size_t n = std::min(scan.ranges.size(), scan.bearings.size());
  if (n == 0) return shape;
  shape.n = n;
  updateTrigonometry(scan.bearings);
  shape.closed = options_.closed_ring && scan.full_circle && n >= 3;
  if (shape.closed) shape.angle_step = 2.0 * M_PI / double(n);
  else if (n > 1) {
    // Between the first and the last beam with a direction: one with none (a non-finite
    // bearing) would make the spacing, and every angle from it, infinite.
    std::size_t first = 0, last = n - 1;
    while (first < n && !std::isfinite(scan.bearings[first])) ++first;
    while (last > first && !std::isfinite(scan.bearings[last])) --last;
    const double step = last > first ? (scan.bearings[last] - scan.bearings[first]) / double(last - first) : 0.0;
    shape.angle_step = std::isfinite(step) ? step : 0.0;
  }
  const std::size_t padded = n + n / 2 + 1;
  clipped_.resize(n); x_.resize(padded); y_.resize(padded); valid_.resize(padded); valid_weight_.resize(n);
  shape.beams = prepareBeams(scan.ranges.data(), cos_.data(), sin_.data(), n, options_.r_max, valid_weight_.data(),
                             clipped_.data(), x_.data(), y_.data());
  for (std::size_t i = 0; i < n; ++i) valid_[i] = valid_weight_[i] != 0.0;
  const double valid = double(shape.beams.valid);
  shape.mean_x = safeDiv(shape.beams.x, valid);
  shape.mean_y = safeDiv(shape.beams.y, valid);
  shape.mean_r = safeDiv(shape.beams.range, valid);
  return shape;
}

/// #1 area, #11 far distance over every neighbour pair; #5 #10 #17 over the segments between
/// neighbouring valid points (segment_[i] = -1 where either end is not valid). step_[i] =
/// |p[i+1] - p[i]|, the seam's too on a closed ring, computed once for all of them.
void FeatureExtractor::measureNeighbours(Shape& shape) {
  const std::size_t n = shape.n;
  const double gate = options_.g_max_dist;
  step_.resize(n);
  distancesAhead(x_.data(), y_.data(), n, 1, step_.data());
  step_[n - 1] = shape.closed ? pointDistance(x_[n - 1], y_[n - 1], x_[0], y_[0]) : 0.0;
  segment_.resize(n);
  NeighbourSums& pairs = shape.pairs;
  pairs = sumNeighbours(clipped_.data(), half_sin_.data(), step_.data(), valid_weight_.data(), n, gate,
                        segment_.data());
  segment_[n - 1] = -1.0;
  if (shape.closed) {  // the seam's pair (n - 1, 0)
    const double d = step_[n - 1];
    pairs.area += clipped_[n - 1] * clipped_[0] * seam_half_sin_;
    pairs.far_distance += d;
    if (valid_[n - 1] && valid_[0]) {
      segment_[n - 1] = d;
      pairs.distance += d;
      if (d < gate) pairs.close_distance += d;
      ++pairs.segments;
    }
  }
  const double segment_mean = safeDiv(pairs.distance, double(pairs.segments));
  shape.segment_std = sampleStd(sumSquaredDeviations(segment_.data(), n, segment_mean), pairs.segments);
}

/// #8 #9 curvature and #15 angular difference over triples of neighbouring valid points.
void FeatureExtractor::measureTriples(Shape& shape) {
  const std::size_t n = shape.n;
  skip2_.resize(n);  // |p[a+2] - p[a]|
  distancesAhead(x_.data(), y_.data(), n, 2, skip2_.data());
  turn_.resize(n);  // the turn at every interior point
  turnAngles(x_.data(), y_.data(), n, turn_.data());
  curvature_.resize(n);
  TripleSums& triples = shape.triples;
  triples = sumTriples(x_.data(), y_.data(), segment_.data(), skip2_.data(), turn_.data(), n, curvature_.data());
  if (shape.closed) {  // the two triples through the seam
    for (std::size_t a = n - 2; a < n; ++a) {
      const std::size_t b = shape.next(a), c = shape.next(b);
      skip2_[a] = pointDistance(x_[a], y_[a], x_[c], y_[c]);
      turn_[a] = angleBetween(x_[b] - x_[a], y_[b] - y_[a], x_[c] - x_[b], y_[c] - y_[b]);
      if (segment_[a] > 0.0 && segment_[b] > 0.0) triples.turn += turn_[a];
      curvature_[a] = tripleCurvature(x_[a], y_[a], x_[b], y_[b], x_[c], y_[c], segment_[a], segment_[b], skip2_[a]);
      if (curvature_[a] >= 0.0) triples.curvature += curvature_[a], ++triples.curved;
    }
  }
  const std::size_t triple_count = shape.closed ? n : (n >= 2 ? n - 2 : 0);
  shape.curvature_mean = safeDiv(triples.curvature, double(triples.curved));
  shape.curvature_std =
      sampleStd(sumSquaredDeviations(curvature_.data(), triple_count, shape.curvature_mean), triples.curved);
}

/// #12 #13 groups: runs of valid neighbours closer than the gate; with a closed ring the run
/// through the seam is one group.
void FeatureExtractor::measureGroups(Shape& shape) {
  const std::size_t n = shape.n;
  const double gate = options_.g_max_dist;
  linked_.resize(n);
  for (std::size_t i = 0; i < n; ++i) linked_[i] = segment_[i] >= 0.0 && segment_[i] < gate;
  run_first_.resize(n + 1);
  run_last_.resize(n + 1);
  auto close_run = [&](std::size_t points, double length) {
    if (points <= std::size_t(options_.g_min_size)) return;
    ++shape.group_count;
    shape.group_points += points;
    shape.group_length_sum += length;
    shape.longest_group = std::max(shape.longest_group, length);
  };
  const std::size_t runs =
      findRuns(valid_.data(), linked_.data(), n, shape.closed, run_first_.data(), run_last_.data());
  if (runs == 0 && shape.beams.valid > 0) close_run(n, shape.pairs.distance);  // linked all round the ring
  for (std::size_t r = 0; r < runs; ++r) {
    const std::size_t first = run_first_[r];
    const std::size_t points = shape.runLength(first, run_last_[r]);
    if (points <= std::size_t(options_.g_min_size)) continue;
    double length = 0.0;
    for (std::size_t i = first, k = 1; k < points; ++k, i = shape.next(i)) length += segment_[i];
    close_run(points, length);
  }
}

/// Moments about the mean of the valid points (#3 #6 #7 #16 #19 #20 and the principal axes),
/// with a least-squares (Kasa) circle in centred coordinates; a degenerate one (fewer than
/// three points, or collinear) gives radius 0 and residual 0.
void FeatureExtractor::measureMoments(Shape& shape) {
  const std::size_t n = shape.n, valid_count = shape.beams.valid;
  centre_distance_.resize(n);
  distancesFromCentred(x_.data(), y_.data(), n, shape.mean_x, shape.mean_y, 0.0, 0.0, centre_distance_.data());
  const MomentSums& moments = shape.moments = sumMoments(x_.data(), y_.data(), clipped_.data(), centre_distance_.data(),
                                                         valid_weight_.data(), n, shape.mean_x, shape.mean_y, shape.mean_r);
  shape.mean_deviation = safeDiv(moments.distance, double(valid_count));
  double cu = 0.0, cv = 0.0;
  const double suu = moments.uu, svv = moments.vv, suv = moments.uv;
  const double det = suu * svv - suv * suv;
  const double trace = suu + svv;
  if (valid_count >= 3 && trace > 0.0 && det > 1e-12 * trace * trace) {
    const double bu = 0.5 * (moments.uuu + moments.uvv), bv = 0.5 * (moments.vvv + moments.vuu);
    cu = (bu * svv - bv * suv) / det;
    cv = (suu * bv - suv * bu) / det;
    shape.circle_radius = std::sqrt(cu * cu + cv * cv + trace / double(valid_count));
  }
  if (shape.circle_radius > 0.0) {
    circle_distance_.resize(n);
    distancesFromCentred(x_.data(), y_.data(), n, shape.mean_x, shape.mean_y, cu, cv, circle_distance_.data());
  }
  sumDeviations(centre_distance_.data(), shape.circle_radius > 0.0 ? circle_distance_.data() : nullptr,
                valid_weight_.data(), n, shape.mean_deviation, shape.circle_radius, &shape.deviation_sum_sq,
                &shape.circle_residual);
}

void FeatureExtractor::writePaperFeatures(const Shape& shape, double* out) {
  auto set = [out](PaperFeature feature, double value) { out[featureIndex(feature)] = value; };
  const std::size_t valid_count = shape.beams.valid;
  set(PaperFeature::kArea, shape.pairs.area);
  set(PaperFeature::kAverageRange, shape.beams.clipped / double(shape.n));
  set(PaperFeature::kCentroid, std::hypot(shape.mean_x, shape.mean_y));
  set(PaperFeature::kCloseArea, shape.moments.squared_range * std::sin(0.5 * shape.angle_step));
  set(PaperFeature::kCloseDistance, shape.pairs.close_distance);
  set(PaperFeature::kCircleRadius, shape.circle_radius);
  set(PaperFeature::kCircleResidual, shape.circle_residual);
  set(PaperFeature::kCurvatureMean, shape.curvature_mean);
  set(PaperFeature::kCurvatureStd, shape.curvature_std);
  set(PaperFeature::kDistance, shape.pairs.distance);
  set(PaperFeature::kFarDistance, shape.pairs.far_distance);
  set(PaperFeature::kGroupCount, double(shape.group_count));
  set(PaperFeature::kGroupSizeMean, shape.groupSizeMean());
  set(PaperFeature::kMaxRangeCount, double(shape.n - valid_count));
  set(PaperFeature::kAngularDifference, shape.triples.turn);
  set(PaperFeature::kMeanDeviation, shape.mean_deviation);
  set(PaperFeature::kRegularity, shape.segment_std);
  set(PaperFeature::kSize, double(valid_count));
  set(PaperFeature::kDeviationStd, sampleStd(shape.deviation_sum_sq, valid_count));
  set(PaperFeature::kRangeStd, sampleStd(shape.moments.range_deviation, valid_count));
}

/// The extended set's scalars but the range quantiles (writeRangeDistribution). Counts are
/// fractions of the beams, so that a model carries over between scanner resolutions.
void FeatureExtractor::writeExtraFeatures(const Shape& shape, double* out) {
  auto set = [out](ExtraFeature feature, double value) { out[featureIndex(feature)] = value; };
  const double beam_count = double(shape.n);
  const std::size_t valid_count = shape.beams.valid;
  set(ExtraFeature::kValidFraction, double(valid_count) / beam_count);
  set(ExtraFeature::kMaxRangeFraction, double(shape.n - valid_count) / beam_count);
  set(ExtraFeature::kGroupSizeFraction, shape.groupSizeMean() / beam_count);
  // Principal axes of the valid points: square roots of the covariance eigenvalues.
  if (valid_count > 1) {
    const MomentSums& moments = shape.moments;
    const double a = moments.uu / double(valid_count), b = moments.uv / double(valid_count);
    const double c = moments.vv / double(valid_count);
    const double half_trace = 0.5 * (a + c);
    const double root = std::sqrt(std::max(0.0, 0.25 * (a - c) * (a - c) + b * b));
    const double major = std::sqrt(std::max(0.0, half_trace + root));
    const double minor = std::sqrt(std::max(0.0, half_trace - root));
    set(ExtraFeature::kPrincipalSigmaMajor, major);
    set(ExtraFeature::kPrincipalSigmaMinor, minor);
    set(ExtraFeature::kAnisotropy, safeDiv(minor, major));
  }
  writeGaps(shape, out);
  set(ExtraFeature::kLongestGroupLength, shape.longest_group);
  set(ExtraFeature::kGroupLengthMean, safeDiv(shape.group_length_sum, double(shape.group_count)));
  writeRangeHistogram(shape, out + featureIndex(ExtraFeature::kRangeHistogram));
}

/// Gaps: runs of beams without a valid return, and the widest one's angle.
void FeatureExtractor::writeGaps(const Shape& shape, double* out) {
  const std::size_t n = shape.n;
  linked_.resize(n);  // reused: 1 where a beam has no valid return
  for (std::size_t i = 0; i < n; ++i) linked_[i] = !valid_[i];
  std::size_t gaps = findRuns(linked_.data(), nullptr, n, shape.closed, run_first_.data(), run_last_.data());
  std::size_t widest = 0;
  for (std::size_t r = 0; r < gaps; ++r) widest = std::max(widest, shape.runLength(run_first_[r], run_last_[r]));
  if (gaps == 0 && shape.beams.valid == 0) gaps = 1, widest = n;  // a closed ring with no return at all
  out[featureIndex(ExtraFeature::kGapCount)] = double(gaps);
  out[featureIndex(ExtraFeature::kWidestGapAngle)] = double(widest) * shape.angle_step;
}

/// Histogram of clipped ranges, as fractions of the beams (max-range beams in none of them),
/// counted as "valid and nearer than each edge" (branch-free sums), then differenced.
void FeatureExtractor::writeRangeHistogram(const Shape& shape, double* out) const {
  std::size_t below[kRangeHistogramBins - 1] = {0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < shape.n; ++i) {
    const double r = clipped_[i];
    const std::size_t v = valid_[i];
    below[0] += v & (r < 1.0);
    below[1] += v & (r < 2.0);
    below[2] += v & (r < 4.0);
    below[3] += v & (r < 8.0);
    below[4] += v & (r < 16.0);
  }
  const double counts[kRangeHistogramBins] = {double(below[0]),           double(below[1] - below[0]),
                                              double(below[2] - below[1]), double(below[3] - below[2]),
                                              double(below[4] - below[3]), double(shape.beams.valid - below[4])};
  for (std::size_t b = 0; b < kRangeHistogramBins; ++b) out[b] = counts[b] / double(shape.n);
}

std::size_t FeatureExtractor::rankValid(const Shape& shape, const double* values) {
  work_.resize(3 * shape.n);
  std::size_t m = 0;
  for (std::size_t i = 0; i < shape.n; ++i) {  // branch-free compaction
    work_[m] = values[i];
    m += valid_[i];
  }
  ranks_.assign(work_.data(), m);
  return m;
}

/// The valid ranges' five quantiles (scalar features) and their signature.
void FeatureExtractor::writeRangeDistribution(const Shape& shape, double* out) {
  const std::size_t m = rankValid(shape, clipped_.data());
  if (m > 0) {
    auto rank = [m](double q) { return std::min(m - 1, std::size_t(q * double(m - 1) + 0.5)); };
    out[featureIndex(ExtraFeature::kRangeQ10)] = ranks_.at(rank(0.10));
    out[featureIndex(ExtraFeature::kRangeQ25)] = ranks_.at(rank(0.25));
    out[featureIndex(ExtraFeature::kRangeQ50)] = ranks_.at(rank(0.50));
    out[featureIndex(ExtraFeature::kRangeQ75)] = ranks_.at(rank(0.75));
    out[featureIndex(ExtraFeature::kRangeQ90)] = ranks_.at(rank(0.90));
  }
  writeQuantiles(ranks_, out + signatureOffset(FeatureSet::kExtended) + std::size_t(Signature::kRange) * kSignatureLevels);
}

/// Chords: distances between valid points an eighth, a quarter and a half of the beams apart,
/// over every beam (cyclically on a closed ring, so a shift changes nothing: the points are
/// followed by the first half of them again). A cheap, shift-invariant cousin of Osada's D2.
void FeatureExtractor::writeChordSignature(const Shape& shape, double* out) {
  const std::size_t n = shape.n;
  if (shape.closed) {
    std::copy(x_.begin(), x_.begin() + long(n / 2), x_.begin() + long(n));
    std::copy(y_.begin(), y_.begin() + long(n / 2), y_.begin() + long(n));
    std::copy(valid_.begin(), valid_.begin() + long(n / 2), valid_.begin() + long(n));
  }
  work_.resize(3 * n);
  std::size_t m = 0;
  for (const std::size_t separation : {n / 8, n / 4, n / 2}) {
    if (separation == 0) continue;
    const std::size_t count = shape.closed ? n : n - separation;
    distancesAhead(x_.data(), y_.data(), count + separation, separation, skip2_.data());
    for (std::size_t i = 0; i < count; ++i) {  // branch-free compaction
      work_[m] = skip2_[i];
      m += valid_[i] & valid_[i + separation];
    }
  }
  ranks_.assign(work_.data(), m);
  writeQuantiles(ranks_, out);
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
  // Their squares are ranked and only the chosen ones rooted: the root is monotone, so this
  // is bit for bit the quantiles of the distances, without thousands of square roots.
  std::copy(px, px + k / 2, px + k);
  std::copy(py, py + k / 2, py + k);
  std::size_t m = 0;
  outline_work_.resize(k * ((k / 2 + 1) / 2));
  for (std::size_t s = 1; s <= k / 2; s += 2) {
    squaredDistancesAhead(px, py, k + s, s, outline_work_.data() + m);
    m += k;
  }
  ranks_.assign(outline_work_.data(), m, RankSelector::Scale::kSquaredDistances);
  writeQuantiles(ranks_, out);
  for (std::size_t q = 0; q < kSignatureLevels; ++q) out[q] = std::sqrt(out[q]);
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

}  // namespace llc
