#include "laser_loop_closure/core/alignment/correlative_search.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "laser_loop_closure/core/common/file_util.hpp"

namespace llc {

std::string CorrelativeSearchOptions::validate() const {
  if (!(cell > 0.0) || !std::isfinite(cell)) return "cell must be finite and > 0";
  if (!(sigma > 0.0) || !std::isfinite(sigma)) return "sigma must be finite and > 0";
  if (!(max_range > 0.0) || !std::isfinite(max_range)) return "max_range must be finite and > 0";
  if (!(connect_distance >= 0.0) || !std::isfinite(connect_distance)) return "connect_distance must be finite and >= 0";
  if (!(max_translation >= 0.0) || !std::isfinite(max_translation)) return "max_translation must be finite and >= 0";
  if (!(translation_step >= cell) || !std::isfinite(translation_step)) return "translation_step must be finite and >= cell";
  if (!(max_rotation >= 0.0) || !(max_rotation <= 3.2)) return "max_rotation must be in [0, 3.2]";
  if (!(rotation_step > 0.0) || !std::isfinite(rotation_step)) return "rotation_step must be finite and > 0";
  // The search visits every pose of the window: a window of more than a few million poses is
  // a setting mistake, not a search.
  const double translations = 2.0 * std::floor(max_translation / translation_step) + 1.0;
  const double rotations = 2.0 * std::floor(max_rotation / rotation_step) + 1.0;
  if (translations * translations * rotations > 2.0e7) return "the window holds more than 2e7 poses";
  if ((max_range + 3.0 * sigma) / cell > 4000.0) return "the field would exceed 8000 x 8000 cells (max_range / cell)";
  return "";
}

LikelihoodField::LikelihoodField(const Points2& target, const CorrelativeSearchOptions& options) : cell_(options.cell) {
  const double reach = 3.0 * options.sigma;
  Points2 near;
  near.reserve(target.size());
  for (const Point2& p : target)
    if (p.allFinite() && p.norm() <= options.max_range) near.push_back(p);
  if (near.empty()) return;
  double max_x = near.front().x(), max_y = near.front().y();
  min_x_ = max_x, min_y_ = max_y;
  for (const Point2& p : near) {
    min_x_ = std::min(min_x_, p.x()), max_x = std::max(max_x, p.x());
    min_y_ = std::min(min_y_, p.y()), max_y = std::max(max_y, p.y());
  }
  min_x_ -= reach, min_y_ -= reach;
  width_ = int(std::ceil((max_x + reach - min_x_) / cell_)) + 1;
  height_ = int(std::ceil((max_y + reach - min_y_) / cell_)) + 1;
  values_.assign(std::size_t(width_) * std::size_t(height_), 0.0f);
  const int radius = int(std::ceil(reach / cell_));
  const double inverse_two_sigma2 = 1.0 / (2.0 * options.sigma * options.sigma);
  auto stamp = [&](const Point2& p) {
    const int cx = int(std::floor((p.x() - min_x_) / cell_)), cy = int(std::floor((p.y() - min_y_) / cell_));
    for (int y = std::max(0, cy - radius); y <= std::min(height_ - 1, cy + radius); ++y) {
      const double dy = min_y_ + (y + 0.5) * cell_ - p.y();
      for (int x = std::max(0, cx - radius); x <= std::min(width_ - 1, cx + radius); ++x) {
        const double dx = min_x_ + (x + 0.5) * cell_ - p.x();
        float& value = values_[std::size_t(y) * std::size_t(width_) + std::size_t(x)];
        value = std::max(value, float(std::exp(-(dx * dx + dy * dy) * inverse_two_sigma2)));
      }
    }
  };
  // A segment along the beam joins a near and a far surface (a door's edge): not a wall.
  const double min_sine_to_beam = std::sin(10.0 * M_PI / 180.0);
  for (std::size_t k = 0; k < near.size(); ++k) {
    stamp(near[k]);
    if (k == 0) continue;
    const Point2 gap = near[k] - near[k - 1];
    const double length = gap.norm();
    const Point2 beam = (near[k] + near[k - 1]).normalized();
    if (!(length > cell_ && length <= options.connect_distance)) continue;
    if (std::abs(beam.x() * gap.y() - beam.y() * gap.x()) < min_sine_to_beam * length) continue;
    const int steps = int(std::ceil(length / (0.5 * cell_)));
    for (int s = 1; s < steps; ++s) stamp(near[k - 1] + gap * (double(s) / steps));
  }
}

double LikelihoodField::at(double x, double y) const {
  if (!(std::isfinite(x) && std::isfinite(y)) || width_ == 0) return 0.0;
  const double fx = std::floor((x - min_x_) / cell_), fy = std::floor((y - min_y_) / cell_);
  if (fx < 0.0 || fy < 0.0 || fx >= width_ || fy >= height_) return 0.0;
  return values_[std::size_t(fy) * std::size_t(width_) + std::size_t(fx)];
}

namespace {
Points2 strided(const Points2& points, std::size_t max_points) {
  Points2 kept;
  const std::size_t stride = (max_points == 0 || points.size() <= max_points) ? 1 : (points.size() + max_points - 1) / max_points;
  for (std::size_t i = 0; i < points.size(); i += stride)
    if (points[i].allFinite()) kept.push_back(points[i]);
  return kept;
}
}  // namespace

double correlativeScore(const LikelihoodField& field, const Points2& source, const Pose2& pose, std::size_t max_points) {
  const Points2 points = strided(source, max_points);
  if (points.empty()) return 0.0;
  const RigidMotion2 move(pose);
  double sum = 0.0;
  for (const Point2& p : points) {
    const Point2 q = move(p);
    sum += field.at(q.x(), q.y());
  }
  return sum / double(points.size());
}

bool withinWindow(const CorrelativeSearchOptions& window, const Pose2& pose, const Pose2& centre, double margin_steps) {
  const double translation = window.max_translation + margin_steps * window.translation_step;
  return std::abs(pose.x - centre.x) <= translation && std::abs(pose.y - centre.y) <= translation &&
         std::abs(normalizeAngle(pose.theta - centre.theta)) <= window.max_rotation + margin_steps * window.rotation_step;
}

double ambiguousShift(const LikelihoodField& field, const Points2& source, const Pose2& pose, const Point2& direction,
                      double max_shift, double step, double max_drop, std::size_t max_points) {
  if (field.empty() || source.empty() || !isFinite(pose) || !direction.allFinite() || !(step > 0.0)) return 0.0;
  const Points2 points = strided(source, max_points);
  const double floor = correlativeScore(field, points, pose, 0) - max_drop;
  const int steps = int(std::floor(max_shift / step + 1e-9));
  double longest = 0.0;
  for (const double sign : {1.0, -1.0}) {
    for (int i = 1; i <= steps; ++i) {
      const double t = sign * step * i;
      const Pose2 moved{pose.x + t * direction.x(), pose.y + t * direction.y(), pose.theta};
      if (correlativeScore(field, points, moved, 0) < floor) break;
      longest = std::max(longest, step * i);
    }
  }
  return longest;
}

CorrelativeSearchResult searchCorrelative(const LikelihoodField& field, const Points2& source, const Pose2& centre,
                                          const CorrelativeSearchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  CorrelativeSearchResult result;
  const Points2 points = strided(source, options.max_points);
  if (points.empty()) result.reject_reason = "no source points";
  else if (field.empty()) result.reject_reason = "the target has no points within max_range";
  else if (!isFinite(centre)) result.reject_reason = "the window's centre is not finite";
  if (!result.reject_reason.empty()) return result;

  const int half_t = int(std::floor(options.max_translation / options.translation_step + 1e-9));
  const int half_r = int(std::floor(options.max_rotation / options.rotation_step + 1e-9));
  const int side = 2 * half_t + 1;
  const int step_cells = std::max(1, int(std::lround(options.translation_step / field.cell_)));
  const double step = step_cells * field.cell_;  // translations fall on whole cells from the first
  std::vector<double> sums(std::size_t(side) * std::size_t(side));
  double best_score = -1.0, best_distance = 0.0;
  for (int r = -half_r; r <= half_r; ++r) {
    const double theta = centre.theta + r * options.rotation_step;
    const double c = std::cos(theta), s = std::sin(theta);
    std::fill(sums.begin(), sums.end(), 0.0);
    for (const Point2& p : points) {
      // The point at the window's first translation, in cells; each further translation
      // moves it by step_cells.
      const double x0 = c * p.x() - s * p.y() + centre.x - half_t * step - field.min_x_;
      const double y0 = s * p.x() + c * p.y() + centre.y - half_t * step - field.min_y_;
      const long bx = long(std::floor(x0 / field.cell_)), by = long(std::floor(y0 / field.cell_));
      for (int i = 0; i < side; ++i) {
        const long ix = bx + long(i) * step_cells;
        if (ix < 0 || ix >= field.width_) continue;
        for (int j = 0; j < side; ++j) {
          const long iy = by + long(j) * step_cells;
          if (iy < 0 || iy >= field.height_) continue;
          sums[std::size_t(i) * std::size_t(side) + std::size_t(j)] += field.values_[std::size_t(iy) * std::size_t(field.width_) + std::size_t(ix)];
        }
      }
    }
    for (int i = 0; i < side; ++i) {
      for (int j = 0; j < side; ++j) {
        const double score = sums[std::size_t(i) * std::size_t(side) + std::size_t(j)] / double(points.size());
        const double dx = (i - half_t) * step, dy = (j - half_t) * step;
        const double distance = dx * dx + dy * dy + 0.1 * (r * options.rotation_step) * (r * options.rotation_step);
        if (score > best_score + 1e-12 || (score >= best_score - 1e-12 && distance < best_distance)) {
          best_score = score, best_distance = distance;
          result.pose = Pose2{centre.x + dx, centre.y + dy, normalizeAngle(theta)};
        }
      }
    }
    result.poses_scored += std::size_t(side) * std::size_t(side);
  }
  result.found = true;
  result.score = best_score;
  result.seconds = secondsSince(start);
  return result;
}

}  // namespace llc
