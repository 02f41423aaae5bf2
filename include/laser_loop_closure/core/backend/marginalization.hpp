// Taking poses out of a pose graph while keeping what their constraints said about the others
// (issue 66, a map at bounded size). A pose is marginalised out of the linearised graph at the
// current means: the constraints that touch it become one dense Gaussian over its neighbours
// (the Schur complement of its information, the ESDF's information form makes this exact to
// first order), which is then sparsified into a tree of relative-pose constraints between those
// neighbours (Chow-Liu style, as Kretzschmar & Stachniss 2012): each neighbour but the oldest is
// linked to an older one, the one whose relative pose the dense marginal knows best, with that
// relative pose's marginal mean and covariance. What the tree loses is measured per pose as the
// Kullback-Leibler divergence of the tree's Gaussian from the dense one (the gauge fixed at the
// oldest neighbour).
#pragma once

#include <cstddef>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/io/g2o_io.hpp"

namespace llc {

/// A pose graph with some poses marginalised out.
struct PoseGraphReduction {
  std::vector<Pose2> poses;       ///< the poses kept, in their old order, at their old means
  std::vector<std::size_t> kept;  ///< each kept pose's old index
  /// The constraints between kept poses (renumbered), ordered as the ESDF rebuilds a graph:
  /// pose i > 0 first reached by an augmentation (to == i, from < i), every other constraint
  /// once both its poses exist (SlamSession::validate's order).
  std::vector<PoseEdge> edges;
  std::size_t retired = 0;  ///< poses marginalised out
  /// Poses asked to be retired but kept: the information of their neighbourhood could not be
  /// factorised (not positive definite), so nothing of them was approximated.
  std::size_t kept_unfactorizable = 0;
  std::size_t constraints_added = 0;  ///< tree constraints made (some later marginalised again)
  double mean_kl = 0.0;  ///< nats, over the retired poses with 2 or more neighbours: what each tree lost
  double max_kl = 0.0;   ///< nats
};

/// Marginalises out every pose i with retire[i] (pose 0, which anchors the graph, never), in
/// increasing order. `edges` must give each pose i > 0 an augmentation (an edge to == i from a
/// pose < i), which every graph the ESDF rebuilds has; the result keeps that property. Throws
/// std::invalid_argument when the sizes differ, an edge names an unknown pose or joins a pose
/// to itself, a pose lacks its augmentation, or a value is not finite.
PoseGraphReduction marginalizePoses(const std::vector<Pose2>& poses, const std::vector<PoseEdge>& edges,
                                    const std::vector<char>& retire);

}  // namespace llc
