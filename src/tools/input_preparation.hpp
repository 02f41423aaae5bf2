// What llc slam and llc localize both do to an input before the pipeline sees it: the
// pipeline's options from --config and the parameter flags, and a log's odometry offset.
#pragma once

#include <optional>
#include <string>

#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "tool_common.hpp"

namespace llc_tool {

/// config/slam.yaml (or --config FILE), then every --SECTION/FIELD VALUE flag; ToolError on a bad file.
llc::SystemOptions systemOptions(const Args& args);

/// Whether some scan's true pose differs from its odometry (a log with TRUEPOS lines, a sim).
bool hasTruthBesideOdometry(const llc::ScanSequence& sequence);

struct OffsetChoice {
  int offset = 0;
  std::string table;  ///< report lines of the estimate (auto only)
};

/// --odometry-offset N (scans, checked), or nothing for auto. Unset: auto for a log (a log's
/// odometry may be written a scan early or late, and is judged by its own scans), 0 for a bag
/// (the nodelets read its odometry at each scan's stamp, plus loop_closure/odometry_time_offset).
std::optional<int> fixedOdometryOffset(const Args& args);

/// --odometry-offset N (scans), or auto: the offset whose odometry ICP corrects least.
OffsetChoice chooseOdometryOffset(const Args& args, const llc::ScanSequence& sequence, const llc::SlamOptions& options);

}  // namespace llc_tool
