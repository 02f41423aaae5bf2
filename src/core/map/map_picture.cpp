#include "laser_loop_closure/core/map/map_picture.hpp"

#include <algorithm>
#include <cmath>

namespace llc {

RgbImage renderMapPicture(const OccupancyGrid& grid, const std::vector<Pose2>& trajectory,
                          const std::vector<PictureLoop>& loops, int max_pixels, int min_pixels) {
  const int largest = std::max(1, std::max(grid.width, grid.height));
  const int pool = std::max(1, (largest + max_pixels - 1) / std::max(1, max_pixels));
  const int zoom = pool == 1 ? std::max(1, std::min(min_pixels / largest, std::max(1, max_pixels) / largest)) : 1;
  const int cells_wide = (grid.width + pool - 1) / pool, cells_high = (grid.height + pool - 1) / pool;
  const int width = std::max(1, cells_wide * zoom), height = std::max(1, cells_high * zoom);
  RgbImage image(width, height, Rgb{205, 205, 205});
  for (int py = 0; py < cells_high; ++py)
    for (int px = 0; px < cells_wide; ++px) {
      int occupied = 0, free = 0;
      for (int dy = 0; dy < pool; ++dy)
        for (int dx = 0; dx < pool; ++dx) {
          const int col = px * pool + dx, row = py * pool + dy;
          if (col >= grid.width || row >= grid.height) continue;
          const int value = grid.at(col, row);
          occupied += value >= 65;
          free += value >= 0 && value <= 20;
        }
      if (occupied == 0 && free == 0) continue;
      const Rgb colour = occupied > 0 ? Rgb{0, 0, 0} : Rgb{255, 255, 255};
      const int y = (cells_high - 1 - py) * zoom;  // image rows go down, map rows go up
      for (int zy = 0; zy < zoom; ++zy)
        for (int zx = 0; zx < zoom; ++zx) image.set(px * zoom + zx, y + zy, colour);
    }
  const double scale = double(zoom) / (grid.resolution * pool);
  auto toPixel = [&](const Pose2& p, double* x, double* y) {
    *x = (p.x - grid.origin_x) * scale;
    *y = double(height) - (p.y - grid.origin_y) * scale;
  };
  for (const bool applied : {false, true})
    for (const PictureLoop& loop : loops) {
      if (loop.applied != applied || loop.from >= trajectory.size() || loop.to >= trajectory.size()) continue;
      double x0, y0, x1, y1;
      toPixel(trajectory[loop.from], &x0, &y0);
      toPixel(trajectory[loop.to], &x1, &y1);
      if (applied) image.line(x0, y0, x1, y1, loop.by_consensus ? Rgb{255, 140, 0} : Rgb{0, 170, 0}, 1);
      else image.line(x0, y0, x1, y1, Rgb{220, 0, 0}, 1, 0.25);
    }
  for (std::size_t i = 1; i < trajectory.size(); ++i) {
    double x0, y0, x1, y1;
    toPixel(trajectory[i - 1], &x0, &y0);
    toPixel(trajectory[i], &x1, &y1);
    image.line(x0, y0, x1, y1, Rgb{30, 80, 220}, 1);
  }
  return image;
}

}  // namespace llc
