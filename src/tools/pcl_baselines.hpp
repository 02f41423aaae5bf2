// PCL's IterativeClosestPoint and GeneralizedIterativeClosestPoint, started from the identity:
// the yardsticks `llc align --compare-pcl` measures the project's alignment against; GICP
// started from the ground truth is `llc align --truth-check`'s independent second opinion.
#pragma once

#include "laser_loop_closure/core/alignment/icp.hpp"

namespace llc_tool {

enum class PclMethod { kIcp, kGicp };

struct PclAlignment {
  bool converged = false;
  llc::Pose2 pose;  ///< source frame in the target frame
  double ms = 0.0;
};

/// Same iteration limit and correspondence distance as the project's ICP; from `start`
/// (source frame in the target frame), the identity unless given.
PclAlignment alignPcl(PclMethod method, const llc::Points2& source, const llc::Points2& target,
                      const llc::IcpOptions& options, const llc::Pose2& start = llc::Pose2{});

}  // namespace llc_tool
