#include "laser_loop_closure/ros/nodes/back_end_client.hpp"

#include <utility>

#include "laser_loop_closure/NearbyKeyframes.h"
#include "laser_loop_closure/PlaceCheck.h"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"

namespace llc_ros {

BackEndClient::BackEndClient(ros::NodeHandle nh, std::string place_check_service, std::string nearby_service,
                             llc::PlaceGateOptions gate)
    : nh_(nh), place_check_service_(std::move(place_check_service)), nearby_service_(std::move(nearby_service)), gate_(gate) {}

template <class Service>
std::string BackEndClient::call(ros::ServiceClient& client, ros::WallTime& retry, const std::string& name, Service& service) {
  const ros::WallTime now = ros::WallTime::now();
  if (!client.isValid() && now >= retry) {
    client = nh_.serviceClient<Service>(name, true);
    retry = now + ros::WallDuration(5.0);
  }
  // The back end bounds its own wait, so this call returns; a back end that is not there fails at once.
  const auto timed = answer_timing_.measure();
  if (client.isValid() && client.call(service) && service.response.answered) return "";
  const std::string why = !client.isValid() ? "no connection" : service.response.message.empty() ? "the call failed" : service.response.message;
  if (!client.isValid() || service.response.message.empty()) client.shutdown();
  return why;
}

llc::LoopVerdict BackEndClient::placeCheck(std::size_t from, std::size_t to, std::size_t keyframe, std::uint64_t loops) {
  ++place_checks_;
  laser_loop_closure::PlaceCheck check;
  check.request.from_keyframe = std::uint32_t(from);
  check.request.to_keyframe = std::uint32_t(to);
  check.request.keyframes = std::uint32_t(keyframe + 1);
  check.request.loops = loops;
  check.request.radius = gate_.radius;
  const std::string why = call(place_client_, place_client_retry_, place_check_service_, check);
  if (!why.empty()) {
    ++place_checks_unanswered_;
    ROS_WARN_THROTTLE(10.0, "loop_closure: the place gate got no answer from %s (%s): candidates are aligned ungated",
                      place_check_service_.c_str(), why.c_str());
    return {};
  }
  return llc::placeGateVerdict(gate_, check.response.chi2);
}

std::vector<llc::NearbyKeyframe> BackEndClient::nearbyKeyframes(std::size_t keyframe, std::size_t before, double max_distance,
                                                                double max_std, std::size_t count, std::uint64_t loops) {
  ++nearby_asked_;
  laser_loop_closure::NearbyKeyframes ask;
  ask.request.keyframe = std::uint32_t(keyframe);
  ask.request.before = std::uint32_t(before);
  ask.request.count = std::uint32_t(count);
  ask.request.max_distance = max_distance;
  ask.request.max_std = max_std;
  ask.request.keyframes = std::uint32_t(keyframe + 1);
  ask.request.loops = loops;
  const std::string why = call(nearby_client_, nearby_client_retry_, nearby_service_, ask);
  if (!why.empty()) {
    ++nearby_unanswered_;
    ROS_WARN_THROTTLE(10.0, "loop_closure: %s gave no nearby keyframes (%s): only the classifier's candidates are aligned",
                      nearby_service_.c_str(), why.c_str());
    return {};
  }
  // Without a pose for each (an older back end), each is searched with no guess.
  const bool posed = ask.response.poses.size() == ask.response.nearby.size();
  std::vector<llc::NearbyKeyframe> nearby;
  for (std::size_t i = 0; i < ask.response.nearby.size(); ++i) {
    llc::NearbyKeyframe near;
    near.keyframe = ask.response.nearby[i];
    if (posed) near.has_pose = true, near.pose = fromPose2D(ask.response.poses[i]);
    nearby.push_back(near);
  }
  return nearby;
}

void BackEndClient::addTo(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  status.add("place checks asked of the back end", place_checks_.load());
  status.add("place checks unanswered (aligned ungated)", place_checks_unanswered_.load());
  status.add("nearby keyframes asked of the back end", nearby_asked_.load());
  status.add("nearby keyframes unanswered (none aligned)", nearby_unanswered_.load());
  answer_timing_.addTo(status, "waits for the back end's answers");
}

}  // namespace llc_ros
