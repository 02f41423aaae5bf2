// llc align: CRF-match + ICP + shape validation on labelled pairs, against the ground truth,
// optionally side by side with PCL's ICP and GICP started from the identity.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "commands.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/alignment/crf_training.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "pcl_baselines.hpp"

namespace llc_tool {
namespace {

/// How far an estimate may lie from the ground truth (--tolerance-m, --tolerance-deg).
struct Tolerance {
  double translation = 0.2;        ///< m
  double rotation = 2.0 * M_PI / 180.0;  ///< rad
  /// Pose b within tolerance of pose a.
  bool near(const llc::Pose2& a, const llc::Pose2& b) const {
    const llc::Pose2 d = llc::between(a, b);
    return std::hypot(d.x, d.y) <= translation && std::abs(d.theta) <= rotation;
  }
};

/// Share of the positive pairs aligned within tolerance, and timing, for one method.
struct MethodStats {
  std::size_t positives = 0, within = 0;
  std::vector<double> ms;
  void add(bool positive, const llc::Pose2& estimate, const llc::Pose2& truth, bool ok, double milliseconds,
           const Tolerance& tolerance) {
    ms.push_back(milliseconds);
    if (!positive) return;
    ++positives;
    within += ok && tolerance.near(truth, estimate);
  }
  double median() const {
    if (ms.empty()) return 0.0;
    std::vector<double> v = ms;
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return v[v.size() / 2];
  }
};

/// Why a positive pair was not aligned within tolerance, judged by ICP started from the
/// ground truth itself (--truth-check).
struct TruthCheck {
  std::size_t failed = 0;
  std::size_t no_start_near_truth = 0;   ///< ICP stays at the truth, which fits better than our result: the starts missed it
  std::size_t better_fit_elsewhere = 0;  ///< ICP stays at the truth, but our (wrong) result fits at least as well
  std::size_t truth_moves = 0;           ///< ICP from the truth converges out of tolerance: the truth is not a fit optimum
  std::size_t icp_fails_at_truth = 0;    ///< ICP from the truth does not converge (e.g. degenerate geometry)
  // A second opinion on those last two kinds, from PCL's GICP started at the truth too:
  std::size_t gicp_agrees_off_truth = 0;  ///< GICP also leaves the tolerance, to within it of our ICP: the reference is off
  std::size_t gicp_stays_at_truth = 0;    ///< GICP stays within tolerance of the truth: our ICP is at fault there
};

}  // namespace

// The aligner's parameters, named as in config/slam.yaml, and the CRF weights file.
const std::vector<std::string> kAlignerFlags = [] {
  std::vector<std::string> flags = parameterNamesUnder("aligner/");
  flags.push_back("crf-weights");
  return flags;
}();

std::shared_ptr<const llc::PreparedScan> PreparedScanCache::get(std::size_t index) {
  auto& slot = prepared_[index];
  if (!slot) slot = aligner_.prepare(sequence_.scans.at(index).scan);
  return slot;
}

llc::ScanAlignerOptions alignerOptions(const Args& args) {
  llc::SystemOptions system;
  applyParameterFlags(args, &system);  // --aligner/... (the only parameter flags these subcommands take)
  llc::ScanAlignerOptions options = system.slam.aligner;
  if (args.has("crf-weights")) {
    try {
      options.crf.weights = llc::loadCrfWeights(args.get("crf-weights", ""));
    } catch (const llc::CrfWeightsError& e) {
      throw ToolError(e.what());
    }
  }
  const std::string error = options.validate();
  if (!error.empty()) throw UsageError(error);
  return options;
}

int runAlign(const Args& args) {
  const std::string out_path = args.required("out");
  const llc::ScanAligner aligner(alignerOptions(args));
  Tolerance tolerance;
  tolerance.translation = args.number("tolerance-m", 0.2);
  tolerance.rotation = args.number("tolerance-deg", 2.0) * M_PI / 180.0;
  if (!(tolerance.translation > 0.0 && tolerance.rotation > 0.0))
    throw UsageError("--tolerance-m and --tolerance-deg must be > 0");
  checkOutputFile("out", out_path);
  std::unique_ptr<llc::ClassifierModel> model;
  if (args.has("model")) {
    try {
      model = std::make_unique<llc::ClassifierModel>(llc::loadClassifierModel(args.get("model", "")));
    } catch (const llc::ModelError& e) {
      throw ToolError(e.what());
    }
  }
  const std::vector<PairData> data =
      loadPairData(args.all("data"), model ? model->features : llc::FeatureOptions{}, args);
  const bool compare = args.has("compare-pcl");
  llc::AtomicTextFile out(out_path);
  const bool truth_check = args.has("truth-check");
  out << "a,b,label,x,y,theta,inlier_share,accepted,ms";
  if (truth_check)
    out << ",fit,truth_fit,icp_from_truth_converged,icp_from_truth_fit,icp_from_truth_error_m,icp_from_truth_error_deg"
           ",icp_from_truth_refusal,gicp_from_truth_converged,gicp_from_truth_error_m,gicp_from_truth_error_deg"
           ",error_m,error_deg";
  out << '\n' << std::setprecision(9);
  TruthCheck check;

  MethodStats ours, pcl_icp, pcl_gicp;
  std::map<std::string, std::size_t> reasons;
  std::size_t candidates = 0, negatives_classified = 0, negatives_refused = 0, positives_accepted = 0, positives = 0;
  std::size_t accepted_within = 0;  // accepted positives within tolerance of the truth: what a map would get
  for (const PairData& item : data) {
    PreparedScanCache prepared(aligner, item.sequence);
    for (const llc::LabeledPair& p : item.pairs) {
      if (model) {
        const std::vector<double> row =
            llc::pairFeatures(model->features.feature_set, item.features[p.a], item.features[p.b]);
        if (!model->classifier.isMatch(row.data())) continue;  // not a candidate
      }
      ++candidates;
      const llc::Pose2 truth = llc::between(item.sequence.scans[p.a].truth, item.sequence.scans[p.b].truth);
      const auto a = prepared.get(p.a), b = prepared.get(p.b);
      const llc::ScanAlignmentResult r = aligner.align(*a, *b);
      const bool aligned = r.icp.converged;
      ours.add(p.label == 1, r.pose, truth, aligned, 1e3 * r.seconds, tolerance);
      const bool within = aligned && tolerance.near(truth, r.pose);
      if (!r.accepted) ++reasons[llc::alignmentRefusalName(r.refusal)];
      if (p.label == 1) ++positives, positives_accepted += r.accepted;
      if (p.label == 1 && r.accepted) accepted_within += within;
      if (p.label == 0) ++negatives_classified, negatives_refused += !r.accepted;
      out << p.a << ',' << p.b << ',' << p.label << ',';
      if (aligned) out << r.pose.x << ',' << r.pose.y << ',' << r.pose.theta;
      else out << "nan,nan,nan";
      out << ',' << r.validation.inlier_share << ',' << int(r.accepted) << ',' << 1e3 * r.seconds;
      if (truth_check) {
        const llc::IcpResult from_truth = aligner.refine(*a, *b, truth);
        // The winner's share, as align() ranked it (not always the largest: see min_relative_overlap).
        const double fit = aligned ? r.icp_shares[r.chosen] : 0.0;
        const double truth_fit = from_truth.converged ? aligner.fit(*a, *b, from_truth.pose) : 0.0;
        const PclAlignment gicp = alignPcl(PclMethod::kGicp, b->points, a->points, aligner.options().icp, truth);
        auto writeOffset = [&out, &truth](const llc::Pose2& pose) {  // ",metres,degrees" of pose from the truth
          const llc::Pose2 d = llc::between(truth, pose);
          out << ',' << std::hypot(d.x, d.y) << ',' << std::abs(d.theta) * 180.0 / M_PI;
        };
        out << ',' << fit << ',' << aligner.fit(*a, *b, truth) << ',' << int(from_truth.converged) << ',' << truth_fit;
        writeOffset(from_truth.pose);
        out << ',' << from_truth.reject_reason << ',' << int(gicp.converged);
        writeOffset(gicp.pose);
        if (aligned) writeOffset(r.pose);
        else out << ",nan,nan";
        if (p.label == 1 && !within) {
          ++check.failed;
          const bool icp_moves = from_truth.converged && !tolerance.near(truth, from_truth.pose);
          if (!from_truth.converged) ++check.icp_fails_at_truth;
          else if (icp_moves) ++check.truth_moves;
          else if (!aligned || truth_fit > fit) ++check.no_start_near_truth;
          else ++check.better_fit_elsewhere;
          if (!from_truth.converged || icp_moves) {
            if (gicp.converged && tolerance.near(truth, gicp.pose)) ++check.gicp_stays_at_truth;
            else if (icp_moves && gicp.converged && tolerance.near(from_truth.pose, gicp.pose)) ++check.gicp_agrees_off_truth;
          }
        }
      }
      out << '\n';
      if (compare) {
        const PclAlignment icp = alignPcl(PclMethod::kIcp, b->points, a->points, aligner.options().icp);
        pcl_icp.add(p.label == 1, icp.pose, truth, icp.converged, icp.ms, tolerance);
        const PclAlignment gicp = alignPcl(PclMethod::kGicp, b->points, a->points, aligner.options().icp);
        pcl_gicp.add(p.label == 1, gicp.pose, truth, gicp.converged, gicp.ms, tolerance);
      }
    }
  }
  out.commit();
  std::cout << std::fixed << std::setprecision(4);
  std::cout << "pairs=" << candidates << (model ? " (accepted by the classifier)" : "") << " positives=" << positives
            << " -> " << out_path << "\n";
  for (const auto& [reason, count] : reasons) std::cout << "refused_by_" << reason << "=" << count << "\n";
  std::cout << "tolerance: " << tolerance.translation << " m, " << tolerance.rotation * 180.0 / M_PI << " deg\n";
  auto line = [&](const char* name, const MethodStats& s) {
    std::cout << name << ": within_tolerance=" << (s.positives ? double(s.within) / double(s.positives) : 0.0)
              << " (" << s.within << "/" << s.positives << ") median_ms=" << s.median() << "\n";
  };
  line("crf_icp", ours);
  if (compare) {
    line("pcl_icp_identity", pcl_icp);
    line("pcl_gicp_identity", pcl_gicp);
  }
  if (truth_check)
    std::cout << "failed_positives=" << check.failed << " no_start_near_truth=" << check.no_start_near_truth
              << " better_fit_elsewhere=" << check.better_fit_elsewhere << " truth_moves_under_icp=" << check.truth_moves
              << " icp_fails_at_truth=" << check.icp_fails_at_truth
              << " of_those_two_gicp_from_truth_agrees_off_truth=" << check.gicp_agrees_off_truth
              << " gicp_from_truth_stays=" << check.gicp_stays_at_truth << "\n";
  std::cout << "positives_accepted=" << (positives ? double(positives_accepted) / double(positives) : 0.0) << "\n";
  std::cout << "accepted_positives_within_tolerance="
            << (positives_accepted ? double(accepted_within) / double(positives_accepted) : 0.0) << " (" << accepted_within
            << "/" << positives_accepted << ")\n";
  std::cout << "negatives_refused=" << (negatives_classified ? double(negatives_refused) / double(negatives_classified) : 0.0)
            << " (" << negatives_refused << "/" << negatives_classified << ")\n";
  return 0;
}

}  // namespace llc_tool

namespace llc_tool {

int runTrainCrf(const Args& args) {
  const std::string out_path = args.required("out");
  const llc::ScanAligner aligner(alignerOptions(args));
  llc::CrfTrainingOptions training;
  training.epochs = int(args.integer("epochs", training.epochs));
  training.seed = std::uint64_t(args.integer("seed", long(training.seed)));
  const std::string invalid = training.validate();
  if (!invalid.empty()) throw UsageError(invalid);
  checkOutputFile("out", out_path);
  const std::vector<std::string> specs = args.all("data");
  const std::vector<PairData> data = loadPairData(specs, llc::FeatureOptions{}, args);
  std::vector<std::shared_ptr<const llc::PreparedScan>> keep;
  std::vector<llc::CrfTrainingPair> pairs;
  for (const PairData& item : data) {
    PreparedScanCache prepared(aligner, item.sequence);
    auto get = [&](std::size_t i) {
      keep.push_back(prepared.get(i));  // the training pairs point into them
      return keep.back().get();
    };
    for (const llc::LabeledPair& p : item.pairs) {
      if (p.label != 1) continue;
      // Source b in the frame of target a, as the aligner uses them.
      pairs.push_back({&get(p.b)->crf, &get(p.a)->crf,
                       llc::between(item.sequence.scans[p.a].truth, item.sequence.scans[p.b].truth)});
    }
  }
  if (pairs.empty()) throw ToolError("no positive pairs to learn from");
  const llc::CrfTrainingResult result = llc::trainCrfWeights(pairs, aligner.options().crf, training);
  std::ostringstream data_text;
  for (const std::string& spec : specs) data_text << (data_text.tellp() ? " " : "") << spec;
  std::ostringstream errors;
  for (double e : result.error_by_epoch) errors << (errors.tellp() ? " " : "") << std::setprecision(4) << e;
  try {
    llc::saveCrfWeights(result.weights, {{"data", data_text.str()}, {"positive_pairs", std::to_string(pairs.size())},
                                         {"epochs", std::to_string(training.epochs)}, {"error_by_epoch", errors.str()}},
                        out_path);
  } catch (const llc::CrfWeightsError& e) {
    throw ToolError(e.what());
  }
  std::cout << "positive_pairs=" << pairs.size() << " node_error_by_epoch=" << errors.str() << " -> " << out_path << "\n";
  const auto w = result.weights.asArray();
  std::cout << "weights=";
  for (std::size_t q = 0; q < w.size(); ++q) std::cout << (q ? "," : "") << std::setprecision(3) << w[q];
  std::cout << "\n";
  return 0;
}

}  // namespace llc_tool
