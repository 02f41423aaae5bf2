#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

const char* loopRefusalName(LoopRefusal refusal) {
  switch (refusal) {
    case LoopRefusal::kNone: return "none";
    case LoopRefusal::kPlaceGate: return "place_gate";
    case LoopRefusal::kCrfMatch: return "crf_match";
    case LoopRefusal::kIcp: return "icp";
    case LoopRefusal::kValidation: return "validation";
    case LoopRefusal::kContext: return "context";
    case LoopRefusal::kBackEndGate: return "back_end_gate";
    case LoopRefusal::kBackEndUnsolvable: return "back_end_unsolvable";
    case LoopRefusal::kBackEndMalformed: return "back_end_malformed";
    case LoopRefusal::kOther: return "other";
  }
  return "other";
}

const char* odometryRefusalName(OdometryRefusal refusal) {
  switch (refusal) {
    case OdometryRefusal::kNone: return "none";
    case OdometryRefusal::kIcp: return "icp";
    case OdometryRefusal::kTooFarFromWheels: return "too_far_from_wheels";
    case OdometryRefusal::kLowOverlap: return "low_overlap";
    case OdometryRefusal::kNewChain: return "new_chain";
  }
  return "none";
}

const char* scanRefusalName(ScanRefusal refusal) {
  switch (refusal) {
    case ScanRefusal::kNone: return "none";
    case ScanRefusal::kStampNotFinite: return "stamp_not_finite";
    case ScanRefusal::kRangesAndBearingsDiffer: return "ranges_bearings_differ";
    case ScanRefusal::kWheelOdometryNotFinite: return "wheel_odometry_not_finite";
    case ScanRefusal::kTimeWentBackwards: return "time_went_backwards";
  }
  return "none";
}

}  // namespace llc
