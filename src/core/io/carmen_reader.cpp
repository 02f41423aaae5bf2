#include "laser_loop_closure/core/io/carmen_reader.hpp"

#include <zlib.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>

namespace llc {
namespace {

/// Splits a line into whitespace-separated tokens and reads them as numbers on demand.
class Fields {
 public:
  Fields(const std::string& line, const std::string& path, std::size_t number)
      : path_(path), number_(number) {
    std::istringstream in(line);
    std::string token;
    while (in >> token) tokens_.push_back(token);
  }
  std::size_t size() const { return tokens_.size(); }
  const std::string& token(std::size_t i) const { return tokens_[i]; }

  double number(std::size_t i, const char* what) const {
    if (i >= tokens_.size()) fail(std::string("line ends before ") + what);
    const char* text = tokens_[i].c_str();
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(text, &end);
    if (end == text || *end != '\0') fail(std::string("'") + text + "' is not a number (" + what + ")");
    return value;
  }
  std::size_t count(std::size_t i, const char* what) const {
    const double value = number(i, what);
    if (!(value >= 0.0 && value <= 1e6 && value == std::floor(value)))
      fail(std::string("bad ") + what + " '" + tokens_[i] + "'");
    return std::size_t(value);
  }
  Pose2 pose(std::size_t i, const char* what) const {
    return {number(i, what), number(i + 1, what), number(i + 2, what)};
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw CarmenError(path_ + ":" + std::to_string(number_) + ": " + tokens_.front() + ": " + why);
  }

 private:
  std::vector<std::string> tokens_;
  const std::string& path_;
  std::size_t number_;
};

struct GzCloser {
  void operator()(gzFile f) const { gzclose(f); }
};

/// Reads one line of any length; false at end of file.
bool readLine(gzFile file, std::string* line) {
  line->clear();
  char buffer[8192];
  while (gzgets(file, buffer, sizeof buffer) != nullptr) {
    line->append(buffer);
    if (!line->empty() && line->back() == '\n') return true;
  }
  return !line->empty();
}

std::string tooManyValues(std::size_t extra, std::size_t beams) {
  return std::to_string(extra) + " more values than a line with " + std::to_string(beams) +
         " beams holds (ranges beyond the beam count?)";
}

/// FLASER/RLASER: n r_1..r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_ts
CarmenLaser parseFlaser(const Fields& f, std::size_t line) {
  CarmenLaser laser;
  laser.line = line;
  const std::size_t n = f.count(1, "beam count");
  if (f.size() < n + 9) f.fail("expected " + std::to_string(n) + " ranges, 6 pose values and a timestamp");
  // Type, count, ranges, 6 pose values, ipc timestamp, host, logger timestamp: more fields
  // mean more ranges than the count says, which would be read as pose and stamp.
  if (f.size() > n + 11) f.fail(tooManyValues(f.size() - (n + 11), n));
  laser.ranges.resize(n);
  for (std::size_t i = 0; i < n; ++i) laser.ranges[i] = f.number(2 + i, "range");
  laser.geometry = carmenFlaserGeometry(n);
  laser.pose = f.pose(2 + n, "pose");
  laser.odometry = f.pose(5 + n, "odometry pose");
  laser.stamp = f.number(8 + n, "timestamp");
  return laser;
}

/// ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r_1..r_n
/// m rem_1..rem_m laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv fsd ssd
/// turn_axis ipc_timestamp host logger_ts
CarmenLaser parseRobotLaser(const Fields& f, std::size_t line) {
  CarmenLaser laser;
  laser.line = line;
  laser.geometry.angle_min = f.number(2, "start angle");
  const double fov = f.number(3, "field of view");
  laser.geometry.angle_increment = f.number(4, "angular resolution");
  laser.geometry.range_max = f.number(5, "maximum range");
  if (!(fov > 0.0 && fov <= 2.0 * M_PI + 1e-6)) f.fail("field of view must lie in (0, 2 pi]");
  if (!(laser.geometry.angle_increment > 0.0)) f.fail("angular resolution must be positive");
  const std::size_t n = f.count(8, "beam count");
  if (f.size() < 10 + n) f.fail("expected " + std::to_string(n) + " ranges and a remission count");  // before sizing by n
  laser.ranges.resize(n);
  for (std::size_t i = 0; i < n; ++i) laser.ranges[i] = f.number(9 + i, "range");
  const std::size_t m = f.count(9 + n, "remission count");
  const std::size_t tail = 10 + n + m;
  if (f.size() > tail + 14) f.fail(tooManyValues(f.size() - (tail + 14), n));
  laser.pose = f.pose(tail, "laser pose");
  laser.odometry = f.pose(tail + 3, "robot pose");
  laser.stamp = f.number(tail + 11, "timestamp");
  return laser;
}

}  // namespace

CarmenLog readCarmenLog(const std::string& path) {
  std::unique_ptr<gzFile_s, GzCloser> file(gzopen(path.c_str(), "rb"));
  if (!file) throw CarmenError(path + ": cannot open (" + std::strerror(errno) + ")");
  CarmenLog log;
  log.path = path;
  std::string text;
  std::size_t line = 0;
  while (readLine(file.get(), &text)) {
    ++line;
    const std::size_t start = text.find_first_not_of(" \t\r\n");
    if (start == std::string::npos || text[start] == '#') continue;
    const Fields f(text, path, line);
    const std::string& type = f.token(0);
    if (type == "FLASER" || type == "RLASER") {
      CarmenLaser laser = parseFlaser(f, line);
      if (type == "FLASER") {
        log.front.push_back(std::move(laser));
        log.front_truth.push_back(-1);
      } else {
        log.rear.push_back(std::move(laser));
      }
    } else if (type == "ROBOTLASER1") {
      log.front.push_back(parseRobotLaser(f, line));
      log.front_truth.push_back(-1);
    } else if (type == "ODOM") {  // ODOM x y theta tv rv accel ipc_timestamp host logger_ts
      CarmenOdometry odom;
      odom.pose = f.pose(1, "pose");
      odom.stamp = f.number(7, "timestamp");
      log.odometry.push_back(odom);
    } else if (type == "TRUEPOS") {  // TRUEPOS x y theta odom_x odom_y odom_theta ipc_ts ...
      CarmenTruePose truth;
      truth.truth = f.pose(1, "true pose");
      truth.odometry = f.pose(4, "odometry pose");
      truth.stamp = f.number(7, "timestamp");
      truth.line = line;
      log.truth.push_back(truth);
      if (!log.front_truth.empty() && log.front_truth.back() < 0)
        log.front_truth.back() = long(log.truth.size() - 1);
    } else if (type == "PARAM" && f.size() >= 3) {
      if (f.token(1) == "robot_frontlaser_offset") log.front_laser_offset = f.number(2, "offset");
      if (f.token(1) == "robot_rearlaser_offset") log.rear_laser_offset = f.number(2, "offset");
    }
  }
  int error = Z_OK;
  gzerror(file.get(), &error);
  if (error != Z_OK && error != Z_STREAM_END)
    throw CarmenError(path + ":" + std::to_string(line) + ": the compressed file is corrupt or truncated");
  return log;
}

}  // namespace llc
