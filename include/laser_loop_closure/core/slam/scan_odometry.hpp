// Keyframe selection and scan-matching odometry: a scan becomes a keyframe once the robot has
// moved keyframe_distance or turned keyframe_angle since the last one, and its motion from the
// last keyframe is refined by ICP, seeded by wheel odometry when there is any.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/correlative_search.hpp"
#include "laser_loop_closure/core/alignment/icp.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/slam/seed_selection.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

/// ICP's options for scan-matching odometry: IcpOptions' defaults, but with solution remapping
/// (remap_ratio 0.01) where the seed is the wheels' guess, which along a corridor's axis (where
/// the scans hardly fix the pose and ICP slid 0.2-0.3 m on ACES) knows better; chosen on the
/// relations benchmark's logs (docs/mapping.md). Without wheels it is not used.
inline IcpOptions odometryIcpOptions() {
  IcpOptions options;
  options.remap_ratio = 0.01;
  return options;
}

struct ScanOdometryOptions {
  double keyframe_distance = 1.0;  ///< m moved since the last keyframe that makes a scan a keyframe
  double keyframe_angle = 0.35;    ///< rad turned since the last keyframe that does it too
  bool scan_matching = true;       ///< refine each step by ICP (false: wheel odometry alone)
  double max_correction_translation = 1.0;  ///< m; an ICP result farther from the wheel guess is not trusted
  double max_correction_rotation = 0.6;     ///< rad; likewise for its heading
  /// Squared Mahalanobis distance of ICP's result from the wheel guess, under the covariance of a
  /// wheel step (wheel_sigma_scale, widened by WheelNoiseScale when the robot's wheels disagree
  /// with ICP more than that as a rule), above which the step is disputed: ICP's motion with a
  /// covariance that also holds the wheels' (a wrong ICP minimum with a matched step's tight
  /// covariance bends the map for good; a wide one lets loops mend it). 0: off.
  double max_wheel_disagreement = 9.0;
  /// Recent matched steps whose disagreement with the wheels sets WheelNoiseScale. (Fixed: not
  /// a parameter; see slam_parameters.hpp.)
  std::size_t wheel_noise_window = 100;
  double min_overlap_share = 0.5;  ///< share of the new scan's points within overlap_distance of the old one, or ICP is not trusted
  double overlap_distance = 0.3;   ///< m
  /// Standard deviations of a matched step: a floor, plus a share of the distance moved and,
  /// for the heading, of the angle turned (they go into the back end's odometry constraints).
  double translation_sigma = 0.02;            ///< m
  double translation_sigma_per_metre = 0.01;  ///< m per m moved
  double rotation_sigma = 0.002;              ///< rad
  double rotation_sigma_per_metre = 0.002;    ///< rad per m moved
  double rotation_sigma_per_radian = 0.01;    ///< rad per rad turned
  double wheel_sigma_scale = 5.0;  ///< a step from wheel odometry alone is this many times less certain
  /// Without wheel odometry: seed each scan's ICP with the last measured velocity, and move on
  /// by it when ICP fails (a featureless stretch), instead of standing still until the robot is
  /// too far from the keyframe for any match (false: no motion model).
  bool predict_motion = true;
  /// With wheel odometry: also match each scan that is not a keyframe to the newest keyframe
  /// (ICP from the wheels' guess), so that every scan has a pose of its own (scans.csv, the
  /// relations metric, odom from publish_odometry_tf); one ICP per scan. Keyframes are chosen
  /// by the wheels either way. (Without wheels every scan is matched anyway.)
  bool match_every_scan = true;
  /// One margin for every choice among a step's seeds (selectSeed: the tracked, predicted,
  /// searched and realigned poses against the wheels' or the step's own): a less trusted seed
  /// wins when the scan's mean likelihood in the target's field (correlativeScore, 0..1) is
  /// this much higher.
  double seed_min_score_gain = 0.1;
  /// With match_every_scan: each scan's ICP is also seeded from the last matched scan's pose
  /// carried on by the wheels' motion since (tracking), and that result is taken when it fits
  /// the scans better by seed_min_score_gain or both seeds reach one pose. Wheels that slip
  /// over many scans are so corrected scan by scan, not all at once at the next keyframe, where one ICP from their guess may be too far off
  /// (FR079); on a tie (a corridor, where ICP slides) the wheels' guess stands.
  bool track_scans = true;
  /// With match_every_scan: a wheel reading within 5 mm and 5 mrad of the scan before's, right
  /// after the wheels moved, is a robot that stood or a stalled odometry source. ICP runs
  /// from the wheels' guess and from the laser's prediction (the last scan's pose on by the
  /// last matched velocity); when the prediction's result wins (as tracking judges) and the
  /// laser moved since the scan before, the wheels stalled: the scan is the laser's, keyframes
  /// come as the laser moves, and one made then takes no wheel reference. MIT CSAIL's wheels
  /// report nothing for 1 s mid-turn, then jump 0.87 rad. (false: the stalled reading is the guess.)
  bool stalled_wheels_as_missing = true;
  /// Without wheel odometry (none at all: not a stall), a matched step's covariance also holds
  /// ICP's own covariance (OdometryStep::icp_covariance) times this.
  /// ICP's, from point errors taken as independent, is too sure by about the number of points,
  /// but it has the shape the scans give: long along a corridor, where laser-only odometry
  /// slides and the loops that mend it must pass the back end's gate. In-sample: chosen on the
  /// four relations logs (ACES laser-only 0.83 -> 0.24 m; 2000-3000 let wrong loops in). 0: off.
  double icp_covariance_scale = 500.0;
  /// Without wheel odometry: a keyframe step's covariance along the direction ICP's own is
  /// longest (a corridor's axis) is widened to cover every shift along it, up to
  /// ambiguity_max_shift, at which the scan still scores within this of its own correlativeScore
  /// against the keyframe (ambiguousShift; of the mean likelihood, 0..1). ICP's covariance,
  /// even scaled, held the Intel log's 6 m slides to 0.5 m, and the back end's gate refused
  /// the loops that mend them. Chosen on the relations logs (in-sample: Intel laser-only
  /// 0.100 -> 0.050 m at any value from 0.01 to 0.2) and the simulated drive without wheels
  /// (not tuned on: 296 loops at 0.02, 251 at 0.1, since the nearby candidates need a known
  /// relative position). 0: off.
  double ambiguity_score_drop = 0.02;
  double ambiguity_max_shift = 10.0;  ///< (fixed) m; the farthest shift ambiguity_score_drop looks at (in steps of correlative.translation_step; at most 2 x correlative.max_range)
  /// With wheel odometry, a keyframe's step is matched to the points of the newest this many
  /// keyframes of the chain (placed by the front end's own odometry, merged on a 5 cm grid,
  /// the newest keyframe's points first) instead of the newest keyframe alone: a local map,
  /// which averages the scan-to-scan errors that drift between loops. The scans between
  /// keyframes, and every scan without wheels, keep to the newest keyframe. In-sample: chosen
  /// on the drifted logs (moderate drift, RMS under 0.3 m on 7 of 8 against 5 of 8). 1: off.
  std::size_t local_map_keyframes = 5;
  /// The motion model's clock (MotionClock): the scans' stamps, or the count of scans times
  /// their mean interval while the median absolute deviation of the last 64 intervals is
  /// above this share of their median (the Intel log's stamps: 0.99). 0: always counted.
  double max_stamp_jitter = 0.5;
  /// (Fixed, with the two polish bounds below: not parameters.)
  /// icp.trim_fraction where the laser's motion made the seed (the motion model, the last
  /// scan's pose; not the wheels, not a correlative search's best pose): from a seed that
  /// missed a motion along a corridor, the few points that see it (a door frame ahead) are the
  /// pairs farthest off, and trimming them keeps the seed; the robot then stands still in the
  /// map while it drives (the Intel log laser-only, scans 1,935-2,000: 4.2 m driven, 1.2 m
  /// taken). The wheels' seeds keep icp.trim_fraction.
  double laser_seeded_trim_fraction = 0.98;
  /// Then ICP once more from that result with icp.trim_fraction, taken when it moves at most
  /// this far (m) and turns at most laser_seeded_polish_rotation: the 98% also keeps points
  /// newly in view that have no counterpart, and they pull each step a little short (the
  /// simulated drive without wheels: 0.017% per step, 0.080 -> 0.148 m RMS); bounded, so it
  /// only polishes and cannot slide back along a corridor (0: off).
  double laser_seeded_polish_translation = 0.01;
  double laser_seeded_polish_rotation = 0.002;  ///< rad; see laser_seeded_polish_translation
  double max_prediction_gap = 1.0;  ///< (fixed) s; scans further apart than this are not predicted (no motion assumed)
  /// No robot moves faster: wheel odometry that jumps farther than max_speed x (the time
  /// between two scans, at least 1 s) is left out of that step, and a velocity beyond these
  /// (stamps out of step with their scans) is not predicted from.
  double max_speed = 50.0;       ///< m/s
  double max_turn_rate = 10.0;   ///< rad/s
  /// (Fixed, as is restart_after_jump_back.) Scans closer in time than this do not update the
  /// velocity (their stamps say too little: a log's scans can come 0.5 ms apart and out of order).
  double min_velocity_interval = 0.01;  ///< s
  /// A scan older than the newest keyframe by more than this starts a new odometry chain (a bag
  /// played in a loop, a clock reset), placed by its first loop closure; by less it is skipped
  /// as out of order.
  double restart_after_jump_back = 5.0;  ///< s (the corridor log starts 1.4 s back in time: not a restart)
  /// ICP of consecutive keyframes (and of each scan, match_every_scan); of it only
  /// max_correspondence_distance, trim_fraction and remap_ratio are parameters.
  IcpOptions icp = odometryIcpOptions();
  /// With wheel odometry: when ICP from the wheels' guess fails, moves too far, overlaps too
  /// little or is disputed, a correlative search (correlative.max_translation, .max_rotation)
  /// around the guess and around the same step backwards seeds a second ICP. When the best of
  /// the two and the search's own pose fits the scans by seed_min_score_gain more than the best
  /// pose within two standard deviations of the wheel step does (correlativeScore), the laser's
  /// motion is taken, as a matched step with a wheel step's covariance (found where matching was hard), not disputed: FR079's wheels count a reverse
  /// as forward; wheels slip; a gap between scans. Where the wheels' pose fits about as well
  /// (a corridor, a wrong ICP minimum) the step stays as it was.
  bool correlative_recovery = true;
  CorrelativeSearchOptions correlative{};   ///< the search of correlative_recovery (parameters: max_translation, max_rotation)
  /// With wheel odometry: a keyframe step whose ICP result overlaps the keyframe by less than
  /// this share (of its points within overlap_distance) is also aligned with no guess, as a loop
  /// candidate is (CRF-match, ICP, validation). Its pose is taken, as a matched step with a
  /// wheel step's covariance, when it fits by seed_min_score_gain more (in the field of the
  /// step's own target, the local map) and lies within the windows correlative recovery
  /// searches (withinWheelWindows): ICP ended
  /// in a wrong minimum the wheels could not rule out (FR079 scan 4483, turning: 0.36 rad off at
  /// 0.65 overlap). Farther off, a look-alike room turned 90 degrees fits as well. 0: off.
  double realign_below_overlap = 0.8;
  [[nodiscard]] std::string validate() const;
};

/// How much noisier than modelled the robot's wheels are: the median disagreement of recent
/// ICP steps with the wheels over the median of a chi-square of 3 DoF (2.366), at least 1
/// (the model is a floor). Until min_samples steps were seen it is infinite: no step is judged
/// against wheels whose noise is not known yet.
class WheelNoiseScale {
 public:
  static constexpr std::size_t min_samples = 20;
  explicit WheelNoiseScale(std::size_t window = 100) : window_(window) {}
  void add(double disagreement);
  double scale() const;

 private:
  std::size_t window_;
  std::vector<double> recent_;  ///< a ring of the last window_ values
  std::size_t next_ = 0;
};

/// Where ScanOdometry::match starts from.
struct StepSeeds {
  Pose2 guess;               ///< wheel odometry's motion (from_wheels), else the best the caller knows
  bool from_wheels = false;  ///< guess is the wheels': checked against ICP (max_correction_*, disputes, recovery)
  /// WheelNoiseScale::scale: widens the wheel covariance for max_wheel_disagreement and for a
  /// disputed step.
  double wheel_noise_scale = 1.0;
  /// With from_wheels: the tracked scan's motion carried on by the wheels (track_scans), taken
  /// when ICP from it fits clearly better (seed_min_score_gain) or reaches the wheels' pose.
  std::optional<Pose2> tracked;
};

class ScanOdometry {
 public:
  /// Throws std::invalid_argument when options.validate() finds a problem.
  explicit ScanOdometry(const ScanOdometryOptions& options = {});
  const ScanOdometryOptions& options() const { return options_; }

  /// Has a motion this large (from the last keyframe) earned a new keyframe?
  bool movedEnough(const Pose2& motion) const;
  /// The motion of `current` in the frame of `previous`, from `seeds` (see StepSeeds); ICP
  /// refines it when allowed and sane.
  OdometryStep match(const MatchTarget& previous, const MatchTarget& current, const StepSeeds& seeds) const;
  /// Two poses this close (0.05 m, 0.02 rad) are one: a second ICP from one would find what
  /// the first did.
  static bool samePose(const Pose2& a, const Pose2& b);
  /// ICP's own covariance (IcpResult::covariance) in the step's parameters (x, y, theta);
  /// zero when it is not finite.
  static Eigen::Matrix3d stepCovarianceOf(const IcpResult& icp);
  /// `options` with solution remapping off (for an ICP seeded by a correlative search).
  static IcpOptions withoutRemapping(IcpOptions options);
  /// `options` for an ICP seeded by the laser's motion (the motion model, the last scan's
  /// pose): no solution remapping, and laser_seeded_trim_fraction of the pairs kept.
  IcpOptions laserSeeded(IcpOptions options) const;
  /// `icp` (from a laser seed) polished: ICP again from its pose with icp.trim_fraction,
  /// without remapping, taken when it converges within laser_seeded_polish_translation and
  /// _rotation of it; otherwise `icp` unchanged.
  IcpResult polishLaserSeeded(const MatchTarget& previous, const MatchTarget& current, const IcpResult& icp) const;
  /// Is `pose` where wheels that gave `guess` could have been: within correlative.max_translation
  /// and .max_rotation (plus slack_steps of its search steps) of the guess or of the same step
  /// backwards (wheels that count a reverse as forward)?
  bool withinWheelWindows(const Pose2& pose, const Pose2& guess, double slack_steps) const;
  /// The covariance the noise model gives a step of this motion.
  Eigen::Matrix3d stepCovariance(const Pose2& motion, bool matched) const;
  /// ambiguity_score_drop: widens a matched step's covariance along the direction its ICP
  /// covariance is longest to (ambiguousShift there)^2, `field` being the likelihood field of
  /// the step's target (made with `correlative`). Records the shift in step.ambiguous_shift;
  /// returns whether the covariance grew (never for an unmatched step or with the option off).
  bool widenAlongAmbiguity(const LikelihoodField& field, const Points2& scan, OdometryStep& step) const;

 private:
  /// correlative_recovery: the laser's motion when it fits clearly better than the wheels' guess.
  std::optional<Pose2> recoverFromWheels(const SeedScorer& scorer, const MatchTarget& previous, const MatchTarget& current, const Pose2& guess,
                                         const IcpResult& icp, const ShapeValidationOptions& overlap,
                                         double wheel_scale) const;

  ScanOdometryOptions options_;
};

}  // namespace llc
