// The loop_closure nodelet's questions to the back end, asked from its worker thread while a
// keyframe's candidates are chosen: the place gate (place_check_service) and the map's nearby
// keyframes (nearby_service). The back end bounds its own wait; a back end that is not there
// fails at once, and the candidates are then aligned ungated or with the classifier's alone.
// Holds no lock while it waits, so diagnostics, training and sessions never wait on it.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"
#include "laser_loop_closure/ros/io/callback_timing.hpp"

namespace llc_ros {

class BackEndClient {
 public:
  BackEndClient(ros::NodeHandle nh, std::string place_check_service, std::string nearby_service, llc::PlaceGateOptions gate);

  /// The place gate's verdict on (from, to) for keyframe `keyframe` after `loops` loop messages:
  /// the back end's statistic judged by placeGateVerdict, or not refused (align) with no answer.
  llc::LoopVerdict placeCheck(std::size_t from, std::size_t to, std::size_t keyframe, std::uint64_t loops);
  /// The map's keyframes near keyframe `keyframe` (see llc::NearbyKeyframes), or none with no answer.
  std::vector<llc::NearbyKeyframe> nearbyKeyframes(std::size_t keyframe, std::size_t before, double max_distance,
                                                   double max_std, std::size_t count, std::uint64_t loops);
  /// Its counts, for the nodelet's diagnostics (any thread).
  void addTo(diagnostic_updater::DiagnosticStatusWrapper& status) const;

 private:
  /// Over `client` (persistent; made again after a failure, at most every 5 s, at `retry`): ""
  /// when it answered, else why not (then `client` is shut down when the connection is at fault).
  template <class Service>
  [[nodiscard]] std::string call(ros::ServiceClient& client, ros::WallTime& retry, const std::string& name, Service& service);

  ros::NodeHandle nh_;
  std::string place_check_service_, nearby_service_;
  llc::PlaceGateOptions gate_;
  ros::ServiceClient place_client_, nearby_client_;  ///< the worker's only
  ros::WallTime place_client_retry_, nearby_client_retry_;
  std::atomic<std::size_t> place_checks_{0}, place_checks_unanswered_{0}, nearby_asked_{0}, nearby_unanswered_{0};
  /// Wall time of each question until its answer (or failure): the time the worker waited on
  /// the back end, which a busy back end stretches (its updates after a loop hold the answer).
  CallbackTiming answer_timing_;
};

}  // namespace llc_ros
