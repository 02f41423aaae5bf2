#include "laser_loop_closure/core/sim/kidnap.hpp"

#include <stdexcept>
#include <string>

namespace llc {

ScanSequence kidnapped(const ScanSequence& input, std::size_t at, std::size_t to) {
  const std::size_t n = input.scans.size();
  if (at == 0 || at >= n || to == 0 || to >= n)
    throw std::invalid_argument("kidnap: scans " + std::to_string(at) + " and " + std::to_string(to) +
                                " must both be in 1 .. " + std::to_string(n - 1));
  ScanSequence out;
  out.source = input.source;
  out.has_odometry = input.has_odometry;
  out.merged_count = input.merged_count;
  out.scans.assign(input.scans.begin(), input.scans.begin() + std::ptrdiff_t(at));
  const LoggedScan& left = input.scans[at - 1];      // where it was taken from
  const LoggedScan& before = input.scans[to - 1];    // the recorded scan before where it is put
  for (std::size_t i = to; i < n; ++i) {
    LoggedScan scan = input.scans[i];
    scan.odometry = compose(left.odometry, between(before.odometry, scan.odometry));
    scan.stamp = left.stamp + (scan.stamp - before.stamp);
    scan.scan.stamp = scan.stamp;
    out.scans.push_back(std::move(scan));
  }
  return out;
}

}  // namespace llc
