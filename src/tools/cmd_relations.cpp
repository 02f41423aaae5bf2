// llc relations, and llc slam --relations: the Kümmerle et al. 2009 relations metric of a
// run's per-scan poses (scans.csv) against a .relations file.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/io/relations_io.hpp"
#include "laser_loop_closure/ros/io/drive_input.hpp"

namespace llc_tool {
namespace {

constexpr double kDegrees = 180.0 / M_PI;

/// One row of a pose CSV: its line number, the text of its key column and its pose.
struct PoseRow {
  std::size_t line = 0;
  std::string key;
  llc::Pose2 pose;
};

/// A CSV whose header names `key`, x, y and theta or yaw (llc slam's scans.csv and
/// trajectory.csv, the nodelets' path.csv); refuses a short row or a pose that is not finite.
std::vector<PoseRow> readPoseCsv(const std::string& path, const char* key) {
  std::ifstream in(path);
  if (!in) throw ToolError(path + ": cannot be read");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  for (std::istringstream names(line); std::getline(names, line, ',');) header.push_back(line);
  auto column = [&](std::initializer_list<const char*> names) {
    for (const char* name : names)
      for (std::size_t i = 0; i < header.size(); ++i)
        if (header[i] == name) return i;
    throw ToolError(path + ":1: no column " + *names.begin() + " (a header naming " + key + ", x, y and theta or yaw)");
  };
  const std::size_t key_at = column({key}), x_at = column({"x"}), y_at = column({"y"});
  const std::size_t theta_at = column({"theta", "yaw"});
  std::vector<PoseRow> rows;
  for (std::size_t number = 2; std::getline(in, line); ++number) {
    if (line.empty()) continue;
    std::vector<std::string> fields;
    for (std::istringstream values(line); std::getline(values, line, ',');) fields.push_back(line);
    try {
      if (fields.size() < header.size()) throw std::invalid_argument("short");
      const llc::Pose2 pose{std::stod(fields[x_at]), std::stod(fields[y_at]), std::stod(fields[theta_at])};
      if (!llc::isFinite(pose)) throw std::invalid_argument("not finite");
      rows.push_back({number, fields[key_at], pose});
    } catch (const std::exception&) {
      throw ToolError(path + ":" + std::to_string(number) + ": expected " + std::to_string(header.size()) +
                      " comma-separated values with a finite pose");
    }
  }
  return rows;
}

/// scans.csv as llc slam writes it: poses by scan index.
std::vector<std::pair<std::size_t, llc::Pose2>> readScanPoses(const std::string& path) {
  std::vector<std::pair<std::size_t, llc::Pose2>> poses;
  for (const PoseRow& row : readPoseCsv(path, "scan")) {
    std::size_t used = 0;
    unsigned long index = 0;
    try {
      index = std::stoul(row.key, &used);
    } catch (const std::exception&) {
    }
    if (used == 0 || used != row.key.size())
      throw ToolError(path + ":" + std::to_string(row.line) + ": '" + row.key + "' is not a scan index");
    poses.emplace_back(index, row.pose);
  }
  return poses;
}

/// Poses by stamp (trajectory.csv, path.csv), each put on the log's scan of that stamp.
std::vector<std::pair<std::size_t, llc::Pose2>> readStampedPoses(const std::string& path,
                                                                 const llc::ScanSequence& sequence) {
  std::vector<double> stamps;
  for (const llc::LoggedScan& s : sequence.scans) stamps.push_back(s.stamp);
  const llc::StampIndex scans(std::move(stamps));
  const std::vector<PoseRow> rows = readPoseCsv(path, "stamp");
  std::vector<std::pair<std::size_t, llc::Pose2>> poses;
  for (const PoseRow& row : rows) {
    char* end = nullptr;
    const double stamp = std::strtod(row.key.c_str(), &end);
    if (row.key.empty() || *end != '\0' || !std::isfinite(stamp))
      throw ToolError(path + ":" + std::to_string(row.line) + ": '" + row.key + "' is not a finite stamp");
    if (const auto scan = scans.find(stamp, llc::RelationErrorOptions{}.stamp_tolerance)) poses.emplace_back(*scan, row.pose);
  }
  if (poses.size() < rows.size())
    std::cerr << "warning: " << path << ": " << rows.size() - poses.size() << " of " << rows.size()
              << " poses have a stamp that names no scan of the log: left out\n";
  return poses;
}

}  // namespace

llc::RelationErrorResult evaluateRunRelations(const std::vector<llc::Relation>& relations,
                                              const llc::ScanSequence& sequence,
                                              const std::vector<std::pair<std::size_t, llc::Pose2>>& scan_poses) {
  llc::ScanTrack track;
  for (const llc::LoggedScan& s : sequence.scans) {
    track.stamps.push_back(s.stamp);
    track.odometry.push_back(s.odometry);
    track.scanner_mounts.push_back(s.front_mount);  // the relations give the scanner's motion
  }
  track.poses.resize(sequence.scans.size());
  for (const auto& [index, pose] : scan_poses) {
    if (index >= track.poses.size())
      throw ToolError("scan " + std::to_string(index) + " of the poses is not in the log (" +
                      std::to_string(track.poses.size()) + " scans): poses of another run?");
    track.poses[index] = pose;
  }
  return llc::evaluateRelations(relations, track);
}

std::vector<llc::Relation> loadRelationsFile(const std::string& path) {
  try {
    return llc::loadRelations(path);
  } catch (const llc::RelationsError& e) {
    throw ToolError(e.what());
  }
}

void reportRelations(const llc::RelationErrorResult& r, std::ostream& out) {
  out << std::setprecision(4) << "relations=" << r.relations << "\n"
      << "relations_evaluated=" << r.evaluated << "\n"
      << "relations_unmatched=" << r.unmatched << "  (a stamp that names no scan of the log)\n"
      << "relations_carried=" << r.carried << "  (an end without a pose of its own, carried by the log's odometry)\n"
      << "relation_translation_mean_m=" << r.translation_mean << "\n"
      << "relation_translation_std_m=" << r.translation_std << "\n"
      << "relation_translation_max_m=" << r.translation_max << "\n"
      << "relation_rotation_mean_deg=" << r.rotation_mean * kDegrees << "\n"
      << "relation_rotation_std_deg=" << r.rotation_std * kDegrees << "\n"
      << "relation_rotation_max_deg=" << r.rotation_max * kDegrees << "\n";
}

void writeRelationErrors(const llc::RelationErrorResult& r, const std::vector<llc::Relation>& relations,
                         const std::string& path) {
  llc::AtomicTextFile out(path);
  out << "relation,t1,t2,scan1,scan2,translation_m,rotation_deg,carried\n" << std::fixed;
  for (const llc::RelationError& e : r.errors)
    out << e.relation << "," << std::setprecision(6) << relations[e.relation].t1 << "," << relations[e.relation].t2 << ","
        << e.scan1 << "," << e.scan2 << "," << e.translation << "," << e.rotation * kDegrees << "," << (e.carried ? 1 : 0)
        << "\n";
  out.commit();
}

int runRelations(const Args& args) {
  if (args.has("poses") == args.has("keyframes")) throw UsageError("give exactly one of --poses and --keyframes");
  const std::string relations_path = args.required("relations");
  const std::string log = args.required("log");
  if (args.has("out")) checkOutputFile("out", args.get("out", ""));
  const std::vector<llc::Relation> relations = loadRelationsFile(relations_path);
  llc::ScanSequence sequence = loadSequence(log, args);
  if (args.has("mount-from")) {
    // Poses made on a bag (the nodelets' /path), judged on the log of the same drive, whose
    // odometry carries them as the log's own runs are carried: the bag's mount, the log's rest.
    const std::string bag = args.get("mount-from", "");
    if (!llc_ros::isBagPath(bag))
      throw UsageError("--mount-from takes the bag the poses were made on (a .bag), not " + bag);
    // Read as any bag is (loadDrive throws on one without scans), so the mount is the one the
    // bag reader, llc slam --bag and the nodelets' MountCache use.
    const llc::Pose2 mount = loadSequence(bag, args).scans.front().front_mount;
    for (llc::LoggedScan& s : sequence.scans) s.front_mount = mount;
    std::cout << "scanner_mount_from=" << bag << " x=" << mount.x << " y=" << mount.y << " theta=" << mount.theta << "\n";
  }
  const auto poses = args.has("poses") ? readScanPoses(args.get("poses", ""))
                                       : readStampedPoses(args.get("keyframes", ""), sequence);
  const llc::RelationErrorResult result = evaluateRunRelations(relations, sequence, poses);
  reportRelations(result, std::cout);
  if (args.has("out")) writeRelationErrors(result, relations, args.get("out", ""));
  return 0;
}

}  // namespace llc_tool
