#include "laser_loop_closure/core/sim/sim_world.hpp"

#include <algorithm>
#include <cmath>

#include "laser_loop_closure/core/common/random.hpp"

namespace llc {
namespace {

constexpr double kSidewalk = 3.0;        // m from kerb to facade line
constexpr double kParkingOffset = 7.8;   // m from the street centre line to a parked car's centre
constexpr double kKerbFurniture = 11.0;  // m from the centre line to poles and street trees

WorldPoint along(WorldPoint a, WorldPoint b, double s, double depth, WorldPoint inward) {
  const double length = std::hypot(b.x - a.x, b.y - a.y);
  const double ux = (b.x - a.x) / length, uy = (b.y - a.y) / length;
  return {a.x + ux * s + inward.x * depth, a.y + uy * s + inward.y * depth};
}

/// Ray (origin o, unit direction d) against segment ab: distance along the ray or +inf.
double raySegment(double ox, double oy, double dx, double dy, const WorldSegment& s) {
  const double ex = s.b.x - s.a.x, ey = s.b.y - s.a.y;
  const double denominator = dx * ey - dy * ex;
  if (std::abs(denominator) < 1e-12) return INFINITY;
  const double wx = s.a.x - ox, wy = s.a.y - oy;
  const double t = (wx * ey - wy * ex) / denominator;
  const double u = (wx * dy - wy * dx) / denominator;
  return (t > 1e-6 && u >= 0.0 && u <= 1.0) ? t : INFINITY;
}

double rayCircle(double ox, double oy, double dx, double dy, const WorldCircle& c) {
  const double fx = ox - c.centre.x, fy = oy - c.centre.y;
  const double b = fx * dx + fy * dy, cc = fx * fx + fy * fy - c.radius * c.radius;
  const double disc = b * b - cc;
  if (disc < 0.0) return INFINITY;
  const double t = -b - std::sqrt(disc);
  return t > 1e-6 ? t : INFINITY;
}

double pointSegment(double x, double y, const WorldSegment& s) {
  const double ex = s.b.x - s.a.x, ey = s.b.y - s.a.y;
  const double length2 = ex * ex + ey * ey;
  double u = length2 > 0 ? ((x - s.a.x) * ex + (y - s.a.y) * ey) / length2 : 0.0;
  u = std::clamp(u, 0.0, 1.0);
  return std::hypot(x - s.a.x - u * ex, y - s.a.y - u * ey);
}

/// The four sides of a w x h box centred at (x, y), turned by heading.
std::vector<WorldPoint> boxCorners(double x, double y, double heading, double length, double width) {
  const double c = std::cos(heading), s = std::sin(heading);
  std::vector<WorldPoint> corners;
  for (const auto& [u, v] : {std::pair{0.5, 0.5}, {-0.5, 0.5}, {-0.5, -0.5}, {0.5, -0.5}})
    corners.push_back({x + c * u * length - s * v * width, y + s * u * length + c * v * width});
  return corners;
}

}  // namespace

void SimWorld::addSegment(WorldPoint a, WorldPoint b, double appear, double vanish) {
  if (std::hypot(b.x - a.x, b.y - a.y) < 1e-6) return;
  segments_.push_back({a, b, appear, vanish});
}

void SimWorld::addPolyline(const std::vector<WorldPoint>& points) {
  for (std::size_t i = 0; i + 1 < points.size(); ++i) addSegment(points[i], points[i + 1]);
}

SimWorld::SimWorld(const WorldOptions& options) : options_(options) {
  Random random(options.seed * 0x9E3779B97F4A7C15ULL + 17);
  const double pitch = options.block_pitch, inset = 0.5 * options.street_width + kSidewalk;
  const int bx = options.blocks_x, by = options.blocks_y;

  // A facade from a to b (a side of a block, street on the left of a->b... any side: `inward`
  // points away from the street): pieces of 6-25 m set back 0-3 m, with door recesses and
  // gaps between buildings.
  auto facade = [&](WorldPoint a, WorldPoint b, WorldPoint inward, std::vector<WorldPoint>* out) {
    const double length = std::hypot(b.x - a.x, b.y - a.y);
    double s = 0.0;
    out->push_back(a);
    while (s < length - 1e-9) {
      const double piece = std::min(length - s, random.uniform(6.0, 25.0));
      const double next_depth = (s == 0.0 || s + piece >= length - 1e-9) ? 0.0
                                : random.uniform() < 0.55 ? 0.0 : random.uniform(0.5, 3.0);
      out->push_back(along(a, b, s, next_depth, inward));
      const bool inner = s > 0.0 && s + piece < length - 1e-9;
      if (inner && piece > 8.0 && random.uniform() < 0.3) {
        // A gap between two buildings: a driveway or passage 3-8 m wide into a yard whose
        // back wall stands 8-30 m in, so each stretch of street looks different.
        const double at = s + random.uniform(1.0, piece - 7.0), width = std::min(random.uniform(3.0, 8.0), s + piece - at - 1.0);
        const double deep = next_depth + random.uniform(8.0, 30.0);
        out->push_back(along(a, b, at, next_depth, inward));
        out->push_back(along(a, b, at, deep, inward));
        out->push_back(along(a, b, at + width, deep, inward));
        out->push_back(along(a, b, at + width, next_depth, inward));
      } else if (piece > 5.0 && random.uniform() < 0.6) {  // a door: 1.2-2 m wide, 0.4-0.8 m deep
        const double at = s + random.uniform(1.5, piece - 3.5), width = random.uniform(1.2, 2.0);
        const double deep = next_depth + random.uniform(0.4, 0.8);
        out->push_back(along(a, b, at, next_depth, inward));
        out->push_back(along(a, b, at, deep, inward));
        out->push_back(along(a, b, at + width, deep, inward));
        out->push_back(along(a, b, at + width, next_depth, inward));
      }
      out->push_back(along(a, b, s + piece, next_depth, inward));
      s += piece;
    }
  };
  // Parked-car slot: occupied in random intervals, by cars of random size (visits differ).
  // Each slot draws from its own stream, so the rest of the world is the same whatever the
  // parking times and the duration.
  std::uint64_t slot_count = 0;
  auto parkedSlot = [&](double x, double y, double heading) {
    Random slot(options.seed * 0xD1B54A32D192ED03ULL + 0x9E3779B97F4A7C15ULL * ++slot_count);
    double t = -1.0;
    bool occupied = slot.uniform() < 0.6;
    while (t < options.duration) {
      const double next = t + 1.0 + -std::log(1.0 - slot.uniform()) * options.parking_mean_s;
      if (occupied) {
        const double shift = slot.uniform(-0.5, 0.5);
        const auto corners = boxCorners(x + std::cos(heading) * shift, y + std::sin(heading) * shift,
                                        heading + slot.uniform(-0.04, 0.04), slot.uniform(4.0, 5.0),
                                        slot.uniform(1.7, 1.9));
        for (std::size_t k = 0; k < 4; ++k)
          addSegment(corners[k], corners[(k + 1) % 4], t < 0 ? -kForever : t,
                     next >= options.duration ? kForever : next);
      }
      occupied = !occupied;
      t = next;
    }
  };

  blocks_.resize(std::size_t(bx * by));
  for (int j = 0; j < by; ++j)
    for (int i = 0; i < bx; ++i) {
      const double u = random.uniform();
      const BlockKind kind = u < 0.62 ? BlockKind::kBuildings : u < 0.77 ? BlockKind::kPark
                             : u < 0.9 ? BlockKind::kCarPark : BlockKind::kSquare;
      blocks_[std::size_t(j * bx + i)] = kind;
      const WorldPoint lo{i * pitch + inset, j * pitch + inset}, hi{(i + 1) * pitch - inset, (j + 1) * pitch - inset};
      const WorldPoint corner[4] = {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}};
      const WorldPoint inward[4] = {{0, 1}, {-1, 0}, {0, -1}, {1, 0}};
      if (kind == BlockKind::kBuildings) {
        std::vector<WorldPoint> outline;
        for (int k = 0; k < 4; ++k) facade(corner[k], corner[(k + 1) % 4], inward[k], &outline);
        addPolyline(outline);
      } else if (kind == BlockKind::kPark) {
        // Rough hedges 0.5 m inside, with an entrance per side; trees inside.
        for (int k = 0; k < 4; ++k) {
          const WorldPoint a = corner[k], b = corner[(k + 1) % 4];
          const double length = std::hypot(b.x - a.x, b.y - a.y), gate = random.uniform(10.0, length - 14.0);
          std::vector<WorldPoint> hedge;
          for (double s = 0.0; s <= length; s += 2.0) {
            if (s > gate && s < gate + 4.0) {
              addPolyline(hedge);
              hedge.clear();
              continue;
            }
            hedge.push_back(along(a, b, s, 0.5 + random.uniform(-0.15, 0.15), inward[k]));
          }
          addPolyline(hedge);
        }
        for (int t = 0; t < 30; ++t)
          circles_.push_back({{random.uniform(lo.x + 4, hi.x - 4), random.uniform(lo.y + 4, hi.y - 4)},
                              random.uniform(0.2, 0.5)});
      } else if (kind == BlockKind::kCarPark) {
        // A fence with one entrance, rows of parking slots.
        for (int k = 0; k < 4; ++k) {
          const WorldPoint a = corner[k], b = corner[(k + 1) % 4];
          if (k == 0) {
            const double length = std::hypot(b.x - a.x, b.y - a.y);
            addSegment(a, along(a, b, 0.5 * length - 4.0, 0.0, inward[k]));
            addSegment(along(a, b, 0.5 * length + 4.0, 0.0, inward[k]), b);
          } else {
            addSegment(a, b);
          }
        }
        for (double y = lo.y + 10.0; y < hi.y - 8.0; y += 16.0)
          for (double x = lo.x + 4.0; x < hi.x - 3.0; x += 2.8) parkedSlot(x, y, M_PI / 2);
      } else {
        // An open square: a kiosk and a few poles.
        const double cx = 0.5 * (lo.x + hi.x) + random.uniform(-10, 10), cy = 0.5 * (lo.y + hi.y) + random.uniform(-10, 10);
        const auto kiosk = boxCorners(cx, cy, random.uniform(0, M_PI), random.uniform(3, 6), random.uniform(3, 5));
        for (std::size_t k = 0; k < 4; ++k) addSegment(kiosk[k], kiosk[(k + 1) % 4]);
        for (int t = 0; t < 8; ++t)
          circles_.push_back({{random.uniform(lo.x + 2, hi.x - 2), random.uniform(lo.y + 2, hi.y - 2)}, 0.12});
      }
    }
  // The city's edge: a continuous facade beyond the outer streets.
  {
    const double far_lo = -inset, far_hi_x = bx * pitch + inset, far_hi_y = by * pitch + inset;
    const WorldPoint corner[4] = {{far_lo, far_lo}, {far_hi_x, far_lo}, {far_hi_x, far_hi_y}, {far_lo, far_hi_y}};
    const WorldPoint outward[4] = {{0, -1}, {1, 0}, {0, 1}, {-1, 0}};
    std::vector<WorldPoint> outline;
    for (int k = 0; k < 4; ++k) facade(corner[k], corner[(k + 1) % 4], outward[k], &outline);
    addPolyline(outline);
  }
  // Streets: kerb-side poles and trees, parked cars on both sides, moving cars, pedestrians.
  const double street_length = pitch - 2.0 * inset;
  for (int horizontal = 0; horizontal < 2; ++horizontal)
    for (int line = 0; line <= (horizontal ? by : bx); ++line)
      for (int piece = 0; piece < (horizontal ? bx : by); ++piece) {
        // The stretch between two intersections, as (start, direction).
        const WorldPoint start = horizontal ? WorldPoint{piece * pitch + inset, line * pitch}
                                            : WorldPoint{line * pitch, piece * pitch + inset};
        const double heading = horizontal ? 0.0 : M_PI / 2;
        const double ux = std::cos(heading), uy = std::sin(heading);
        for (int side = -1; side <= 1; side += 2) {
          const double nx = -uy * side, ny = ux * side;
          for (double s = random.uniform(2, 12); s < street_length - 2; s += random.uniform(12, 30))
            circles_.push_back({{start.x + ux * s + nx * kKerbFurniture, start.y + uy * s + ny * kKerbFurniture},
                                random.uniform() < 0.5 ? 0.08 : random.uniform(0.25, 0.4)});
          for (double s = 5.0; s < street_length - 5.0; s += 6.5)
            if (random.uniform() < 0.8)
              parkedSlot(start.x + ux * s + nx * kParkingOffset, start.y + uy * s + ny * kParkingOffset, heading);
        }
        for (int m = 0; m < 2; ++m) {  // cars in either direction, in their right lane
          WorldMover car;
          const bool forward = random.uniform() < 0.5;
          car.heading = forward ? heading : heading + M_PI;
          const double lane = 2.0;
          const WorldPoint from = forward ? start : WorldPoint{start.x + ux * street_length, start.y + uy * street_length};
          car.origin = {from.x + std::sin(car.heading) * lane, from.y - std::cos(car.heading) * lane};
          car.speed = random.uniform(5, 12);
          car.start = random.uniform(0, options.duration);
          car.stop = car.start + street_length / car.speed;
          car.length = random.uniform(4.0, 5.0);
          car.width = 1.8;
          movers_.push_back(car);
        }
        for (int m = 0; m < 4; ++m) {  // pedestrians on the sidewalks
          WorldMover walker;
          const int side = random.uniform() < 0.5 ? -1 : 1;
          walker.heading = random.uniform() < 0.5 ? heading : heading + M_PI;
          const double s0 = random.uniform(0, street_length), offset = side * (0.5 * options.street_width + 1.5);
          walker.origin = {start.x + ux * s0 - uy * offset, start.y + uy * s0 + ux * offset};
          walker.speed = random.uniform(1.0, 1.6);
          walker.start = random.uniform(0, options.duration);
          walker.stop = walker.start + random.uniform(10, 60);
          walker.length = walker.width = 0.5;
          movers_.push_back(walker);
        }
      }
  buildGrid();
}

void SimWorld::buildGrid() {
  const double margin = 0.5 * options_.street_width + kSidewalk + 10.0;
  min_x_ = -margin;
  min_y_ = -margin;
  cols_ = int(std::ceil((options_.blocks_x * options_.block_pitch + 2 * margin) / cell_));
  rows_ = int(std::ceil((options_.blocks_y * options_.block_pitch + 2 * margin) / cell_));
  std::vector<std::vector<std::int32_t>> cells(std::size_t(cols_ * rows_));
  auto cover = [&](double x0, double y0, double x1, double y1, std::int32_t item) {
    const int c0 = std::clamp(int(std::floor((std::min(x0, x1) - min_x_) / cell_)), 0, cols_ - 1);
    const int c1 = std::clamp(int(std::floor((std::max(x0, x1) - min_x_) / cell_)), 0, cols_ - 1);
    const int r0 = std::clamp(int(std::floor((std::min(y0, y1) - min_y_) / cell_)), 0, rows_ - 1);
    const int r1 = std::clamp(int(std::floor((std::max(y0, y1) - min_y_) / cell_)), 0, rows_ - 1);
    for (int r = r0; r <= r1; ++r)
      for (int c = c0; c <= c1; ++c) cells[std::size_t(r * cols_ + c)].push_back(item);
  };
  for (std::size_t i = 0; i < segments_.size(); ++i)
    cover(segments_[i].a.x, segments_[i].a.y, segments_[i].b.x, segments_[i].b.y, std::int32_t(i));
  for (std::size_t i = 0; i < circles_.size(); ++i) {
    const WorldCircle& c = circles_[i];
    cover(c.centre.x - c.radius, c.centre.y - c.radius, c.centre.x + c.radius, c.centre.y + c.radius, ~std::int32_t(i));
  }
  cell_start_.assign(cells.size() + 1, 0);
  cell_items_.clear();
  for (std::size_t c = 0; c < cells.size(); ++c) {
    cell_start_[c] = std::uint32_t(cell_items_.size());
    cell_items_.insert(cell_items_.end(), cells[c].begin(), cells[c].end());
  }
  cell_start_[cells.size()] = std::uint32_t(cell_items_.size());
}

double SimWorld::castRay(double x, double y, double angle, double time, double max_range,
                         const std::vector<WorldSegment>* extra) const {
  const double dx = std::cos(angle), dy = std::sin(angle);
  double best = INFINITY;
  if (extra)
    for (const WorldSegment& s : *extra) best = std::min(best, raySegment(x, y, dx, dy, s));
  // Grid walk (Amanatides & Woo): cells in the order the ray enters them; stop once the best
  // hit lies before the cell's far side.
  double gx = (x - min_x_) / cell_, gy = (y - min_y_) / cell_;
  int c = int(std::floor(gx)), r = int(std::floor(gy));
  const int step_c = dx > 0 ? 1 : -1, step_r = dy > 0 ? 1 : -1;
  const double t_delta_c = std::abs(dx) > 1e-12 ? cell_ / std::abs(dx) : INFINITY;
  const double t_delta_r = std::abs(dy) > 1e-12 ? cell_ / std::abs(dy) : INFINITY;
  double t_max_c = std::abs(dx) > 1e-12 ? ((dx > 0 ? c + 1 - gx : gx - c) * cell_) / std::abs(dx) : INFINITY;
  double t_max_r = std::abs(dy) > 1e-12 ? ((dy > 0 ? r + 1 - gy : gy - r) * cell_) / std::abs(dy) : INFINITY;
  double t_cell_end = 0.0;
  while (t_cell_end <= max_range) {
    t_cell_end = std::min(t_max_c, t_max_r);
    if (c >= 0 && c < cols_ && r >= 0 && r < rows_) {
      const std::size_t cell = std::size_t(r * cols_ + c);
      for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
        const std::int32_t item = cell_items_[k];
        if (item >= 0) {
          const WorldSegment& s = segments_[std::size_t(item)];
          if (time < s.appear || time >= s.vanish) continue;
          best = std::min(best, raySegment(x, y, dx, dy, s));
        } else {
          best = std::min(best, rayCircle(x, y, dx, dy, circles_[std::size_t(~item)]));
        }
      }
    }
    if (best <= t_cell_end) break;
    if (t_max_c < t_max_r) {
      c += step_c;
      t_max_c += t_delta_c;
    } else {
      r += step_r;
      t_max_r += t_delta_r;
    }
  }
  return best <= max_range ? best : INFINITY;
}

std::vector<WorldSegment> SimWorld::moverOutlines(double time, double x, double y, double range,
                                                  const std::vector<WorldPoint>& ego, double ego_half_width) const {
  std::vector<WorldSegment> out;
  for (const WorldMover& m : movers_) {
    if (time < m.start || time >= m.stop) continue;
    const double travelled = m.speed * (time - m.start);
    const double c = std::cos(m.heading), s = std::sin(m.heading);
    const double cx = m.origin.x + c * travelled, cy = m.origin.y + s * travelled;
    if (std::hypot(cx - x, cy - y) > range + m.length) continue;
    const bool through_ego = std::any_of(ego.begin(), ego.end(), [&](const WorldPoint& p) {
      const double along = c * (p.x - cx) + s * (p.y - cy), across = -s * (p.x - cx) + c * (p.y - cy);
      return std::abs(along) <= 0.5 * m.length + ego_half_width && std::abs(across) <= 0.5 * m.width + ego_half_width;
    });
    if (through_ego) continue;
    const auto corners = boxCorners(cx, cy, m.heading, m.length, m.width);
    for (std::size_t k = 0; k < 4; ++k) out.push_back({corners[k], corners[(k + 1) % 4]});
  }
  return out;
}

double SimWorld::distanceToSurface(double x, double y, double time, const std::vector<WorldSegment>* extra) const {
  double best = INFINITY;
  for (const WorldSegment& s : segments_)
    if (time >= s.appear && time < s.vanish) best = std::min(best, pointSegment(x, y, s));
  for (const WorldCircle& c : circles_)
    best = std::min(best, std::abs(std::hypot(x - c.centre.x, y - c.centre.y) - c.radius));
  if (extra)
    for (const WorldSegment& s : *extra) best = std::min(best, pointSegment(x, y, s));
  return best;
}

}  // namespace llc
