#include "laser_loop_closure/core/sim/kidnap.hpp"

#include <stdexcept>
#include <string>

namespace llc {

namespace {

/// Frames 0 .. at-1, then frames from `to` on with their odometry and stamps going on from
/// frame at-1 by the recorded steps from frame to-1.
template <class Frame>
std::vector<Frame> carriedAway(const std::vector<Frame>& in, std::size_t at, std::size_t to, Pose2 Frame::*odometry,
                               double Frame::*stamp) {
  const std::size_t n = in.size();
  if (at == 0 || at >= n || to == 0 || to >= n)
    throw std::invalid_argument("kidnap: scans " + std::to_string(at) + " and " + std::to_string(to) +
                                " must both be in 1 .. " + std::to_string(n == 0 ? 0 : n - 1));
  std::vector<Frame> out(in.begin(), in.begin() + std::ptrdiff_t(at));
  const Frame& left = in[at - 1];    // where it was taken from
  const Frame& before = in[to - 1];  // the recorded frame before where it is put
  for (std::size_t i = to; i < n; ++i) {
    Frame frame = in[i];
    frame.*odometry = compose(left.*odometry, between(before.*odometry, frame.*odometry));
    frame.*stamp = left.*stamp + (frame.*stamp - before.*stamp);
    out.push_back(std::move(frame));
  }
  return out;
}

}  // namespace

ScanSequence kidnapped(const ScanSequence& input, std::size_t at, std::size_t to) {
  ScanSequence out;
  out.source = input.source;
  out.has_odometry = input.has_odometry;
  out.merged_count = input.merged_count;
  out.scans = carriedAway(input.scans, at, to, &LoggedScan::odometry, &LoggedScan::stamp);
  for (LoggedScan& scan : out.scans) scan.scan.stamp = scan.stamp;
  return out;
}

SimDrive kidnapped(const SimDrive& drive, std::size_t at, std::size_t to) {
  SimDrive out = drive;
  out.frames = carriedAway(drive.frames, at, to, &SimFrame::odometry, &SimFrame::stamp);
  return out;
}

}  // namespace llc
