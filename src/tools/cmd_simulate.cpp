// llc simulate: the deterministic urban drive as sim.bag, sim.log and world.png (and, with
// --robots N, the drive cut into N robots that drive at once as fleet.bag).
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "laser_loop_closure/core/sim/carmen_writer.hpp"
#include "laser_loop_closure/core/sim/kidnap.hpp"
#include "laser_loop_closure/core/common/png_image.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "laser_loop_closure/ros/io/bag_io.hpp"

namespace llc_tool {
namespace {

/// The world from above (0.5 m per pixel, north up) with the route: buildings and fences
/// black, hedges and trees green, parked cars (ever present) grey, the driven path red.
void drawWorld(const llc::SimWorld& world, const llc::SimDrive& drive, const std::string& path) {
  const auto& o = world.options();
  const double margin = 30.0, scale = 2.0;  // pixels per metre
  const double width_m = o.blocks_x * o.block_pitch + 2 * margin, height_m = o.blocks_y * o.block_pitch + 2 * margin;
  llc::RgbImage image(int(width_m * scale), int(height_m * scale), {250, 250, 245});
  auto px = [&](double x) { return (x + margin) * scale; };
  auto py = [&](double y) { return (height_m - margin - y) * scale; };
  for (const llc::WorldSegment& s : world.segments()) {
    const bool parked = std::isfinite(s.appear) || std::isfinite(s.vanish);
    image.line(px(s.a.x), py(s.a.y), px(s.b.x), py(s.b.y), parked ? llc::Rgb{150, 150, 160} : llc::Rgb{20, 20, 20}, 1);
  }
  for (const llc::WorldCircle& c : world.circles())
    image.disc(px(c.centre.x), py(c.centre.y), std::max(1.0, c.radius * scale), {30, 140, 40});
  for (std::size_t k = 1; k < drive.frames.size(); ++k) {
    const llc::Pose2& a = drive.frames[k - 1].truth;
    const llc::Pose2& b = drive.frames[k].truth;
    image.line(px(a.x), py(a.y), px(b.x), py(b.y), {220, 30, 30}, 3);
  }
  if (!drive.frames.empty()) {
    const llc::Pose2& start = drive.frames.front().truth;
    image.disc(px(start.x), py(start.y), 8, {30, 60, 220});
  }
  image.savePng(path);
}

/// --start-frame/--end-frame and --kidnap-at/--kidnap-to (frame numbers of the whole drive).
llc::SimDrive selectedFrames(llc::SimDrive drive, const Args& args) {
  const long n = long(drive.frames.size());
  const long first = args.integer("start-frame", 0), end = args.integer("end-frame", n);
  if (first < 0 || end <= first || end > n)
    throw UsageError("--start-frame and --end-frame must keep frames in 0 .. " + std::to_string(n) + " (the drive has " +
                     std::to_string(n) + ")");
  if (args.has("kidnap-at") != args.has("kidnap-to")) throw UsageError("give both --kidnap-at FRAME and --kidnap-to FRAME, or neither");
  const long at = args.integer("kidnap-at", 0), to = args.integer("kidnap-to", 0);
  if (args.has("kidnap-at") && (at <= first || at >= end || to <= first || to >= end))
    throw UsageError("--kidnap-at and --kidnap-to must be frames after --start-frame and before --end-frame");
  drive.frames = std::vector<llc::SimFrame>(drive.frames.begin() + first, drive.frames.begin() + end);
  if (args.has("kidnap-at")) drive = llc::kidnapped(drive, std::size_t(at - first), std::size_t(to - first));
  return drive;
}

/// --robots N: the drive cut into N consecutive parts, each a robot r1 .. rN driving at once
/// (stamps shifted to the first part's start; --robots-in-turn: each where the drive had it, one
/// after the other), the parts after the first with their odometry in a random frame
/// (--robot-seed): fleet.bag, as multi_robot.launch takes it. "" when not asked.
std::string writeFleet(const llc::SimDrive& drive, const Args& args, const std::string& out_dir) {
  if (!args.has("robots")) return "";
  const long robots = args.integer("robots", 1);
  if (robots < 2 || robots > 16) throw UsageError("--robots must be 2 to 16");
  const std::size_t per_part = drive.frames.size() / std::size_t(robots);
  if (per_part < 2) throw UsageError("--robots: fewer than 2 frames per robot");
  llc::Random random(std::uint64_t(args.integer("robot-seed", 1)));
  std::vector<llc::SimDrive> parts;
  std::vector<llc_ros::SimBagRobot> fleet;
  parts.reserve(std::size_t(robots));
  for (std::size_t r = 0; r < std::size_t(robots); ++r) {
    llc::SimDrive part = drive;
    const std::size_t first = r * per_part, end = r + 1 == std::size_t(robots) ? drive.frames.size() : first + per_part;
    part.frames.assign(drive.frames.begin() + long(first), drive.frames.begin() + long(end));
    parts.push_back(std::move(part));
  }
  for (std::size_t r = 0; r < parts.size(); ++r) {
    llc_ros::SimBagRobot robot{&parts[r], "r" + std::to_string(r + 1)};
    if (r > 0)
      robot.odometry_frame = {random.uniform(-500.0, 500.0), random.uniform(-500.0, 500.0), random.uniform(-M_PI, M_PI)};
    if (!args.has("robots-in-turn")) robot.time_shift = parts[0].frames.front().stamp - parts[r].frames.front().stamp;
    fleet.push_back(robot);
  }
  try {
    llc_ros::writeSimFleetBag(fleet, out_dir + "/fleet.bag");
  } catch (const llc_ros::BagError& e) {
    throw ToolError(e.what());
  }
  return " " + out_dir + "/fleet.bag (" + std::to_string(robots) + " robots r1 .. r" + std::to_string(robots) + ")";
}

}  // namespace

int runSimulate(const Args& args) {
  const std::string out_dir = args.required("out");
  llc::SimDriveOptions options;
  const long seed = args.integer("seed", 1);
  if (seed < 0) throw UsageError("--seed must be zero or more");
  options.seed = std::uint64_t(seed);
  const long route_seed = args.integer("route-seed", 0);
  if (route_seed < 0) throw UsageError("--route-seed must be zero or more");
  options.route_seed = std::uint64_t(route_seed);
  options.length_m = args.number("length-m", 2000.0);
  options.rate_hz = args.number("rate-hz", 10.0);
  options.parking_mean_s = args.number("parking-mean-s", options.parking_mean_s);
  const std::string scanners = args.get("scanners", "front,back");
  if (scanners == "front,back" || scanners == "back,front") options.back_scanner = true;
  else if (scanners == "front") options.back_scanner = false;
  else throw UsageError("--scanners must be 'front,back' or 'front', not '" + scanners + "'");
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw UsageError(invalid);
  prepareOutputFolder("out", out_dir);

  const auto start = std::chrono::steady_clock::now();
  const llc::SimWorld world(llc::simWorldOptions(options));
  llc::SimDrive drive = llc::simulateDrive(world, options);
  const double simulated = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  drive = selectedFrames(drive, args);
  llc::writeCarmenLog(drive, out_dir + "/sim.log");
  try {
    llc_ros::writeSimBag(drive, out_dir + "/sim.bag");
  } catch (const llc_ros::BagError& e) {
    throw ToolError(e.what());
  }
  drawWorld(world, drive, out_dir + "/world.png");
  const std::string fleet = writeFleet(drive, args, out_dir);
  const double drive_seconds = drive.frames.empty() ? 0.0 : drive.frames.back().stamp;
  std::cout << std::fixed << std::setprecision(2) << "frames=" << drive.frames.size() << " drive_seconds=" << drive_seconds
            << " blocks=" << world.options().blocks_x << "x" << world.options().blocks_y
            << " segments=" << world.segments().size() << " circles=" << world.circles().size()
            << " movers=" << world.movers().size() << "\n"
            << "simulated in " << simulated << " s: " << std::setprecision(0)
            << (simulated > 0 ? drive_seconds / simulated : 0.0) << "x real time\n"
            << "wrote " << out_dir << "/sim.bag " << out_dir << "/sim.log " << out_dir << "/world.png" << fleet << "\n";
  return 0;
}

}  // namespace llc_tool
