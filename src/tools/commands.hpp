// The llc subcommands; each returns the process exit code.
#pragma once

#include <map>
#include <memory>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/geometry/relation_error.hpp"
#include "tool_common.hpp"

namespace llc_tool {
int runPairs(const Args& args);
int runFeatures(const Args& args);
int runTrain(const Args& args);
int runScore(const Args& args);
int runEvaluate(const Args& args);
int runSimulate(const Args& args);
int runAlign(const Args& args);
int runTrainCrf(const Args& args);
int runGraph(const Args& args);
int runSlam(const Args& args);
/// llc slam with several inputs or --split N: several robots, one map (cmd_slam_robots.cpp).
int runMultiRobotSlam(const Args& args);
int runLocalize(const Args& args);
int runRelations(const Args& args);
/// The relations metric of a run: the log's stamps and odometry, the run's (scan, pose) pairs.
llc::RelationErrorResult evaluateRunRelations(const std::vector<llc::Relation>& relations,
                                              const llc::ScanSequence& sequence,
                                              const std::vector<std::pair<std::size_t, llc::Pose2>>& scan_poses);
/// A .relations file, or ToolError naming the line.
std::vector<llc::Relation> loadRelationsFile(const std::string& path);
/// Report lines relations=..., relation_translation_mean_m=..., ...
void reportRelations(const llc::RelationErrorResult& result, std::ostream& out);
/// One line per evaluated relation (relation_errors.csv).
void writeRelationErrors(const llc::RelationErrorResult& result, const std::vector<llc::Relation>& relations,
                         const std::string& path);
/// Alignment options from the --aligner/... parameter flags and --crf-weights.
llc::ScanAlignerOptions alignerOptions(const Args& args);
extern const std::vector<std::string> kAlignerFlags;
/// The ESDF's parameters (esdf/..., named as in config/slam.yaml) but esdf/gate_loops: llc graph's --gate.
extern const std::vector<std::string> kEsdfFlags;

/// The scans of one recording prepared for alignment, each once, on first use.
class PreparedScanCache {
 public:
  PreparedScanCache(const llc::ScanAligner& aligner, const llc::ScanSequence& sequence)
      : aligner_(aligner), sequence_(sequence) {}
  std::shared_ptr<const llc::PreparedScan> get(std::size_t index);

 private:
  const llc::ScanAligner& aligner_;
  const llc::ScanSequence& sequence_;
  std::map<std::size_t, std::shared_ptr<const llc::PreparedScan>> prepared_;
};
}  // namespace llc_tool
