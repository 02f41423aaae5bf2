// PCL's IterativeClosestPoint and GeneralizedIterativeClosestPoint, started from the identity:
// the yardsticks `llc align --compare-pcl` measures the project's alignment against.
#pragma once

#include "laser_loop_closure/core/icp.hpp"

namespace llc_tool {

enum class PclMethod { kIcp, kGicp };

struct PclAlignment {
  bool converged = false;
  llc::Pose2 pose;  ///< source frame in the target frame
  double ms = 0.0;
};

/// Same iteration limit and correspondence distance as the project's ICP.
PclAlignment alignPcl(PclMethod method, const llc::Points2& source, const llc::Points2& target,
                      const llc::IcpOptions& options);

}  // namespace llc_tool
