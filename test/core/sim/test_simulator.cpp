// The simulated drive: determinism, what the CARMEN reader makes of it, geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "laser_loop_closure/core/io/carmen_reader.hpp"
#include "laser_loop_closure/core/sim/carmen_writer.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "../test_util.hpp"

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string simulateTo(const llc_test::TempDir& dir, const std::string& name, std::uint64_t seed, double length) {
  llc::SimDriveOptions options;
  options.seed = seed;
  options.length_m = length;
  const llc::SimWorld world(llc::simWorldOptions(options));
  const llc::SimDrive drive = llc::simulateDrive(world, options);
  const std::string path = dir.file(name);
  llc::writeCarmenLog(drive, path);
  return path;
}

TEST(Simulator, SameSeedSameBytesOtherSeedOtherWorld) {
  llc_test::TempDir dir;
  const std::string a = slurp(simulateTo(dir, "a.log", 7, 250.0));
  const std::string b = slurp(simulateTo(dir, "b.log", 7, 250.0));
  const std::string c = slurp(simulateTo(dir, "c.log", 8, 250.0));
  EXPECT_GT(a.size(), 100000u);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  llc::SimDriveOptions o1, o2;
  o1.seed = 1, o2.seed = 2;
  EXPECT_NE(llc::SimWorld(llc::simWorldOptions(o1)).segments().size(),
            llc::SimWorld(llc::simWorldOptions(o2)).segments().size());
}

TEST(Simulator, TheReaderMergesFrontAndBackInto360DegreeScansOnTheWorldsSurfaces) {
  llc_test::TempDir dir;
  llc::SimDriveOptions options;
  options.seed = 3;
  options.length_m = 150.0;
  const llc::SimWorld world(llc::simWorldOptions(options));
  const llc::SimDrive drive = llc::simulateDrive(world, options);
  llc::writeCarmenLog(drive, dir.file("sim.log"));
  const llc::ScanSequence sequence = llc::loadScanSequence(dir.file("sim.log"));
  ASSERT_EQ(sequence.scans.size(), drive.frames.size());
  EXPECT_EQ(sequence.merged_count, drive.frames.size());
  // Speed 7 m/s at 10 Hz, slower in turns: about 0.7 m per scan.
  EXPECT_GT(double(drive.frames.size()), 150.0 / 0.7 * 0.95);
  std::size_t points = 0, on_surface = 0;
  for (std::size_t k = 0; k < sequence.scans.size(); k += 40) {
    const llc::LoggedScan& logged = sequence.scans[k];
    EXPECT_TRUE(logged.scan.full_circle);
    EXPECT_EQ(logged.scan.size(), 722u);
    const double t = drive.frames[k].stamp;
    const auto movers = world.moverOutlines(t, logged.truth.x, logged.truth.y, 100.0);
    for (std::size_t i = 0; i < logged.scan.size(); i += 7) {
      const double r = logged.scan.ranges[i];
      if (!(r < 79.0)) continue;
      const double b = logged.scan.bearings[i] + logged.truth.theta;
      const double x = logged.truth.x + r * std::cos(b), y = logged.truth.y + r * std::sin(b);
      ++points;
      // Log precision (mm, micro-radians) plus 5 sigma of the 2 cm noise.
      on_surface += world.distanceToSurface(x, y, t, &movers) < 0.11;
    }
  }
  ASSERT_GT(points, 200u);
  EXPECT_GT(double(on_surface) / double(points), 0.995) << on_surface << " of " << points;
}

TEST(Simulator, RaysHitWhatIsThere) {
  llc::SimDriveOptions options;
  const llc::SimWorld world(llc::simWorldOptions(options));
  // From a street centre, looking along the street: the far facade is within 80 m or not at
  // all; looking across the street: a facade, parked car or pole within 14 m.
  const llc::WorldPoint p = world.node(1, 1);
  const double across = world.castRay(p.x + 50.0, p.y, M_PI / 2, 10.0, 80.0);
  EXPECT_LE(across, 13.0 + 3.0 + 0.8 + 1e-9);  // facade line plus the deepest recess and door
  EXPECT_GT(across, 5.0);
  EXPECT_TRUE(std::isinf(world.castRay(p.x, p.y, 0.3, 10.0, 0.5)));  // nothing within 0.5 m
}

TEST(Simulator, NoMoverDrivesThroughTheEgoVehicle) {
  // A car at its midpoint: left out while the ego's axis lies in its box (grown by the given
  // half width), drawn when the ego is 3 m to its side.
  const llc::SimWorld world(llc::simWorldOptions(llc::SimDriveOptions{}));
  const llc::WorldMover& car = world.movers().front();
  ASSERT_GT(car.length, 3.0);
  const double t = 0.5 * (car.start + car.stop), travelled = car.speed * (t - car.start);
  const llc::WorldPoint centre{car.origin.x + std::cos(car.heading) * travelled, car.origin.y + std::sin(car.heading) * travelled};
  const llc::WorldPoint aside{centre.x - std::sin(car.heading) * 3.0, centre.y + std::cos(car.heading) * 3.0};
  const std::size_t all = world.moverOutlines(t, centre.x, centre.y, 10.0).size();
  EXPECT_EQ(world.moverOutlines(t, centre.x, centre.y, 10.0, {centre}, 0.9).size(), all - 4);
  EXPECT_EQ(world.moverOutlines(t, centre.x, centre.y, 10.0, {aside}, 0.9).size(), all);
  // A drive where a car overtook the ego through it (seed 3, route seed 5: before the rule, the
  // front scanner saw the inside of a car, 357 of its 361 beams at 0.4 m): no scanner has most
  // of its beams within 1 m in any frame.
  llc::SimDriveOptions options;
  options.seed = 3, options.route_seed = 5, options.length_m = 700.0;
  const llc::SimDrive drive = llc::simulateDrive(llc::SimWorld(llc::simWorldOptions(options)), options);
  for (std::size_t f = 0; f < drive.frames.size(); ++f)
    for (const std::vector<double>* ranges : {&drive.frames[f].front, &drive.frames[f].back}) {
      const auto near = std::count_if(ranges->begin(), ranges->end(), [](double r) { return r < 1.0; });
      EXPECT_LT(2 * std::size_t(near), ranges->size()) << "frame " << f;
    }
}

TEST(Simulator, BadOptionsAreRefused) {
  llc::SimDriveOptions options;
  options.length_m = -5;
  EXPECT_FALSE(options.validate().empty());
  const llc::SimWorld world(llc::simWorldOptions(llc::SimDriveOptions{}));
  EXPECT_THROW(llc::simulateDrive(world, options), std::invalid_argument);
  options = llc::SimDriveOptions{};
  options.rate_hz = 0;
  EXPECT_FALSE(options.validate().empty());
  options = llc::SimDriveOptions{};
  options.length_m = 1e9;  // would exhaust memory: refused
  EXPECT_FALSE(options.validate().empty());
}

}  // namespace
