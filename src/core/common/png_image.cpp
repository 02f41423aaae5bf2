#include "laser_loop_closure/core/common/png_image.hpp"

#include <zlib.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include "laser_loop_closure/core/common/file_util.hpp"

namespace llc {
namespace {

void putBigEndian(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(char((v >> shift) & 0xFF));
}

void appendChunk(std::string& png, const char* type, const std::string& data) {
  putBigEndian(png, std::uint32_t(data.size()));
  std::string body(type, 4);
  body += data;
  png += body;
  putBigEndian(png, std::uint32_t(crc32(0, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()))));
}

}  // namespace

RgbImage::RgbImage(int width, int height, Rgb background)
    : width_(std::max(1, width)), height_(std::max(1, height)), pixels_(std::size_t(width_) * std::size_t(height_), background) {}

void RgbImage::set(int x, int y, Rgb colour) {
  if (x >= 0 && y >= 0 && x < width_ && y < height_) pixels_[std::size_t(y * width_ + x)] = colour;
}

void RgbImage::line(double x0, double y0, double x1, double y1, Rgb colour, int thickness, double opacity) {
  const double length = std::hypot(x1 - x0, y1 - y0);
  const int steps = std::max(1, int(std::ceil(length * 2)));
  const int half = thickness / 2;
  const double keep = 1.0 - std::clamp(opacity, 0.0, 1.0);
  auto mix = [&](std::uint8_t below, std::uint8_t above) {
    return std::uint8_t(std::lround(keep * below + (1.0 - keep) * above));
  };
  int last_x = INT_MIN, last_y = INT_MIN;
  for (int i = 0; i <= steps; ++i) {
    const double t = double(i) / steps;
    const int x = int(std::lround(x0 + t * (x1 - x0))), y = int(std::lround(y0 + t * (y1 - y0)));
    if (x == last_x && y == last_y) continue;  // steps are half a pixel: do not mix a pixel twice
    last_x = x, last_y = y;
    for (int dy = -half; dy <= half; ++dy)
      for (int dx = -half; dx <= half; ++dx) {
        const int px = x + dx, py = y + dy;
        if (keep == 0.0 || px < 0 || py < 0 || px >= width_ || py >= height_) {
          set(px, py, colour);
          continue;
        }
        const Rgb below = at(px, py);
        set(px, py, Rgb{mix(below.r, colour.r), mix(below.g, colour.g), mix(below.b, colour.b)});
      }
  }
}

void RgbImage::disc(double x, double y, double radius, Rgb colour) {
  const int r = int(std::ceil(radius));
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      if (dx * dx + dy * dy <= radius * radius + 0.5) set(int(std::lround(x)) + dx, int(std::lround(y)) + dy, colour);
}

void RgbImage::savePng(const std::string& path) const {
  std::string raw;  // each row: filter byte 0, then RGB
  raw.reserve(std::size_t(height_) * (1 + 3 * std::size_t(width_)));
  for (int y = 0; y < height_; ++y) {
    raw.push_back(0);
    for (int x = 0; x < width_; ++x) {
      const Rgb& p = pixels_[std::size_t(y * width_ + x)];
      raw.push_back(char(p.r));
      raw.push_back(char(p.g));
      raw.push_back(char(p.b));
    }
  }
  uLongf size = compressBound(uLong(raw.size()));
  std::string compressed(size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&compressed[0]), &size, reinterpret_cast<const Bytef*>(raw.data()),
                uLong(raw.size()), 6) != Z_OK)
    throw std::runtime_error(path + ": PNG compression failed");
  compressed.resize(size);
  std::string png("\x89PNG\r\n\x1a\n", 8), header;
  putBigEndian(header, std::uint32_t(width_));
  putBigEndian(header, std::uint32_t(height_));
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, RGB, deflate, no filter, no interlace
  appendChunk(png, "IHDR", header);
  appendChunk(png, "IDAT", compressed);
  appendChunk(png, "IEND", "");
  writeFileAtomically(path, png);
}

}  // namespace llc
