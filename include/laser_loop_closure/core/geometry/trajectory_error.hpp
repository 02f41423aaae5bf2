// Trajectory error against ground truth: RMS of positions after the rigid motion that best
// lays the estimate onto the truth (closed-form 2D Kabsch/Umeyama, no scale).
#pragma once

#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

/// RMS position error (m) of estimate[i] against truth[i] after the best rigid alignment of
/// the estimate, returned in *alignment when given (truth frame <- estimate frame). Throws
/// std::invalid_argument on sizes that differ; 0 for fewer than one pose.
double alignedRmsError(const std::vector<Pose2>& estimate, const std::vector<Pose2>& truth, Pose2* alignment = nullptr);

}  // namespace llc
