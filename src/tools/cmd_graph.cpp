// llc graph: a 2D g2o pose graph through the ESDF, incrementally (in file order: the mean kept
// current after every loop edge) or in batch (all edges, then Gauss-Newton from the file's
// initial poses, or the odometry chain when it has none).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <vector>

#include <sys/resource.h>

#include "commands.hpp"
#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/io/g2o_io.hpp"

namespace llc_tool {
namespace {

/// Adds the milliseconds since `start` to `out` when it goes out of scope (every path of a step).
struct StepTimer {
  std::chrono::steady_clock::time_point start;
  std::vector<double>* out;
  ~StepTimer() { out->push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count()); }
};

}  // namespace

const std::vector<std::string> kEsdfFlags = parameterNamesUnder("esdf/", {"esdf/gate_loops"});

int runGraph(const Args& args) {
  const std::string in_path = args.required("g2o"), out_path = args.required("out");
  if (args.has("incremental") && args.has("batch")) throw UsageError("--incremental and --batch exclude each other");
  const bool batch = args.has("batch");
  llc::SystemOptions system;
  applyParameterFlags(args, &system);  // --esdf/... (the only parameter flags llc graph takes)
  const llc::EsdfOptions options = system.slam.esdf;
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw UsageError(invalid);
  const bool gate = args.has("gate");
  checkOutputFile("out", out_path);
  const std::string latency_path = args.get("latency-csv", "");
  if (!latency_path.empty()) {
    if (batch) throw UsageError("--latency-csv times the steps of an incremental run, not --batch");
    checkOutputFile("latency-csv", latency_path);
  }
  llc::PoseGraph2 graph;
  try {
    graph = llc::readG2o(in_path);
  } catch (const llc::G2oError& e) {
    throw ToolError(e.what());
  }
  const auto start = std::chrono::steady_clock::now();
  llc::Esdf filter(graph.poses.front(), options);
  std::size_t loops = 0, refused = 0;
  // Edges in file order: a new pose is augmented by the first edge that reaches it from an
  // existing one; any other edge is applied as soon as both of its poses exist. An edge that
  // comes before its poses waits, filed under the newer of them (a graph of two sessions
  // joined later, as ais2klinik: the second's chain arrives before the edge that reaches it).
  std::map<std::size_t, std::vector<const llc::PoseEdge*>> waiting;
  auto apply = [&](const llc::PoseEdge& e) {
    ++loops;
    // Batch: every edge in first, one solve at the end from the file's initial poses.
    const llc::EsdfUpdateResult r = filter.updateWithInformation(e, gate && !batch, !batch);
    if (!r.applied) {
      ++refused;
      std::cerr << "refused edge " << e.from << " -> " << e.to << ": " << r.reject_reason << "\n";
    }
  };
  // Per step (one edge of the file: a pose augmented with the edges it released, or one edge
  // applied, or one set waiting): what a caller adding them one by one waits each time.
  std::vector<double> step_ms;
  step_ms.reserve(graph.edges.size());
  // Augments the next pose by `e`, then takes in what waited for it, and for the poses after
  // it that a waiting edge now reaches.
  auto augment = [&](const llc::PoseEdge& first) {
    for (const llc::PoseEdge* e = &first; e;) {
      filter.augmentWithInformation(*e);
      e = nullptr;
      const auto due = waiting.find(filter.size() - 1);  // both of their poses exist now
      if (due != waiting.end()) {
        for (const llc::PoseEdge* d : due->second) apply(*d);
        waiting.erase(due);
      }
      const auto next = waiting.find(filter.size());
      if (next == waiting.end()) continue;
      std::vector<const llc::PoseEdge*>& edges = next->second;
      const auto reaching = std::find_if(edges.begin(), edges.end(), [&](const llc::PoseEdge* w) {
        return w->from < filter.size() && w->to == filter.size();
      });
      if (reaching != edges.end()) e = *reaching, edges.erase(reaching);
      if (edges.empty()) waiting.erase(next);
    }
  };
  for (const llc::PoseEdge& e : graph.edges) {
    const StepTimer timer{std::chrono::steady_clock::now(), &step_ms};
    if (e.from < filter.size() && e.to == filter.size()) augment(e);
    else if (e.from < filter.size() && e.to < filter.size()) apply(e);
    else waiting[std::max(e.from, e.to)].push_back(&e);
  }
  if (!waiting.empty() || filter.size() != graph.poses.size())
    throw ToolError(in_path + ": " + std::to_string(graph.poses.size() - filter.size()) +
                    " poses cannot be reached from pose 0 along the edges");
  if (batch) filter.solveFrom(graph.poses);
  // Wrong loops. Unless --least-squares, a graph with loops is solved again robustly
  // (robust_loop_chi2 = loop_chi2_threshold) from the file's start, and of that and the
  // least-squares end the lower robust cost is kept: where every loop fits both are the
  // least-squares optimum, where a wrong loop bent the graph only the re-solve lets it go. Not
  // only when a constraint misfits: least squares can bend a graph to fit a wrong loop so
  // evenly that nothing misfits. Given --esdf/robust_loop_chi2, an incremental run reweights
  // as it goes and is re-solved so too.
  const std::size_t misfits = filter.misfitConstraints(options.loop_chi2_threshold);
  bool robust = options.robust_loop_chi2 > 0.0, resolve = robust && !batch;
  if (!robust && loops > 0 && !args.has("least-squares")) {
    filter.setRobustLoopChi2(options.loop_chi2_threshold);
    robust = resolve = true;
  }
  bool robust_resolve_kept = false;
  if (resolve) {
    const std::vector<llc::Pose2> incremental = filter.mean();
    const double incremental_cost = filter.robustCost();
    filter.solveFrom(graph.poses);
    robust_resolve_kept = filter.robustCost() < incremental_cost;
    if (!robust_resolve_kept) filter.solveFrom(incremental);
  }
  std::size_t down_weighted = 0;  // loops the robust kernel holds at under a tenth of their information
  for (double w : filter.constraintWeights()) down_weighted += w < 0.1;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  llc::PoseGraph2 out = graph;
  out.poses = filter.mean();
  try {
    llc::writeG2o(out, out_path);
  } catch (const llc::G2oError& e) {
    throw ToolError(e.what());
  }
  std::cout << "poses=" << out.poses.size() << " edges=" << graph.edges.size() << " loop_edges=" << loops
            << " refused=" << refused << " factorizations=" << filter.factorizations()
            << " rank_updates=" << filter.rankUpdates()
            << " relinearizations=" << filter.relinearizations()
            << " edges_relinearized_in_place=" << filter.edgesRelinearizedInPlace()
            << " rebuilds=" << filter.rebuilds() << std::setprecision(3)
            << " seconds_rank_updates=" << filter.timings().rank_updates
            << " seconds_solves=" << filter.timings().solves
            << " seconds_factorizations=" << filter.timings().factorizations << " initial_chi2=" << std::setprecision(10)
            << llc::chiSquared(graph.edges, graph.poses) << " -> " << out_path << "\n";
  std::cout << "misfit_constraints=" << misfits << "\n";
  if (robust)
    std::cout << "robust: loops_down_weighted=" << down_weighted << " robust_cost=" << filter.robustCost()
              << (!resolve ? "" : robust_resolve_kept ? " (the robust re-solve from the start kept)" : " (the run's own end kept)")
              << "\n";
  std::cout << "chi2=" << llc::chiSquared(graph.edges, out.poses) << "\n";
  std::cout << "seconds=" << std::setprecision(4) << seconds << "\n";
  // The process's peak resident memory (the file read, the filter, its factor): an upper bound
  // on the back end's memory per pose.
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) == 0 && !out.poses.empty())
    std::cout << std::setprecision(4) << "peak_rss_mb=" << double(usage.ru_maxrss) / 1024.0
              << "\npeak_rss_bytes_per_pose=" << std::setprecision(6) << 1024.0 * double(usage.ru_maxrss) / double(out.poses.size())
              << "\n";
  if (!batch && !step_ms.empty()) {
    // Nearest-rank percentiles of the steps' latency, and the step (edge index in file order) of the worst.
    std::vector<double> sorted = step_ms;
    std::sort(sorted.begin(), sorted.end());
    auto rank = [&](double p) {  // the smallest value with at least p of the steps at or below it
      const std::size_t k = std::size_t(std::max(1.0, std::ceil(p * double(sorted.size()))));
      return sorted[std::min(sorted.size(), k) - 1];
    };
    const std::size_t worst = std::size_t(std::max_element(step_ms.begin(), step_ms.end()) - step_ms.begin());
    std::cout << std::setprecision(4) << "step_latency_median_ms=" << rank(0.5) << "\nstep_latency_p90_ms=" << rank(0.9)
              << "\nstep_latency_p99_ms=" << rank(0.99) << "\nstep_latency_max_ms=" << sorted.back()
              << "\nstep_latency_max_at=" << worst << "\ntotal_seconds=" << seconds << "\n";
  }
  if (!latency_path.empty()) {
    std::ofstream csv(latency_path);
    csv << "step,edge_from,edge_to,ms\n" << std::setprecision(6);
    for (std::size_t k = 0; k < step_ms.size(); ++k)
      csv << k << ',' << graph.edges[k].from << ',' << graph.edges[k].to << ',' << step_ms[k] << '\n';
    if (!csv.flush()) throw ToolError("could not write " + latency_path);
  }
  return 0;
}

}  // namespace llc_tool
