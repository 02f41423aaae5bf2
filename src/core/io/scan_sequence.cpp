#include "laser_loop_closure/core/io/scan_sequence.hpp"

#include <algorithm>
#include <cmath>

namespace llc {

std::uint64_t recordedRangesKey(const std::vector<double>& ranges) {
  std::uint64_t hash = 14695981039346656037ull;  // FNV-1a, 64 bits
  auto mix = [&](std::uint64_t value) {
    for (int byte = 0; byte < 8; ++byte) hash = (hash ^ ((value >> (8 * byte)) & 0xff)) * 1099511628211ull;
  };
  mix(ranges.size());
  for (double r : ranges) mix(std::isfinite(r) ? std::uint64_t(std::llround(r * 100.0)) : 0x7ff0000000000000ull);
  return hash == 0 ? 1 : hash;
}

ScanSequence makeScanSequence(const CarmenLog& log, const ScanSequenceOptions& options) {
  ScanSequence sequence;
  sequence.source = log.path;
  sequence.scans.reserve(log.front.size());
  const Pose2 front_mount{log.front_laser_offset, 0.0, 0.0};
  const Pose2 rear_mount{log.rear_laser_offset, 0.0, M_PI};
  std::size_t rear = 0;  // first rear line not yet behind the current front line
  for (std::size_t i = 0; i < log.front.size(); ++i) {
    const CarmenLaser& front = log.front[i];
    LoggedScan logged;
    logged.stamp = front.stamp;
    logged.odometry = front.odometry;
    logged.front_mount = front_mount;
    logged.recorded_ranges_key = recordedRangesKey(front.ranges);
    logged.truth = log.front_truth[i] >= 0 ? log.truth[std::size_t(log.front_truth[i])].truth : front.pose;
    logged.scan = scanFromRanges(front.ranges, front.geometry, front_mount, front.stamp);

    // Candidates: rear lines between the previous and the next front line of the file.
    const std::size_t previous_line = i > 0 ? log.front[i - 1].line : 0;
    const std::size_t next_line = i + 1 < log.front.size() ? log.front[i + 1].line : SIZE_MAX;
    while (rear < log.rear.size() && log.rear[rear].line < previous_line) ++rear;
    const CarmenLaser* best = nullptr;
    for (std::size_t r = rear; options.use_rear && r < log.rear.size() && log.rear[r].line < next_line; ++r) {
      const double gap = std::abs(log.rear[r].stamp - front.stamp);
      if (gap <= options.max_merge_gap && (!best || gap < std::abs(best->stamp - front.stamp)))
        best = &log.rear[r];
    }
    if (best) {
      const Scan back = scanFromRanges(best->ranges, best->geometry, rear_mount, best->stamp);
      logged.scan = mergeScans(logged.scan, back);
      ++sequence.merged_count;
    }
    sequence.scans.push_back(std::move(logged));
  }
  return sequence;
}

ScanSequence loadScanSequence(const std::string& path, const ScanSequenceOptions& options) {
  return makeScanSequence(readCarmenLog(path), options);
}

void shiftOdometry(ScanSequence* sequence, int offset) {
  if (offset == 0 || sequence->scans.empty()) return;
  std::vector<Pose2> odometry;
  odometry.reserve(sequence->scans.size());
  for (const LoggedScan& s : sequence->scans) odometry.push_back(s.odometry);
  const long last = long(odometry.size()) - 1;
  for (long i = 0; i <= last; ++i)
    sequence->scans[std::size_t(i)].odometry = odometry[std::size_t(std::clamp(i + offset, 0L, last))];
}

}  // namespace llc
