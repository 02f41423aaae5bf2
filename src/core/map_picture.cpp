#include "laser_loop_closure/core/map_picture.hpp"

#include <algorithm>
#include <cmath>

namespace llc {

RgbImage renderMapPicture(const OccupancyGrid& grid, const std::vector<Pose2>& trajectory,
                          const std::vector<PictureLoop>& loops, int max_pixels) {
  const int largest = std::max(grid.width, grid.height);
  const int pool = std::max(1, (largest + max_pixels - 1) / std::max(1, max_pixels));
  const int width = std::max(1, (grid.width + pool - 1) / pool), height = std::max(1, (grid.height + pool - 1) / pool);
  RgbImage image(width, height, Rgb{205, 205, 205});
  for (int py = 0; py < height; ++py)
    for (int px = 0; px < width; ++px) {
      int occupied = 0, free = 0;
      for (int dy = 0; dy < pool; ++dy)
        for (int dx = 0; dx < pool; ++dx) {
          const int col = px * pool + dx, row = py * pool + dy;
          if (col >= grid.width || row >= grid.height) continue;
          const int value = grid.at(col, row);
          occupied += value >= 65;
          free += value >= 0 && value <= 20;
        }
      const int y = height - 1 - py;  // image rows go down, map rows go up
      if (occupied > 0) image.set(px, y, Rgb{0, 0, 0});
      else if (free > 0) image.set(px, y, Rgb{255, 255, 255});
    }
  const double scale = 1.0 / (grid.resolution * pool);
  auto toPixel = [&](const Pose2& p, double* x, double* y) {
    *x = (p.x - grid.origin_x) * scale;
    *y = double(height) - (p.y - grid.origin_y) * scale;
  };
  for (const PictureLoop& loop : loops) {
    if (loop.from >= trajectory.size() || loop.to >= trajectory.size()) continue;
    double x0, y0, x1, y1;
    toPixel(trajectory[loop.from], &x0, &y0);
    toPixel(trajectory[loop.to], &x1, &y1);
    image.line(x0, y0, x1, y1, loop.applied ? Rgb{0, 170, 0} : Rgb{220, 0, 0}, 1);
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
