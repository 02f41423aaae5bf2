#include "pcl_baselines.hpp"

#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/icp.h>

#include <chrono>
#include <cmath>

namespace llc_tool {
namespace {
pcl::PointCloud<pcl::PointXYZ>::Ptr toCloud(const llc::Points2& points) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(points.size());
  for (const llc::Point2& p : points) cloud->push_back(pcl::PointXYZ(float(p.x()), float(p.y()), 0.0f));
  return cloud;
}
}  // namespace

PclAlignment alignPcl(PclMethod method, const llc::Points2& source, const llc::Points2& target,
                      const llc::IcpOptions& options, const llc::Pose2& start_pose) {
  PclAlignment result;
  if (source.size() < 3 || target.size() < 3) return result;
  // PCL prints "not enough correspondences" for every pair it cannot align; the result says so.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  const auto src = toCloud(source), tgt = toCloud(target);
  const auto start = std::chrono::steady_clock::now();
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
  pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>& registration =
      method == PclMethod::kIcp ? static_cast<pcl::Registration<pcl::PointXYZ, pcl::PointXYZ>&>(icp) : gicp;
  registration.setInputSource(src);
  registration.setInputTarget(tgt);
  registration.setMaximumIterations(options.max_iterations);
  registration.setMaxCorrespondenceDistance(options.max_correspondence_distance);
  registration.setTransformationEpsilon(1e-8);
  Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
  const float c = float(std::cos(start_pose.theta)), s = float(std::sin(start_pose.theta));
  guess(0, 0) = c, guess(0, 1) = -s, guess(1, 0) = s, guess(1, 1) = c;
  guess(0, 3) = float(start_pose.x), guess(1, 3) = float(start_pose.y);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  registration.align(aligned, guess);
  result.ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.converged = registration.hasConverged();
  const Eigen::Matrix4f t = registration.getFinalTransformation();
  result.pose = {double(t(0, 3)), double(t(1, 3)), std::atan2(double(t(1, 0)), double(t(0, 0)))};
  return result;
}

}  // namespace llc_tool
