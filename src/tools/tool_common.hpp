// What the llc subcommands share: argument parsing, loading logs with their features and
// pair files, and the default model path.
#pragma once

#include <map>
#include <optional>
#include <stdexcept>
#include <ostream>
#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/adaboost.hpp"
#include "laser_loop_closure/core/classifier/augmentation.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/sim/odometry_drift.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/map/map_picture.hpp"
#include "laser_loop_closure/ros/io/drive_input.hpp"

namespace llc_tool {

/// A problem the user can fix in a file or the data (missing file, malformed log, an output
/// that cannot be written); printed as one line, exit code 1.
class ToolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A problem in the command line itself (unknown option, missing or malformed value, a value
/// out of range); printed as one line, exit code 2. Raised before the run starts.
class UsageError : public ToolError {
 public:
  using ToolError::ToolError;
};

/// Refuses (ToolError) an output file that cannot be written, before the run starts: its
/// folder missing or read-only, or the path a folder. `flag` names it in the message.
void checkOutputFile(const std::string& flag, const std::string& path);
/// Creates the output folder `path` (with its parents) and refuses it when it cannot be
/// written to, before the run starts.
void prepareOutputFolder(const std::string& flag, const std::string& path);

/// "--name value" options and "--flag" switches; every name must be known to the subcommand.
class Args {
 public:
  /// `flags` are switches without a value; `options` take one value (may repeat).
  Args(int argc, char** argv, const std::vector<std::string>& options,
       const std::vector<std::string>& flags);
  bool has(const std::string& name) const;
  std::string get(const std::string& name, const std::string& fallback) const;
  std::string required(const std::string& name) const;
  std::vector<std::string> all(const std::string& name) const;
  double number(const std::string& name, double fallback) const;
  long integer(const std::string& name, long fallback) const;
  /// "true" or "false", else UsageError.
  bool boolean(const std::string& name, bool fallback) const;

 private:
  std::multimap<std::string, std::string> values_;
};

/// Pipeline parameters given on the command line as --SECTION/FIELD VALUE (the names of
/// config/slam.yaml and the nodelets' parameters), set onto `options` after --config.
/// Throws UsageError on a bad value or options that do not validate.
void applyParameterFlags(const Args& args, llc::SystemOptions* options);
/// Lists every pipeline parameter as a flag with its built-in default, and its unit and meaning
/// from the comment beside it in config/slam.yaml (a test checks that file against the defaults).
void systemParametersHelp(std::ostream& out, const std::string& prefix = "");
/// Every pipeline parameter name under `prefix` ("aligner/", "esdf/"), but those in `except`:
/// the flags of a subcommand that runs one stage.
std::vector<std::string> parameterNamesUnder(const std::string& prefix, const std::vector<std::string>& except = {});

/// Feature options from --features/set, --features/r_max, --features/g_max_dist,
/// --features/g_min_size and --features/closed_ring: the keys of a model file's features.
llc::FeatureOptions featureOptions(const Args& args);
extern const std::vector<std::string> kFeatureFlags;   ///< the option names it reads

/// One --data LOG:PAIRS item, loaded (the adapter's: the service reads pairs the same way).
using llc_ros::PairData;

/// Flags naming the topics of a .bag input (every subcommand that reads a log takes them).
extern const std::vector<std::string> kInputFlags;
/// The bag reader's options from kInputFlags; UsageError on a bad --odometry-time-offset.
llc_ros::BagReadOptions bagOptions(const Args& args);
/// A CARMEN log (.log, .log.gz, any other name) or a rosbag (.bag, topics from kInputFlags).
/// bagOptions, after checking that the flags only a bag takes come with a bag (UsageError).
llc_ros::BagReadOptions driveReadOptions(const std::string& path, const Args& args);
/// mapping (llc slam): a bag is read as the nodelets take it (BagReadOptions): with wheel
/// odometry the scans they would get no odometry for are left out; without (--no-wheel-odometry)
/// the scans are put in header.seq order (--seq-reorder-scans, default the nodelet's
/// seq_reorder_scans; 0: off). `probe`: a bag's wheels read at the offset it finds, as the
/// nodelets' estimate_odometry_time_offset (BagReadOptions::odometry_time_offset_probe).
llc::ScanSequence loadSequence(const std::string& path, const Args& args, bool mapping = false,
                               llc::OdometryTimeOffsetProbe* probe = nullptr);
using llc_ros::extractAll;
std::vector<PairData> loadPairData(const std::vector<std::string>& specs, const llc::FeatureOptions& options,
                                   const Args& args);
/// Pair feature rows of every pair of every data item, in order.
llc::TrainingSet pairTrainingSet(const std::vector<PairData>& data, llc::FeatureSet feature_set);

/// --augment half-beams,double-beams|none (default none); UsageError on a bad list.
std::vector<llc::ScanAugmentation> augmentations(const Args& args);
/// --exclude-features NAME,...: pair features no stump may use (a feature study); UsageError
/// on a name the feature set does not have.
std::vector<std::string> excludedFeatures(const Args& args, const llc::FeatureOptions& options);
/// Per kind, per data item: its pairs' rows with both scans augmented (row for row).
std::vector<std::vector<llc::TrainingSet>> augmentedSets(const std::vector<PairData>& data,
                                                         const std::vector<llc::ScanAugmentation>& kinds,
                                                         const llc::FeatureOptions& options);

/// config/classifier.yaml of the source tree, or of the installed share folder.
std::string defaultModelPath();
/// config/NAME of the source tree, or of the installed share folder.
std::string configFilePath(const std::string& name);

void ensureDirectory(const std::string& path);

/// The flags odometryDrift reads.
extern const std::vector<std::string> kDriftFlags;
/// --drift moderate|strong and --drift-* (each overrides the preset; any of them alone starts
/// from moderate): the odometry degraded before use, for logs whose odometry is perfect.
/// Nothing when no drift flag is given.
std::optional<llc::OdometryDrift> odometryDrift(const Args& args);

/// DIR/map.pgm, map.yaml and map.png (the loops drawn) of keyframes' scans at their poses;
/// ToolError ("map: ...") when the grid cannot be made or written.
void writeMapFiles(const std::vector<llc::Keyframe>& keyframes, const std::vector<llc::Pose2>& poses,
                   const std::vector<llc::PictureLoop>& loops, const llc::OccupancyGridOptions& options, const std::string& dir);

/// --save-session S with --lifelong: the session pruned to options (slam/session_pruning) and
/// saved at path, its keyframes listed in DIR/session_keyframes.csv (robot, index, stamp, x,
/// y, theta). Returns the report's lines; ToolError when it cannot be saved.
std::string saveLifelongSession(const llc::SlamSession& session, const llc::SessionPruningOptions& options,
                                const std::string& path, const std::string& dir);

}  // namespace llc_tool
