// The loop_closure nodelet's diagnostics of its front end: every llc::FrontEndCounters field by
// a name people read in rqt_runtime_monitor.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>

#include "laser_loop_closure/core/slam/slam_front_end.hpp"

namespace llc_ros {

/// Adds the counters (and the classifier's threshold K) to `status`.
void addFrontEndCounters(const llc::FrontEndCounters& c, double threshold, diagnostic_updater::DiagnosticStatusWrapper& status);

}  // namespace llc_ros
