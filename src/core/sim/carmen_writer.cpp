#include "laser_loop_closure/core/sim/carmen_writer.hpp"

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace llc {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

void writeLaser(std::FILE* out, const char* type, const std::vector<double>& ranges, const SimScannerOptions& scanner,
                const SimFrame& frame) {
  std::fprintf(out, "%s %zu", type, ranges.size());
  for (double r : ranges) std::fprintf(out, " %.3f", std::isfinite(r) ? r : scanner.max_range);
  // x y theta: the scanner's pose by odometry; then the robot's odometry pose.
  const Pose2 laser = compose(frame.odometry, scanner.mount);
  std::fprintf(out, " %.6f %.6f %.6f %.6f %.6f %.6f %.6f sim %.6f\n", laser.x, laser.y, laser.theta, frame.odometry.x,
               frame.odometry.y, frame.odometry.theta, frame.stamp, frame.stamp);
}

}  // namespace

void writeCarmenLog(const SimDrive& drive, const std::string& path) {
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "w"));
  if (!file) throw std::runtime_error(path + ": cannot write");
  std::FILE* out = file.get();
  std::fprintf(out, "# laser_loop_closure simulated urban drive: seed %llu, %.1f m, %.1f Hz\n",
               static_cast<unsigned long long>(drive.options.seed), drive.options.length_m, drive.options.rate_hz);
  std::fprintf(out, "PARAM robot_frontlaser_offset %.3f\n", drive.front.mount.x);
  if (drive.options.back_scanner) std::fprintf(out, "PARAM robot_rearlaser_offset %.3f\n", drive.back.mount.x);
  double previous_stamp = 0.0;
  Pose2 previous_odometry;
  for (std::size_t k = 0; k < drive.frames.size(); ++k) {
    const SimFrame& frame = drive.frames[k];
    double tv = 0.0, rv = 0.0;
    if (k > 0 && frame.stamp > previous_stamp) {
      const Pose2 step = between(previous_odometry, frame.odometry);
      tv = std::hypot(step.x, step.y) / (frame.stamp - previous_stamp);
      rv = step.theta / (frame.stamp - previous_stamp);
    }
    std::fprintf(out, "ODOM %.6f %.6f %.6f %.6f %.6f 0.000000 %.6f sim %.6f\n", frame.odometry.x, frame.odometry.y,
                 frame.odometry.theta, tv, rv, frame.stamp, frame.stamp);
    writeLaser(out, "FLASER", frame.front, drive.front, frame);
    std::fprintf(out, "TRUEPOS %.6f %.6f %.6f %.6f %.6f %.6f %.6f sim %.6f\n", frame.truth.x, frame.truth.y,
                 frame.truth.theta, frame.odometry.x, frame.odometry.y, frame.odometry.theta, frame.stamp, frame.stamp);
    if (drive.options.back_scanner) writeLaser(out, "RLASER", frame.back, drive.back, frame);
    previous_stamp = frame.stamp;
    previous_odometry = frame.odometry;
  }
  if (std::fflush(out) != 0 || std::ferror(out)) throw std::runtime_error(path + ": write failed");
}

}  // namespace llc
