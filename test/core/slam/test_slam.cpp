// The SLAM pipeline and what it writes: trajectory error, occupancy grid and its files, the
// parameter list and the shipped config, bad input to the pipeline, and a short simulated drive.
#include <gtest/gtest.h>
#include <Eigen/LU>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <iostream>
#include <set>
#include <sstream>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/map/map_picture.hpp"
#include "laser_loop_closure/core/map/occupancy_grid.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/slam/slam_evaluation.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "../test_util.hpp"

namespace {

const double kInf = std::numeric_limits<double>::infinity();

using llc_test::defaultModel;
using llc_test::frameScan;
using llc_test::simulatedDrive;


TEST(TrajectoryError, RigidlyMovedCopyHasNoErrorAndTheMotionIsFound) {
  const std::vector<llc::Pose2> truth = {{0, 0, 0}, {1, 0, 0.1}, {2, 1, 0.5}, {1, 3, 2.0}};
  const llc::Pose2 motion{3.0, -2.0, 0.7};
  std::vector<llc::Pose2> estimate;
  for (const llc::Pose2& p : truth) estimate.push_back(llc::compose(motion, p));
  llc::Pose2 alignment;
  EXPECT_NEAR(llc::alignedRmsError(estimate, truth, &alignment), 0.0, 1e-12);
  const llc::Pose2 back = llc::compose(alignment, motion);  // the identity
  EXPECT_NEAR(back.x, 0.0, 1e-12);
  EXPECT_NEAR(back.y, 0.0, 1e-12);
  EXPECT_NEAR(back.theta, 0.0, 1e-12);
}

TEST(TrajectoryError, HandWorkedValue) {
  // Truth (-1,0),(1,0); estimate (-1,0),(1,2): centred, the estimate is (-1,-1),(1,1) against
  // (-1,0),(1,0): rotated onto the x axis it is (-sqrt2,0),(sqrt2,0): error sqrt2 - 1 each.
  const double rms = llc::alignedRmsError({{-1, 0, 0}, {1, 2, 0}}, {{-1, 0, 0}, {1, 0, 0}});
  EXPECT_NEAR(rms, std::sqrt(2.0) - 1.0, 1e-12);
  EXPECT_THROW(llc::alignedRmsError({{0, 0, 0}}, {}), std::invalid_argument);
  EXPECT_EQ(llc::alignedRmsError({}, {}), 0.0);
}

TEST(OccupancyGrid, OneScanHandWorked) {
  // Four beams of 1 m along the axes, robot at the origin, 0.1 m cells.
  llc::Scan scan = llc_test::ringScan({1.0, 1.0, 1.0, 1.0});  // bearings -pi, -pi/2, 0, pi/2
  llc::OccupancyGridOptions options;
  options.margin = 0.5;
  const llc::OccupancyGrid grid = llc::buildOccupancyGrid({&scan}, {llc::Pose2{}}, options);
  auto cell = [&](double x, double y) {
    return int(grid.at(int(std::floor((x - grid.origin_x) / grid.resolution)), int(std::floor((y - grid.origin_y) / grid.resolution))));
  };
  const int hit = int(std::lround(100.0 / (1.0 + std::exp(-0.85))));  // 70
  const int miss = int(std::lround(100.0 / (1.0 + std::exp(0.4))));   // 40
  EXPECT_EQ(hit, 70);
  EXPECT_EQ(miss, 40);
  EXPECT_EQ(cell(1.05, 0.05), hit);   // the end of the beam at bearing 0
  EXPECT_EQ(cell(0.05, 1.05), hit);   // bearing pi/2
  EXPECT_EQ(cell(0.55, 0.05), miss);  // crossed
  EXPECT_EQ(cell(0.55, 0.55), -1);    // between beams: never seen
  EXPECT_EQ(cell(-1.3, 0.05), -1);    // beyond the wall
  EXPECT_NEAR(grid.origin_x, -1.5 - 0.1, 0.1 + 1e-9);
}

TEST(OccupancyGrid, NoReturnsAndBadValues) {
  llc::Scan scan = llc_test::ringScan({kInf, std::nan(""), -1.0, 0.0});
  scan.ranges.push_back(2.0);
  scan.bearings.push_back(std::nan(""));  // a beam without a direction
  llc::OccupancyGridOptions options;
  llc::OccupancyGrid grid = llc::buildOccupancyGrid({&scan}, {llc::Pose2{}}, options);
  for (std::int8_t v : grid.cells) EXPECT_EQ(v, -1);  // nothing said anything
  options.no_return_free_range = 2.0;
  grid = llc::buildOccupancyGrid({&scan}, {llc::Pose2{}}, options);
  std::size_t free = 0;
  for (std::int8_t v : grid.cells) free += v == 40;
  EXPECT_EQ(free, 20u);  // the +inf beam at -pi: 2 m of 0.1 m cells
  options.resolution = 0.0;
  EXPECT_THROW(llc::buildOccupancyGrid({&scan}, {llc::Pose2{}}, options), std::invalid_argument);
  EXPECT_THROW(llc::buildOccupancyGrid({&scan}, {}, llc::OccupancyGridOptions{}), std::invalid_argument);
  options = {};
  options.max_cells = 10;
  llc::Scan far = llc_test::ringScan({5.0, 5.0, 5.0, 5.0});
  EXPECT_THROW(llc::buildOccupancyGrid({&far}, {llc::Pose2{}}, options), std::invalid_argument);
}

TEST(OccupancyGrid, MapFilesRoundTripAndRefusals) {
  llc_test::TempDir dir;
  // Several scans from the same spot make the crossed cells free and the ends occupied.
  llc::Scan scan = llc_test::ringScan(std::vector<double>(360, 3.0));
  const std::vector<const llc::Scan*> scans(5, &scan);
  const llc::OccupancyGrid grid = llc::buildOccupancyGrid(scans, std::vector<llc::Pose2>(5, llc::Pose2{1, 2, 0}));
  llc::saveMapFiles(grid, dir.file("map"));
  const llc::OccupancyGrid loaded = llc::loadMapFiles(dir.file("map.yaml"));
  ASSERT_EQ(loaded.width, grid.width);
  ASSERT_EQ(loaded.height, grid.height);
  EXPECT_DOUBLE_EQ(loaded.resolution, grid.resolution);
  EXPECT_DOUBLE_EQ(loaded.origin_x, grid.origin_x);
  EXPECT_DOUBLE_EQ(loaded.origin_y, grid.origin_y);
  std::size_t occupied = 0, free = 0;
  for (std::size_t i = 0; i < grid.cells.size(); ++i) {
    const int expected = grid.cells[i] < 0 ? -1 : grid.cells[i] >= 65 ? 100 : grid.cells[i] <= 19 ? 0 : -1;
    ASSERT_EQ(loaded.cells[i], expected) << "cell " << i;
    occupied += expected == 100, free += expected == 0;
  }
  EXPECT_GT(occupied, 100u);
  EXPECT_GT(free, 1000u);
  // Refusals: truncated pixels, wrong magic, missing image, not YAML.
  std::ifstream in(dir.file("map.pgm"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  llc_test::writeText(dir.file("map.pgm"), bytes.substr(0, bytes.size() / 2));
  EXPECT_THROW(llc::loadMapFiles(dir.file("map.yaml")), std::runtime_error);
  llc_test::writeText(dir.file("map.pgm"), "P2\n1 1\n255\n0\n");
  EXPECT_THROW(llc::loadMapFiles(dir.file("map.yaml")), std::runtime_error);
  llc_test::writeText(dir.file("other.yaml"), "image: missing.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n");
  EXPECT_THROW(llc::loadMapFiles(dir.file("other.yaml")), std::runtime_error);
  llc_test::writeText(dir.file("bad.yaml"), "image: [unclosed\n");
  EXPECT_THROW(llc::loadMapFiles(dir.file("bad.yaml")), std::runtime_error);
}

TEST(MapPicture, DrawsWithinBoundsAtAnySize) {
  llc::Scan scan = llc_test::ringScan(std::vector<double>(90, 4.0));
  const llc::OccupancyGrid grid = llc::buildOccupancyGrid(std::vector<const llc::Scan*>{&scan, &scan}, {llc::Pose2{}, llc::Pose2{1, 0, 0}});
  const std::vector<llc::Pose2> trajectory = {{0, 0, 0}, {1, 0, 0}};
  const llc::RgbImage small = llc::renderMapPicture(grid, trajectory, {{0, 1, true}, {0, 7, false}}, 20);
  EXPECT_LE(std::max(small.width(), small.height()), 20);
  const llc::RgbImage full = llc::renderMapPicture(grid, trajectory, {}, 5000, 0);
  EXPECT_EQ(full.width(), grid.width);
  EXPECT_EQ(full.height(), grid.height);
  // A small grid is magnified by a whole factor, every cell a square of pixels.
  const int zoom = 1000 / std::max(grid.width, grid.height);
  ASSERT_GE(zoom, 2);
  const llc::RgbImage magnified = llc::renderMapPicture(grid, trajectory, {}, 5000, 1000);
  EXPECT_EQ(magnified.width(), zoom * grid.width);
  EXPECT_EQ(magnified.height(), zoom * grid.height);
  for (int row = 0; row < grid.height; ++row)
    for (int col = 0; col < grid.width; ++col) {
      const llc::Rgb a = full.at(col, row), b = magnified.at(zoom * col + zoom - 1, zoom * row + zoom - 1);
      if (a.b == 220 || b.b == 220) continue;  // the trajectory (blue) lies over other pixels at each size
      EXPECT_EQ(b.r, a.r) << col << "," << row;
    }
}

TEST(MapPicture, LoopsAppliedByConsensusAreOrangeTheOthersGreenOrRed) {
  llc::Scan scan = llc_test::ringScan(std::vector<double>(90, 4.0));
  const std::vector<llc::Pose2> trajectory = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
  const llc::OccupancyGrid grid = llc::buildOccupancyGrid({&scan, &scan, &scan, &scan}, trajectory);
  // Three loops, each alone on the diagonals and an edge: the middle of each line shows its colour.
  llc::PictureLoop applied{0, 2, true, false}, by_consensus{1, 3, true, true}, refused{0, 3, false, false};
  const llc::RgbImage image = llc::renderMapPicture(grid, trajectory, {applied, by_consensus, refused}, 5000, 0);
  const auto middle = [&](const llc::Pose2& a, const llc::Pose2& b) {
    const double x = ((a.x + b.x) / 2 - grid.origin_x) / grid.resolution;
    const double y = double(image.height()) - ((a.y + b.y) / 2 - grid.origin_y) / grid.resolution;
    return image.at(int(std::floor(x)), int(std::floor(y)));
  };
  // The diagonals cross in the middle: a quarter of the way along each instead.
  const auto quarter = [&](const llc::Pose2& a, const llc::Pose2& b) {
    return middle(a, llc::Pose2{(a.x + b.x) / 2, (a.y + b.y) / 2, 0});
  };
  EXPECT_EQ(quarter(trajectory[0], trajectory[2]).g, 170);  // green
  EXPECT_EQ(quarter(trajectory[0], trajectory[2]).r, 0);
  const llc::Rgb orange = quarter(trajectory[1], trajectory[3]);
  EXPECT_EQ(orange.r, 255);
  EXPECT_EQ(orange.g, 140);
  EXPECT_EQ(orange.b, 0);
  EXPECT_GT(middle(trajectory[0], trajectory[3]).r, middle(trajectory[0], trajectory[3]).g);  // faint red
}

TEST(PngImage, AFaintLineMixesEachPixelOnce) {
  llc::RgbImage image(10, 3, llc::Rgb{200, 200, 200});
  image.line(0, 1, 9, 1, llc::Rgb{0, 0, 0}, 1, 0.25);
  for (int x = 0; x < 10; ++x) {
    EXPECT_EQ(image.at(x, 1).r, 150) << x;  // 0.75 * 200 + 0.25 * 0, not mixed twice (112)
    EXPECT_EQ(image.at(x, 0).r, 200) << x;
  }
  image.line(0, 1, 9, 1, llc::Rgb{0, 0, 0});
  EXPECT_EQ(image.at(4, 1).r, 0);
  image.line(-5, -5, 20, 20, llc::Rgb{1, 2, 3}, 3, 0.5);  // beyond the edges: clipped, no crash
}

TEST(SlamParameters, NamesAreUniqueAndTheShippedConfigGivesEveryOneAtItsDefault) {
  const std::vector<std::string> names = llc::systemParameterNames();
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size());
  const std::string path = std::string(LLC_SOURCE_DIR) + "/config/slam.yaml";
  // Every parameter is in the file (and nothing else: loading refuses unknown keys).
  const YAML::Node root = YAML::LoadFile(path);
  for (const std::string& name : names) {
    YAML::Node node = YAML::Clone(root);
    std::size_t start = 0;
    for (std::size_t slash; (slash = name.find('/', start)) != std::string::npos; start = slash + 1)
      node = node[name.substr(start, slash - start)];
    EXPECT_TRUE(node[name.substr(start)].IsDefined()) << name << " is not in config/slam.yaml";
  }
  // ... and every value there is the built-in default, so the file documents the code.
  llc::SystemOptions loaded;
  llc::loadSystemOptionsYaml(path, &loaded);
  llc::SystemOptions defaults;
  std::vector<std::string> loaded_values, default_values;
  auto collect = [](std::vector<std::string>* out) {
    return [out](const std::string& name, auto& field) {
      std::ostringstream text;
      text << name << "=" << field;
      out->push_back(text.str());
    };
  };
  llc::visitParameters(loaded, collect(&loaded_values));
  llc::visitParameters(defaults, collect(&default_values));
  EXPECT_EQ(loaded_values, default_values);
}

TEST(SlamParameters, PartialFilesOverrideAndBadFilesAreRefused) {
  llc_test::TempDir dir;
  llc::SystemOptions options;
  llc_test::writeText(dir.file("a.yaml"), "odometry:\n  keyframe_distance: 2.5\nloops:\n  max_candidates: 7\n");
  llc::loadSystemOptionsYaml(dir.file("a.yaml"), &options);
  EXPECT_EQ(options.slam.odometry.keyframe_distance, 2.5);
  EXPECT_EQ(options.slam.loops.max_candidates, 7u);
  EXPECT_EQ(options.slam.odometry.keyframe_angle, llc::ScanOdometryOptions{}.keyframe_angle);
  auto refused = [&](const std::string& text, const std::string& needle) {
    llc_test::writeText(dir.file("b.yaml"), text);
    llc::SystemOptions o;
    try {
      llc::loadSystemOptionsYaml(dir.file("b.yaml"), &o);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  refused("odometry:\n  keyframe_distanse: 1.0\n", "unknown parameter 'odometry/keyframe_distanse'");
  // A margin an earlier version had says what replaced it.
  refused("odometry:\n  track_min_fit_gain: 0.05\n", "'odometry/track_min_fit_gain' (folded into odometry/seed_min_score_gain");
  refused("odometry:\n  keyframe_distance: far\n", "odometry/keyframe_distance");
  refused("loops:\n  max_candidates: -3\n", "loops/max_candidates");
  refused("odometry:\n  keyframe_distance: -1.0\n", "keyframe_distance must be > 0");
  refused("[1, 2, 3]\n", "must be a map");
  refused("odometry: {keyframe_distance: [1\n", "cannot read as YAML");
  EXPECT_THROW(llc::loadSystemOptionsYaml(dir.file("none.yaml"), &options), std::runtime_error);
}

TEST(SlamParameters, CommandLineValuesSetTheSameFieldsAsAFileAndBadOnesAreRefused) {
  llc::SystemOptions options;
  llc::setSystemParameters({{"odometry/keyframe_distance", "2.5"}, {"loops/max_candidates", "7"},
                            {"odometry/scan_matching", "false"}, {"aligner/icp/max_iterations", "12"}},
                           "the command line", &options);
  EXPECT_EQ(options.slam.odometry.keyframe_distance, 2.5);
  EXPECT_EQ(options.slam.loops.max_candidates, 7u);
  EXPECT_FALSE(options.slam.odometry.scan_matching);
  EXPECT_EQ(options.slam.aligner.icp.max_iterations, 12);
  EXPECT_EQ(options.slam.odometry.keyframe_angle, llc::ScanOdometryOptions{}.keyframe_angle);
  auto refused = [](const std::string& name, const std::string& value, const std::string& needle) {
    llc::SystemOptions o;
    try {
      llc::setSystemParameters({{name, value}}, "the command line", &o);
      ADD_FAILURE() << "accepted: " << name << " " << value;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  refused("odometry/keyframe_distanse", "1", "unknown parameter 'odometry/keyframe_distanse'");
  refused("odometry/realign_min_fit_gain", "0.1", "(folded into odometry/seed_min_score_gain in 0.23.0)");
  EXPECT_EQ(llc::retiredParameterNote("odometry/seed_min_score_gain"), "");
  refused("odometry/keyframe_distance", "far", "parameter 'odometry/keyframe_distance': bad value");
  refused("odometry/keyframe_distance", "[1, 2]", "parameter 'odometry/keyframe_distance': bad value");
  refused("loops/max_candidates", "-3", "loops/max_candidates");
  refused("odometry/keyframe_distance", "-1", "keyframe_distance must be > 0");
}

TEST(SlamParameters, DefaultsAsTextNameEveryParameterAndReadBackToTheDefaults) {
  const std::vector<std::pair<std::string, std::string>> defaults = llc::systemParameterDefaults();
  const std::vector<std::string> names = llc::systemParameterNames();
  ASSERT_EQ(defaults.size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(defaults[i].first, names[i]);
  EXPECT_EQ(defaults[1], (std::pair<std::string, std::string>("odometry/keyframe_angle", "0.35")));
  // Set back from their own text, every value is the built-in default again.
  llc::SystemOptions from_text;
  llc::setSystemParameters(defaults, "defaults", &from_text);
  std::vector<std::string> a, b;
  auto collect = [](std::vector<std::string>* out) {
    return [out](const std::string& name, auto& field) {
      std::ostringstream text;
      text.precision(17);
      text << name << "=" << field;
      out->push_back(text.str());
    };
  };
  llc::SystemOptions built_in;
  llc::visitParameters(from_text, collect(&a));
  llc::visitParameters(built_in, collect(&b));
  EXPECT_EQ(a, b);
}

TEST(LoopRefusal, EveryStageThatRefusesWritesItsOwnCode) {
  using llc::LoopRefusal;
  // The place gate's verdict, as the pipeline and the nodelet make it.
  llc::PlaceGateOptions gate;
  const llc::LoopVerdict far = llc::placeGateVerdict(gate, gate.chi2_threshold * 10.0);
  EXPECT_EQ(far.refusal, LoopRefusal::kPlaceGate);
  EXPECT_TRUE(far.refused());
  EXPECT_FALSE(far.reason.empty());
  const llc::LoopVerdict near = llc::placeGateVerdict(gate, 0.0);
  EXPECT_FALSE(near.refused());
  EXPECT_TRUE(near.reason.empty());
  // The aligner on two scans of three points: CRF-match and the global search find no start.
  const llc::ScanAligner aligner;
  const llc::Scan tiny = llc_test::ringScan({1.0, 1.0, 1.0});
  const llc::ScanAlignmentResult none = aligner.align(*aligner.prepare(tiny), *aligner.prepare(tiny));
  EXPECT_EQ(none.refusal, llc::AlignmentRefusal::kNoStart) << none.reject_reason;
  EXPECT_FALSE(none.reject_reason.empty());
  EXPECT_STREQ(llc::alignmentRefusalName(none.refusal), "no_start");
  // Shape validation's and a clean alignment's codes: test_alignment's seen-through and
  // position-std tests.
  // The back end: an unknown keyframe, then a loop that contradicts a certain odometry chain.
  llc::SlamBackEnd back;
  const Eigen::Matrix3d certain = Eigen::Matrix3d::Identity() * 1e-6;
  for (int k = 0; k < 3; ++k) {
    llc::Keyframe keyframe;
    keyframe.scan = llc_test::ringScan(std::vector<double>(36, 2.0));
    (void)back.addKeyframe(keyframe, llc::Pose2{1.0, 0.0, 0.0}, certain);
  }
  llc::LoopClosure loop;
  loop.from = 0, loop.to = 7, loop.accepted = true, loop.covariance = certain;
  EXPECT_EQ(back.addLoop(loop).refusal, LoopRefusal::kBackEndMalformed);
  loop.to = 2, loop.pose = llc::Pose2{-5.0, 3.0, 1.0};  // the chain says (2, 0, 0)
  const llc::LoopRecord gated = back.addLoop(loop);
  ASSERT_FALSE(gated.applied);
  EXPECT_EQ(gated.refusal, LoopRefusal::kBackEndGate) << gated.reject_reason;
  loop.pose = llc::Pose2{2.0, 0.0, 0.0};
  const llc::LoopRecord applied = back.addLoop(loop);
  EXPECT_TRUE(applied.applied) << applied.reject_reason;
  EXPECT_EQ(applied.refusal, LoopRefusal::kNone);
  // Names: distinct, one per kind, usable as report keys.
  std::set<std::string> names;
  for (std::size_t kind = 0; kind < llc::kLoopRefusalKinds; ++kind) {
    const std::string name = llc::loopRefusalName(LoopRefusal(kind));
    EXPECT_EQ(name.find_first_not_of("abcdefghijklmnopqrstuvwxyz_"), std::string::npos) << name;
    names.insert(name);
  }
  EXPECT_EQ(names.size(), llc::kLoopRefusalKinds);
}

TEST(SlamPipeline, BadScansAreSkippedWithAReasonAndNeverThrow) {
  llc::SlamPipeline slam(defaultModel());
  llc::Scan good = llc_test::ringScan(std::vector<double>(360, 4.0));
  good.stamp = 10.0;
  const llc::Pose2 origin{};
  EXPECT_TRUE(slam.addScan(good, 0, &origin).keyframe);
  llc::Scan scan = good;
  scan.stamp = std::nan("");
  EXPECT_EQ(slam.addScan(scan, 1, &origin).skip_reason, "stamp is not finite");
  scan = good;
  scan.bearings.pop_back();
  EXPECT_EQ(slam.addScan(scan, 2, &origin).skip_reason, "ranges and bearings differ in count");
  scan = good;
  scan.stamp = 9.0;
  EXPECT_EQ(slam.addScan(scan, 3, &origin).skip_reason, "time went backwards");
  const llc::Pose2 bad_odometry{std::nan(""), 0, 0};
  scan.stamp = 11.0;
  EXPECT_EQ(slam.addScan(scan, 4, &bad_odometry).skip_reason, "wheel odometry is not finite");
  EXPECT_EQ(slam.counters().skipped_scans, 4u);
  // Each skip also by its name, once each, and none as "none".
  const std::array<std::size_t, llc::kScanRefusalKinds> once = {0, 1, 1, 1, 1};
  EXPECT_EQ(slam.counters().scans_skipped, once);
  std::set<std::string> names;
  for (std::size_t kind = 0; kind < llc::kScanRefusalKinds; ++kind) names.insert(llc::scanRefusalName(llc::ScanRefusal(kind)));
  EXPECT_EQ(names.size(), llc::kScanRefusalKinds);
  // Scans of garbage and of nothing still become keyframes when the wheels say so.
  const std::vector<std::vector<double>> garbage = {
      {}, std::vector<double>(360, std::nan("")), std::vector<double>(360, kInf), std::vector<double>(360, -2.0), {1.0, 2.0}};
  double x = 0.0;
  for (const std::vector<double>& ranges : garbage) {
    llc::Scan bad = ranges.empty() ? llc::Scan{} : llc_test::ringScan(ranges);
    bad.stamp = scan.stamp += 1.0;
    const llc::Pose2 moved{x += 2.0, 0.0, 0.0};
    const llc::SlamStepResult step = slam.addScan(bad, 5, &moved);
    EXPECT_TRUE(step.skip_reason.empty());
    EXPECT_TRUE(step.keyframe);
    EXPECT_FALSE(step.odometry.matched);  // nothing to match: the wheels are used
    // Named: ICP (no points) or the overlap (too few) refused; never "none".
    EXPECT_TRUE(step.odometry.refusal == llc::OdometryRefusal::kIcp ||
                step.odometry.refusal == llc::OdometryRefusal::kLowOverlap)
        << llc::odometryRefusalName(step.odometry.refusal) << ": " << step.odometry.reject_reason;
  }
  EXPECT_EQ(slam.counters().steps_not_matched[std::size_t(llc::OdometryRefusal::kIcp)] +
                slam.counters().steps_not_matched[std::size_t(llc::OdometryRefusal::kLowOverlap)],
            garbage.size());
  for (const llc::Pose2& pose : slam.poses()) EXPECT_TRUE(std::isfinite(pose.x) && std::isfinite(pose.theta));
  EXPECT_NEAR(slam.poses().back().x, x, 1e-6);
}

TEST(SlamBackEnd, KeepsAKeyframeWithUnusableOdometryLooselyLinkedAndSaysWhy) {
  llc::SlamBackEnd back;
  const Eigen::Matrix3d good = 0.01 * Eigen::Matrix3d::Identity();
  EXPECT_EQ(back.addKeyframe(llc::Keyframe{}, llc::Pose2{}, good), "");
  EXPECT_EQ(back.addKeyframe(llc::Keyframe{}, {1.0, 0.0, 0.0}, good), "");
  Eigen::Matrix3d not_positive = Eigen::Matrix3d::Identity();
  not_positive(2, 2) = -1.0;
  // Keyframes 2..4 with a covariance not positive definite, a NaN motion, and a covariance
  // beyond what the filter can hold beside the others (std 1e-12 m): each kept, and named.
  EXPECT_NE(back.addKeyframe(llc::Keyframe{}, {1.0, 0.0, 0.0}, not_positive).find("not positive definite"), std::string::npos);
  EXPECT_NE(back.addKeyframe(llc::Keyframe{}, {std::nan(""), 0.0, 0.0}, good).find("not finite"), std::string::npos);
  EXPECT_NE(back.addKeyframe(llc::Keyframe{}, {1.0, 0.0, 0.0}, 1e-24 * Eigen::Matrix3d::Identity()).find("max_information"),
            std::string::npos);
  llc::Keyframe wheels;
  wheels.has_wheel_odometry = true;
  wheels.wheel_odometry = {std::numeric_limits<double>::infinity(), 0.0, 0.0};
  EXPECT_NE(back.addKeyframe(wheels, {1.0, 0.0, 0.0}, good).find("wheel odometry not finite"), std::string::npos);
  ASSERT_EQ(back.keyframes().size(), 6u);
  EXPECT_FALSE(back.keyframes()[5].has_wheel_odometry);
  EXPECT_EQ(back.counters().loosely_linked_keyframes, 3u);
  // Loose links carry the motion when it is finite (keyframe 2 and 4: one more metre each), none when not.
  const std::vector<double> expected_x = {0.0, 1.0, 2.0, 2.0, 3.0, 4.0};
  for (std::size_t k = 0; k < expected_x.size(); ++k) {
    EXPECT_NEAR(back.poses()[k].x, expected_x[k], 1e-9) << "keyframe " << k;
    EXPECT_TRUE(std::isfinite(back.poses()[k].y));
  }
  EXPECT_GT(back.latestCovariance()(0, 0), 1e3) << "behind a loose link the pose is barely known";
  // The first loop closure places the loosely linked stretch: keyframe 5 seen 5 m from keyframe 0.
  llc::LoopClosure loop;
  loop.from = 0, loop.to = 5, loop.accepted = true;
  loop.pose = {5.0, 0.0, 0.0};
  loop.covariance = good;
  const llc::LoopRecord record = back.addLoop(loop);
  EXPECT_TRUE(record.applied) << record.reject_reason;
  EXPECT_NEAR(back.poses()[5].x, 5.0, 0.05);
  EXPECT_LT(back.latestCovariance()(0, 0), 0.1);
}

TEST(SlamBackEnd, RefusesMalformedKeyframesAndLoopsWithAReason) {
  llc::SlamBackEnd back;
  llc::Keyframe first;
  first.has_wheel_odometry = true;
  first.wheel_odometry = {2.0, 1.0, 0.5};
  EXPECT_EQ(back.addKeyframe(first, llc::Pose2{}, Eigen::Matrix3d::Identity()), "");
  EXPECT_NEAR(back.poses()[0].x, 2.0, 1e-9);  // the first keyframe sits at its wheel pose
  Eigen::Matrix3d not_positive = Eigen::Matrix3d::Identity();
  not_positive(2, 2) = -1.0;
  EXPECT_EQ(back.addKeyframe(llc::Keyframe{}, {1.0, 0.0, 0.0}, 0.01 * Eigen::Matrix3d::Identity()), "");
  ASSERT_EQ(back.keyframes().size(), 2u);

  llc::LoopClosure loop;
  loop.from = 0, loop.to = 5;  // no keyframe 5
  loop.accepted = true;
  EXPECT_FALSE(back.addLoop(loop).applied);
  loop.to = 0;
  EXPECT_NE(back.addLoop(loop).reject_reason, "");  // to itself
  loop.to = 1;
  loop.pose = {1.0, 0.0, 0.0};
  loop.covariance = not_positive;
  EXPECT_FALSE(back.addLoop(loop).applied);
  loop.covariance = 0.01 * Eigen::Matrix3d::Identity();
  loop.pose = {30.0, 0.0, 0.0};  // far from the odometry: the gate refuses it
  const llc::LoopRecord gated = back.addLoop(loop);
  EXPECT_FALSE(gated.applied);
  EXPECT_GT(gated.innovation_chi2, 16.27);
  loop.pose = {1.01, 0.0, 0.0};
  EXPECT_TRUE(back.addLoop(loop).applied);
  EXPECT_EQ(back.counters().refused_loops, 3u);
  EXPECT_EQ(back.counters().refused_by_gate, 1u);
  EXPECT_EQ(back.counters().loops_accepted, 1u);
  EXPECT_EQ(back.loops().size(), 5u);
  // map -> odom: the newest keyframe has no wheel odometry, so identity.
  EXPECT_EQ(back.mapToOdom().x, 0.0);
}

TEST(SlamPipeline, OptionsAreValidatedOnce) {
  llc::SlamOptions options;
  options.odometry.keyframe_distance = 0.0;
  EXPECT_THROW(llc::SlamPipeline(defaultModel(), options), std::invalid_argument);
  options = {};
  options.loops.max_candidates = 0;
  EXPECT_THROW(llc::SlamPipeline(defaultModel(), options), std::invalid_argument);
}

TEST(LoopDetector, FindsARevisitTurnedRoundAndAlignsIt) {
  const llc::SimDrive drive = simulatedDrive(80.0);
  llc::LoopDetectorOptions options;
  options.min_keyframe_gap = 5;
  options.stop_at_first_accepted = false;
  options.max_candidates = 3;
  llc::LoopDetector detector(defaultModel(), llc::ScanAlignerOptions{}, options);
  for (std::size_t i = 0; i < drive.frames.size(); i += 3) detector.add(frameScan(drive, drive.frames[i]));
  EXPECT_THROW(detector.detect(detector.size()), std::out_of_range);
  // Back at the first place, turned by 2 rad: the features of a closed ring do not change.
  const std::size_t query = detector.add(llc::rotateScan(frameScan(drive, drive.frames[0]), 2.0));
  const llc::LoopDetectionResult result = detector.detect(query);
  EXPECT_EQ(result.compared, query - options.min_keyframe_gap);
  ASSERT_FALSE(result.aligned.empty());
  // The best candidates score alike (neighbours of the first place look the same): every
  // accepted one must agree with the truth, and the first place must be among them.
  const llc::Pose2 query_truth = llc::compose(drive.frames[0].truth, llc::Pose2{0.0, 0.0, 2.0});
  bool found_first = false;
  for (const llc::LoopClosure& candidate : result.aligned) {
    EXPECT_EQ(candidate.to, query);
    if (!candidate.accepted) continue;
    const llc::Pose2 truth = llc::between(drive.frames[3 * candidate.from].truth, query_truth);
    const llc::Pose2 error = llc::between(truth, candidate.pose);
    EXPECT_LT(std::hypot(error.x, error.y), 0.1) << "keyframe " << candidate.from;
    EXPECT_LT(std::abs(error.theta), 0.01) << "keyframe " << candidate.from;
    EXPECT_GT(candidate.inlier_share, 0.9);
    found_first |= candidate.from == 0;
  }
  EXPECT_TRUE(found_first);
  // A CandidateCheck is asked about every candidate, best first; what it refuses is not aligned.
  std::vector<std::size_t> asked;
  const llc::LoopDetectionResult refused = detector.detect(query, [&](std::size_t from, std::size_t to) {
    EXPECT_EQ(to, query);
    asked.push_back(from);
    return llc::LoopVerdict{llc::LoopRefusal::kPlaceGate, "not here"};
  });
  EXPECT_EQ(refused.candidates, result.candidates);
  EXPECT_TRUE(refused.aligned.empty());
  ASSERT_EQ(refused.not_aligned.size(), result.aligned.size());
  for (std::size_t k = 0; k < asked.size(); ++k) {
    EXPECT_EQ(asked[k], result.aligned[k].from);
    EXPECT_EQ(refused.not_aligned[k].from, asked[k]);
    EXPECT_EQ(refused.not_aligned[k].score, result.aligned[k].score);
    EXPECT_EQ(refused.not_aligned[k].reject_reason, "not here");
    EXPECT_EQ(refused.not_aligned[k].refusal, llc::LoopRefusal::kPlaceGate);
    EXPECT_FALSE(refused.not_aligned[k].accepted);
  }
  const llc::LoopDetectionResult passed = detector.detect(query, [](std::size_t, std::size_t) { return llc::LoopVerdict{}; });
  ASSERT_EQ(passed.aligned.size(), result.aligned.size());
  EXPECT_TRUE(passed.not_aligned.empty());
  for (std::size_t k = 0; k < passed.aligned.size(); ++k) EXPECT_EQ(passed.aligned[k].pose.x, result.aligned[k].pose.x);

  // checked_candidates: a refused candidate frees its slot for the next best one.
  llc::LoopDetectorOptions wider = options;
  wider.checked_candidates = 10;
  llc::LoopDetector refilling(defaultModel(), llc::ScanAlignerOptions{}, wider);
  for (std::size_t i = 0; i < drive.frames.size(); i += 3) refilling.add(frameScan(drive, drive.frames[i]));
  refilling.add(llc::rotateScan(frameScan(drive, drive.frames[0]), 2.0));
  const std::size_t first_best = result.aligned.front().from;
  const llc::LoopDetectionResult refilled = refilling.detect(
      query, [&](std::size_t from, std::size_t) {
        return from == first_best ? llc::LoopVerdict{llc::LoopRefusal::kPlaceGate, "not here"} : llc::LoopVerdict{};
      });
  ASSERT_GT(refilled.candidates, options.max_candidates) << "the test needs more candidates than max_candidates";
  EXPECT_EQ(refilled.aligned.size(), options.max_candidates);
  ASSERT_EQ(refilled.not_aligned.size(), 1u);
  EXPECT_EQ(refilled.not_aligned.front().from, first_best);
  for (const llc::LoopClosure& candidate : refilled.aligned) EXPECT_NE(candidate.from, first_best);
  wider.checked_candidates = 2;  // fewer than max_candidates
  EXPECT_NE(wider.validate().find("checked_candidates"), std::string::npos);

  const llc::LoopClosure& loop = result.aligned.front();
  // Its covariance is at least the floor, and positive definite.
  EXPECT_GE(loop.covariance(0, 0), options.translation_sigma * options.translation_sigma);
  EXPECT_GT(loop.covariance.determinant(), 0.0);
  // A model made with other feature parameters cannot be swapped in.
  llc::ClassifierModel other = defaultModel();
  other.features.r_max = 20.0;
  EXPECT_THROW(detector.setModel(other), std::invalid_argument);
}

TEST(LoopDetector, CalibrationSetsKFromTheScoresOfSurelyDifferentPairs) {
  const llc::SimDrive drive = simulatedDrive(80.0);
  llc::LoopDetectorOptions options;
  options.calibration.enabled = true;
  options.calibration.min_pairs = 30;
  options.calibration.target_false_alarm = 0.1;
  llc::LoopDetector detector(defaultModel(), llc::ScanAlignerOptions{}, options);
  for (std::size_t i = 0; i < drive.frames.size(); i += 3) detector.add(frameScan(drive, drive.frames[i]));
  ASSERT_GE(detector.size(), 20u);
  const double model_k = defaultModel().classifier.thresholdK();
  EXPECT_DOUBLE_EQ(detector.threshold(), model_k);
  // Keyframe q against the ten oldest, for q = 10, 11, 12: 30 pairs, then K is their 90% quantile.
  std::vector<double> fed;
  for (std::size_t q = 10; q < 13; ++q) {
    std::vector<std::size_t> others(10);
    for (std::size_t j = 0; j < 10; ++j) others[j] = j, fed.push_back(detector.pairScore(j, q));
    EXPECT_EQ(detector.calibrate(q, others), 10u);
    if (q < 12) {
      EXPECT_DOUBLE_EQ(detector.threshold(), model_k) << "too few pairs yet";
    }
  }
  EXPECT_EQ(detector.calibrator().seen(), 30u);
  EXPECT_DOUBLE_EQ(detector.threshold(), llc::thresholdForFalseAlarm(fed, 0.1));
  // pairScore is the score detect() gives the pair.
  const llc::LoopDetectionResult result = detector.detect(detector.size() - 1);
  for (const llc::LoopClosure& loop : result.aligned)
    EXPECT_NEAR(loop.score, detector.pairScore(loop.from, loop.to), 1e-5);
  // A new model: the scores were the old model's, so the calibration starts again.
  detector.setModel(defaultModel());
  EXPECT_EQ(detector.calibrator().seen(), 0u);
  EXPECT_DOUBLE_EQ(detector.threshold(), model_k);
  // A threshold set by hand is never overridden.
  options.score_threshold = 0.3;
  llc::LoopDetector fixed(defaultModel(), llc::ScanAlignerOptions{}, options);
  for (std::size_t i = 0; i < 13; ++i) fixed.add(frameScan(drive, drive.frames[3 * i]));
  for (std::size_t q = 10; q < 13; ++q) fixed.calibrate(q, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9});
  EXPECT_TRUE(fixed.calibrator().calibrated());
  EXPECT_DOUBLE_EQ(fixed.threshold(), 0.3);
  options.calibration.max_path = -1.0;
  EXPECT_THROW(llc::LoopDetector(defaultModel(), llc::ScanAlignerOptions{}, options), std::invalid_argument);
}

TEST(LoopDetector, TheDefaultModelKnowsAPlaceAtHalfTheBeams) {
  // Real scanners of one field of view differ in resolution (the shared logs have 180 and 360
  // beams over 180 degrees): a model must not depend on the beam count. The front scanner of
  // the simulated drive (361 beams) against the same scan with every second beam (181 beams,
  // twice the step) must be one place.
  const llc::SimDrive drive = simulatedDrive(600.0);
  auto frontScan = [&](const llc::SimFrame& frame, std::size_t step) {
    llc::ScannerGeometry g;
    g.angle_min = llc::simBeamAngle(drive.front, 0);
    g.angle_increment = step * (llc::simBeamAngle(drive.front, 1) - g.angle_min);
    g.range_max = drive.front.max_range;
    std::vector<double> ranges;
    for (std::size_t i = 0; i < frame.front.size(); i += step) ranges.push_back(frame.front[i]);
    return llc::scanFromRanges(ranges, g, drive.front.mount, frame.stamp);
  };
  const llc::ClassifierModel model = defaultModel();
  llc::FeatureExtractor extractor(model.features);
  const double k = model.classifier.thresholdK();
  std::size_t same = 0, apart = 0, apart_same_resolution = 0, tried = 0, tried_apart = 0;
  const std::size_t stride = drive.frames.size() / 20;
  for (std::size_t i = 0; i + stride < drive.frames.size(); i += stride) {
    const std::vector<double> fine = extractor.extract(frontScan(drive.frames[i], 1));
    const std::vector<double> coarse = extractor.extract(frontScan(drive.frames[i], 2));
    same += model.classifier.score(llc::pairFeatures(model.features.feature_set, fine, coarse).data()) >= k;
    ++tried;
    // The place half the drive on, at the other resolution.
    const llc::SimFrame& other = drive.frames[(i + drive.frames.size() / 2) % drive.frames.size()];
    if (std::hypot(other.truth.x - drive.frames[i].truth.x, other.truth.y - drive.frames[i].truth.y) < 20.0) continue;
    const std::vector<double> far = extractor.extract(frontScan(other, 2));
    const std::vector<double> far_fine = extractor.extract(frontScan(other, 1));
    apart += model.classifier.score(llc::pairFeatures(model.features.feature_set, fine, far).data()) < k;
    apart_same_resolution += model.classifier.score(llc::pairFeatures(model.features.feature_set, fine, far_fine).data()) < k;
    ++tried_apart;
  }
  RecordProperty("same_place_across_resolutions", std::to_string(same) + "/" + std::to_string(tried));
  RecordProperty("places_apart_across_resolutions", std::to_string(apart) + "/" + std::to_string(tried_apart));
  RecordProperty("places_apart_same_resolution", std::to_string(apart_same_resolution) + "/" + std::to_string(tried_apart));
  EXPECT_GE(tried, 19u);
  EXPECT_GE(same * 10, tried * 9) << same << " of " << tried << " scans known at half the beams";
  // Places apart: the front halves of this street look alike to a model of indoor logs (15 of
  // 20 kept apart at one resolution when written), so the test is that half the beams make
  // no more of them look alike.
  EXPECT_GE(apart + 1, apart_same_resolution) << apart << " of " << tried_apart << " places apart kept apart across "
                                              << "resolutions, " << apart_same_resolution << " at one";
  EXPECT_GE(tried_apart, 10u);
}

TEST(LoopDetector, ParameterCovarianceOfALeftPerturbation) {
  // A pure rotation d_theta about the target origin moves a pose at (2, 0) by (0, 2 d_theta).
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  c(2, 2) = 0.01;
  const Eigen::Matrix3d p = llc::poseParameterCovariance({2.0, 0.0, 0.3}, c);
  EXPECT_NEAR(p(1, 1), 0.04, 1e-15);
  EXPECT_NEAR(p(1, 2), 0.02, 1e-15);
  EXPECT_NEAR(p(0, 0), 0.0, 1e-15);
  EXPECT_NEAR(p(2, 2), 0.01, 1e-15);
}

/// A short simulated drive through the pipeline, wheels or no wheels: keyframes about every
/// keyframe_distance, scan matching far better than the drifting wheel odometry.
class SlamOnShortDrive : public ::testing::TestWithParam<bool> {};

TEST_P(SlamOnShortDrive, ScanMatchingBeatsDeadReckoning) {
  const bool wheels = GetParam();
  llc::SimDriveOptions drive_options;
  drive_options.length_m = 150.0;
  drive_options.odometry_scale_bias = 0.03;  // drift that shows within 150 m
  drive_options.odometry_turn_bias = 0.003;
  const llc::SimWorld world(llc::simWorldOptions(drive_options));
  const llc::SimDrive drive = llc::simulateDrive(world, drive_options);
  llc::SlamPipeline slam(defaultModel());
  std::vector<llc::Pose2> truth, odometry;
  for (std::size_t i = 0; i < drive.frames.size(); ++i) {
    const llc::SimFrame& frame = drive.frames[i];
    const llc::SlamStepResult step = slam.addScan(frameScan(drive, frame), i, wheels ? &frame.odometry : nullptr);
    ASSERT_TRUE(step.skip_reason.empty()) << step.skip_reason;
    if (step.keyframe) truth.push_back(frame.truth), odometry.push_back(frame.odometry);
  }
  const std::size_t keyframes = slam.keyframes().size();
  // 0.7 m between scans on straights: a keyframe every second scan (1.4 m), more in turns.
  EXPECT_GT(keyframes, 90u);
  EXPECT_LT(keyframes, 150u);
  EXPECT_EQ(slam.counters().matched_steps, keyframes - 1);
  const double slam_error = llc::alignedRmsError(slam.poses(), truth);
  const double odometry_error = llc::alignedRmsError(odometry, truth);
  EXPECT_LT(slam_error, 0.1);
  std::cout << "keyframes " << keyframes << ", rms error " << slam_error << " m, odometry " << odometry_error << " m\n";
  if (wheels) {
    EXPECT_GT(odometry_error, 5.0 * slam_error);
  }
  // map -> odom carries the newest keyframe's odometry pose onto its estimate.
  const llc::Pose2 on_map = llc::compose(slam.mapToOdom(), slam.keyframes().back().wheel_odometry);
  if (wheels) {
    EXPECT_NEAR(on_map.x, slam.poses().back().x, 1e-9);
    EXPECT_NEAR(on_map.y, slam.poses().back().y, 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(WheelsOrNot, SlamOnShortDrive, ::testing::Bool());

/// The local map (odometry/local_map_keyframes): keyframe steps matched to the newest keyframes
/// merged average the scan-to-scan errors that drift between loops. On a simulated drive with
/// drifting wheels and no loop, the front end's chain of keyframe poses drifts less with it
/// than matched to the newest keyframe alone, and the keyframes are the same scans.
TEST(LocalMap, DriftsLessThanTheNewestKeyframeAlone) {
  llc::SimDriveOptions drive_options;
  drive_options.length_m = 150.0;
  drive_options.odometry_scale_bias = 0.03;
  drive_options.odometry_turn_bias = 0.003;
  const llc::SimWorld world(llc::simWorldOptions(drive_options));
  const llc::SimDrive drive = llc::simulateDrive(world, drive_options);
  auto chainError = [&](std::size_t local_map_keyframes, std::vector<double>* stamps) {
    llc::SlamOptions options;
    options.odometry.local_map_keyframes = local_map_keyframes;
    options.loops.min_keyframe_gap = 1000000;  // no loop: the front end's chain alone
    llc::SlamPipeline slam(defaultModel(), options);
    std::vector<llc::Pose2> truth;
    for (std::size_t i = 0; i < drive.frames.size(); ++i) {
      const llc::SimFrame& frame = drive.frames[i];
      const llc::SlamStepResult step = slam.addScan(frameScan(drive, frame), i, &frame.odometry);
      if (step.keyframe) truth.push_back(frame.truth), stamps->push_back(frame.stamp);
    }
    EXPECT_EQ(slam.counters().loops_accepted, 0u);
    EXPECT_EQ(slam.counters().matched_steps, truth.size() - 1);
    return llc::alignedRmsError(slam.poses(), truth);
  };
  std::vector<double> alone_stamps, local_stamps;
  const double alone = chainError(1, &alone_stamps);
  const double local = chainError(5, &local_stamps);
  std::cout << "rms error: newest keyframe alone " << alone << " m, local map of 5 " << local << " m\n";
  EXPECT_EQ(local_stamps, alone_stamps);  // keyframes are chosen by the wheels either way
  EXPECT_LT(local, alone);
  EXPECT_THROW(llc::ScanOdometry([] {
                 llc::ScanOdometryOptions o;
                 o.local_map_keyframes = 0;
                 return o;
               }()),
               std::invalid_argument);
}

TEST(SlamPipeline, PlaceGateSparesAlignmentsButNoTrueLoop) {
  const llc::SimDrive drive = simulatedDrive(500.0);
  struct Run {
    llc::SlamCounters counters;
    std::vector<llc::Pose2> poses, truth;
    std::vector<bool> full_circle;
    std::vector<llc::LoopClosure> not_aligned;
    llc::LoopTruthCheck loops;
  };
  auto run = [&](bool gate) {
    llc::SlamOptions options;
    options.place_gate.enabled = gate;
    llc::SlamPipeline slam(defaultModel(), options);
    Run r;
    for (std::size_t i = 0; i < drive.frames.size(); ++i) {
      const llc::SlamStepResult step = slam.addScan(frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
      r.not_aligned.insert(r.not_aligned.end(), step.loops.not_aligned.begin(), step.loops.not_aligned.end());
      if (step.keyframe) r.truth.push_back(drive.frames[i].truth), r.full_circle.push_back(true);
    }
    r.counters = slam.counters();
    r.poses = slam.poses();
    r.loops = llc::checkLoopsAgainstTruth(r.truth, r.full_circle, slam.loops());
    return r;
  };
  const Run off = run(false), on = run(true);
  ASSERT_GT(off.loops.closed, 5u) << "the drive must close loops";
  EXPECT_EQ(off.counters.not_aligned, 0u);
  EXPECT_TRUE(off.not_aligned.empty());
  // The gate keeps candidates from alignment, and none of them is a true revisit ...
  EXPECT_GT(on.counters.not_aligned, 0u);
  EXPECT_EQ(on.counters.not_aligned, on.not_aligned.size());
  EXPECT_LT(on.counters.aligned, off.counters.aligned);
  EXPECT_EQ(llc::countTrueRevisitPairs(on.truth, on.full_circle, on.not_aligned), 0u);
  for (const llc::LoopClosure& skipped : on.not_aligned) EXPECT_EQ(skipped.reject_reason.rfind("place gate: ", 0), 0u);
  // ... so the same revisits are closed, none wrongly, and the map is as good.
  EXPECT_GE(on.loops.closed, off.loops.closed);
  EXPECT_EQ(on.loops.wrong_loops, 0u);
  const double error_on = llc::alignedRmsError(on.poses, on.truth), error_off = llc::alignedRmsError(off.poses, off.truth);
  std::cout << "aligned " << on.counters.aligned << " of " << off.counters.aligned << ", closed " << on.loops.closed << " of "
            << off.loops.closed << ", rms " << error_on << " m against " << error_off << " m\n";
  EXPECT_LT(error_on, 0.3);
  EXPECT_LT(error_on, error_off + 0.05);
}

TEST(LoopTruth, TrueRevisitPairsAreCountedByDistanceAndHeading) {
  const std::vector<llc::Pose2> truth{{0.0, 0.0, 0.0}, {1.0, 0.0, 3.0}, {5.0, 0.0, 0.0}, {0.5, 0.0, 0.2}};
  auto pair = [](std::size_t from, std::size_t to) {
    llc::LoopClosure p;
    p.from = from, p.to = to;
    return p;
  };
  const std::vector<llc::LoopClosure> pairs{pair(0, 1), pair(0, 2), pair(0, 3), pair(0, 9)};
  // 360-degree scans: 0-1 and 0-3 are near; 0-2 is 5 m away; keyframe 9 is unknown.
  EXPECT_EQ(llc::countTrueRevisitPairs(truth, {true, true, true, true}, pairs), 2u);
  // Partial scans: 0-1 faces the other way, so only 0-3 counts.
  EXPECT_EQ(llc::countTrueRevisitPairs(truth, {false, false, false, false}, pairs), 1u);
}

TEST(LoopTruth, EachOpenRevisitIsCountedAtTheFurthestStageItsTrueCandidatesReached) {
  // Keyframes 0..4 at x = 0, 10, 20, 30, 40; keyframes 5..9 revisit them (gap 2).
  std::vector<llc::Pose2> truth;
  for (int k = 0; k < 10; ++k) truth.push_back({10.0 * (k % 5), 0.0, 0.0});
  const std::vector<bool> full(10, true);
  llc::LoopTruthOptions options;
  options.min_keyframe_gap = 2;
  auto loop = [&](std::size_t from, std::size_t to, bool accepted, bool applied, double off = 0.0) {
    llc::LoopRecord record;
    record.loop.from = from, record.loop.to = to;
    record.loop.pose = llc::between(truth[from], truth[to]);
    record.loop.pose.x += off;
    record.loop.accepted = accepted;
    record.applied = applied;
    return record;
  };
  llc::LoopClosure skipped;
  skipped.from = 2, skipped.to = 7;
  llc::LoopClosure skipped_too;
  skipped_too.from = 3, skipped_too.to = 8;
  const std::vector<llc::LoopRecord> loops{
      loop(0, 5, true, true),           // closed
      loop(1, 6, false, false),         // refused by alignment
      loop(3, 8, true, false),          // refused by the gate (beats its skip below)
      loop(4, 9, true, true, 5.0),      // applied 5 m off: wrong
      loop(0, 7, true, true, -20.0)};   // a false pair (20 m apart) called one place: no stage for 7
  const std::vector<llc::LoopClosure> not_aligned{skipped, skipped_too};
  const llc::RevisitFates fates = llc::revisitFates(truth, full, loops, not_aligned, options);
  EXPECT_EQ(fates.open, 4u);  // 6, 7, 8, 9
  EXPECT_EQ(fates.alignment, 1u);
  EXPECT_EQ(fates.place_gate, 1u);
  EXPECT_EQ(fates.back_end_gate, 1u);
  EXPECT_EQ(fates.wrong_pose, 1u);
  EXPECT_EQ(fates.no_true_candidate, 0u);
  EXPECT_EQ(llc::checkLoopsAgainstTruth(truth, full, loops, options).closed, 1u);
  // With no candidates at all, every revisit is open for want of one.
  const llc::RevisitFates none = llc::revisitFates(truth, full, {}, {}, options);
  EXPECT_EQ(none.open, 5u);
  EXPECT_EQ(none.no_true_candidate, 5u);
}

}  // namespace
