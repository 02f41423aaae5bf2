// A small RGB raster with line drawing, saved as PNG (zlib), for pictures the tools write.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace llc {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
};

class RgbImage {
 public:
  RgbImage(int width, int height, Rgb background);
  int width() const { return width_; }
  int height() const { return height_; }
  void set(int x, int y, Rgb colour);  ///< ignored outside the image
  Rgb at(int x, int y) const { return pixels_[std::size_t(y * width_ + x)]; }
  /// A line of the given thickness (pixels) between two points (pixel coordinates); with
  /// opacity < 1 it is mixed with what is below (each pixel once per line).
  void line(double x0, double y0, double x1, double y1, Rgb colour, int thickness = 1, double opacity = 1.0);
  void disc(double x, double y, double radius, Rgb colour);
  /// Writes an 8-bit RGB PNG; throws std::runtime_error when it cannot.
  void savePng(const std::string& path) const;

 private:
  int width_, height_;
  std::vector<Rgb> pixels_;
};

}  // namespace llc
