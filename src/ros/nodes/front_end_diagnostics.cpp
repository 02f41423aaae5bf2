#include "laser_loop_closure/ros/nodes/front_end_diagnostics.hpp"

#include <string>

namespace llc_ros {

void addFrontEndCounters(const llc::FrontEndCounters& c, double threshold, diagnostic_updater::DiagnosticStatusWrapper& status) {
  status.add("scans skipped by the front end", c.skipped_scans);
  for (std::size_t kind = 1; kind < llc::kScanRefusalKinds; ++kind)  // llc::ScanRefusal's names
    status.add(std::string("scans skipped: ") + llc::scanRefusalName(llc::ScanRefusal(kind)), c.scans_skipped[kind]);
  status.add("keyframes", c.keyframes);
  status.add("steps matched by ICP", c.matched_steps);
  status.add("steps from wheel odometry alone", c.wheel_steps);
  status.add("steps where ICP and wheels disagreed", c.disputed_steps);
  status.add("steps where the laser overruled the wheels", c.recovered_steps);
  status.add("keyframe steps matched from the tracked scans", c.tracked_steps);
  for (std::size_t kind = 1; kind < llc::kOdometryRefusalKinds; ++kind)  // llc::OdometryRefusal's names
    status.add(std::string("steps not matched: ") + llc::odometryRefusalName(llc::OdometryRefusal(kind)),
               c.steps_not_matched[kind]);
  status.add("wheel odometry jumps left out", c.wheel_jumps);
  status.add("scans with stalled wheel odometry (placed by the laser)", c.stalled_wheel_scans);
  status.add("laser steps matched from the last scan's pose (the prediction failed)", c.laser_fallback_steps);
  status.add("laser keyframe steps widened along an ambiguous direction", c.ambiguous_steps);
  status.add("scans disputed with the wheels, placed from the laser's prediction", c.scans_placed_by_prediction);
  status.add("keyframe steps realigned with no guess (ICP overlapped little)", c.realigned_steps);
  status.add("scans timed by counting (stamps jitter beyond max_stamp_jitter)", c.scans_counted);
  status.add("stamps that jumped back (new odometry chains)", c.time_jumps);
  status.add("pairs classified", c.pairs_classified);
  status.add("candidates", c.candidates);
  status.add("classifier threshold K", threshold);
  status.add("candidates kept from alignment by the place gate", c.not_aligned);
  status.add("threshold calibration pairs", c.calibration_pairs);
  status.add("loops found", c.loops_found);
  status.add("nearby candidates aligned (the map's, not the classifier's)", c.nearby_aligned);
  status.add("nearby candidates found (aligned and validated)", c.nearby_found);
  status.add("loops checked against their context", c.context_checked);
  status.add("loops whose context was too small to check", c.context_unchecked);
  status.add("refused by alignment", c.refused_by_alignment);
  status.add("seconds classifying", c.seconds_classify);
  status.add("seconds aligning", c.seconds_align);
}

}  // namespace llc_ros
