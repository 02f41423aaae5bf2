#include "input_preparation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <vector>

#include "laser_loop_closure/core/slam/odometry_offset.hpp"

namespace llc_tool {

llc::SystemOptions systemOptions(const Args& args) {
  llc::SystemOptions options;
  const std::string config = args.get("config", configFilePath("slam.yaml"));
  if (args.has("config") || std::ifstream(config)) {
    try {
      llc::loadSystemOptionsYaml(config, &options);
    } catch (const std::exception& e) {
      throw ToolError(e.what());
    }
  }
  applyParameterFlags(args, &options);  // --SECTION/FIELD VALUE, after the file
  return options;
}

namespace {
/// The time offset (s) that shifts odometry as `offset` scans do: offset times the median
/// scan period, plus the --odometry-time-offset already applied. Rounded to 10 ms.
double suggestedTimeOffset(const Args& args, const llc::ScanSequence& sequence, int offset) {
  std::vector<double> periods;
  for (std::size_t i = 1; i < sequence.scans.size(); ++i) {
    const double dt = sequence.scans[i].stamp - sequence.scans[i - 1].stamp;
    if (dt > 0.0) periods.push_back(dt);
  }
  if (periods.empty()) return args.number("odometry-time-offset", 0.0);
  std::nth_element(periods.begin(), periods.begin() + long(periods.size() / 2), periods.end());
  const double seconds = args.number("odometry-time-offset", 0.0) + offset * periods[periods.size() / 2];
  return std::round(seconds * 100.0) / 100.0;
}

}  // namespace

bool hasTruthBesideOdometry(const llc::ScanSequence& sequence) {
  for (const llc::LoggedScan& s : sequence.scans)
    if (s.truth.x != s.odometry.x || s.truth.y != s.odometry.y || s.truth.theta != s.odometry.theta) return true;
  return false;
}

/// --odometry-offset N (scans, checked), or nothing for auto. Unset: auto for a log (a log's
/// odometry may be written a scan early or late, and is judged by its own scans), 0 for a bag
/// (the nodelets read its odometry at each scan's stamp, plus loop_closure/odometry_time_offset).
std::optional<int> fixedOdometryOffset(const Args& args) {
  if (args.get("odometry-offset", args.has("log") ? "auto" : "0") == "auto") return std::nullopt;
  const long offset = args.integer("odometry-offset", 0);
  if (std::abs(offset) > 50) throw UsageError("--odometry-offset must be auto or an integer in [-50, 50]");
  return int(offset);
}

/// --odometry-offset N (scans), or auto: the offset whose odometry ICP corrects least.
OffsetChoice chooseOdometryOffset(const Args& args, const llc::ScanSequence& sequence, const llc::SlamOptions& options) {
  OffsetChoice choice;
  if (const std::optional<int> fixed = fixedOdometryOffset(args)) {
    choice.offset = *fixed;
    return choice;
  }
  const auto start = std::chrono::steady_clock::now();
  const llc::OdometryOffsetResult estimate = llc::estimateOdometryOffset(
      sequence, llc::ScanOdometry(options.odometry), llc::ScanAligner(options.aligner));
  std::ostringstream table;
  table << std::setprecision(4);
  table << "odometry_offset_seconds=" << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
        << "  (the estimate; not in seconds below)\n";
  for (const llc::OdometryOffsetScore& s : estimate.scores)
    table << "odometry_offset_tried: offset=" << s.offset << " pairs=" << s.pairs << " matched=" << s.matched
          << " mean_correction_m=" << s.mean_correction_m << " mean_correction_rad=" << s.mean_correction_rad << "\n";
  if (!estimate.ok) {
    if (args.has("odometry-offset")) std::cerr << "warning: --odometry-offset auto: " << estimate.reason << "; using 0\n";
    table << "odometry_offset_estimate=none (" << estimate.reason << ")\n";
  } else {
    table << "odometry_offset_reason=" << estimate.reason << "\n";
  }
  choice.offset = estimate.ok ? estimate.best_offset : 0;
  if (estimate.ok) table << "odometry_time_offset_suggested=" << suggestedTimeOffset(args, sequence, choice.offset)
                         << "  (s: the nodelets' odometry_time_offset, llc's --odometry-time-offset; the offset's "
                            "scans times the median scan period, plus any --odometry-time-offset given)\n";
  choice.table = table.str();
  return choice;
}



}  // namespace llc_tool
