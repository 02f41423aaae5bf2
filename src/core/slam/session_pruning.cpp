#include "laser_loop_closure/core/slam/session_pruning.hpp"

#include <chrono>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

#include "laser_loop_closure/core/backend/marginalization.hpp"

namespace llc {

std::string SessionPruningOptions::validate() const {
  if (!(place_size > 0.0) || !std::isfinite(place_size)) return "place_size must be a finite number > 0";
  if (heading_sectors < 1 || heading_sectors > 360) return "heading_sectors must be in 1 .. 360";
  return "";
}

namespace {

/// Which keyframes to retire: in each place and heading sector, all but the keep_per_place newest (or oldest).
std::vector<char> keyframesToRetire(const SlamSession& session, const SessionPruningOptions& options, std::size_t* places) {
  // Places are centred on the map's origin and axes, sectors on heading 0: a robot driving
  // along the map's first line, or a corridor along its axes, stays in one place as it wavers
  // by millimetres (with edges there, each wobble across one kept a keyframe more).
  auto placeOf = [&](const Pose2& pose) {
    const double turn = normalizeAngle(pose.theta) / (2.0 * M_PI);  // -0.5 .. 0.5
    const long sectors = long(options.heading_sectors);
    const long sector = ((long(std::floor(turn * double(sectors) + 0.5)) % sectors) + sectors) % sectors;
    return std::make_tuple(long(std::floor(pose.x / options.place_size + 0.5)),
                           long(std::floor(pose.y / options.place_size + 0.5)), sector);
  };
  std::map<std::tuple<long, long, long>, std::size_t> seen;  // place -> keyframes kept there so far
  std::vector<char> retire(session.poses.size(), 0);
  const std::size_t n = session.poses.size();
  if (n > 0) seen[placeOf(session.poses[0])] = 1;  // keyframe 0 anchors the map: it stays, and fills its place
  for (std::size_t j = 1; j < n; ++j) {  // the ones to keep first
    const std::size_t i = options.keep_newest ? n - j : j;
    if (++seen[placeOf(session.poses[i])] > options.keep_per_place) retire[i] = 1;
  }
  *places = seen.size();
  return retire;
}

}  // namespace

SlamSession pruneSession(const SlamSession& session, const SessionPruningOptions& options, SessionPruningResult* result) {
  const auto start = std::chrono::steady_clock::now();
  const std::string bad_options = options.validate();
  if (!bad_options.empty()) throw std::invalid_argument("session pruning: " + bad_options);
  const std::string invalid = session.validate();
  if (!invalid.empty()) throw std::invalid_argument("session pruning: the session is inconsistent: " + invalid);
  SessionPruningResult r;
  r.keyframes_before = session.keyframes.size();
  r.constraints_before = session.constraints.size();
  std::vector<char> retire(session.poses.size(), 0);
  if (options.keep_per_place > 0) retire = keyframesToRetire(session, options, &r.places);
  const PoseGraphReduction reduced = marginalizePoses(session.poses, session.constraints, retire);
  SlamSession out;
  std::vector<std::size_t> index(session.keyframes.size(), SIZE_MAX);
  for (std::size_t i = 0; i < reduced.kept.size(); ++i) {
    const std::size_t old = reduced.kept[i];
    index[old] = i;
    out.keyframes.push_back(session.keyframes[old]);
    out.features.push_back(session.features[old]);
    if (!session.robots.empty()) out.robots.push_back(session.robots[old]);
  }
  out.poses = reduced.poses;
  out.constraints = reduced.edges;
  for (const LoopRecord& record : session.loops) {
    if (index[record.loop.from] == SIZE_MAX || index[record.loop.to] == SIZE_MAX) {
      ++r.loops_dropped;
      continue;
    }
    LoopRecord kept = record;
    kept.loop.from = index[record.loop.from];
    kept.loop.to = index[record.loop.to];
    out.loops.push_back(kept);
  }
  r.keyframes_after = out.keyframes.size();
  r.constraints_after = out.constraints.size();
  r.kept_unfactorizable = reduced.kept_unfactorizable;
  r.mean_kl = reduced.mean_kl;
  r.max_kl = reduced.max_kl;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (result) *result = r;
  return out;
}

}  // namespace llc
