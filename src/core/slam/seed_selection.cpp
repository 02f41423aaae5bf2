#include "laser_loop_closure/core/slam/seed_selection.hpp"

namespace llc {

const char* seedSourceName(SeedSource source) {
  switch (source) {
    case SeedSource::kWheels: return "wheels";
    case SeedSource::kTracked: return "tracked";
    case SeedSource::kPredicted: return "predicted";
    case SeedSource::kSearched: return "searched";
    case SeedSource::kSearchGrid: return "search_grid";
    case SeedSource::kRealigned: return "realigned";
  }
  return "unknown";
}

std::size_t selectSeed(const std::vector<SeedCandidate>& candidates, double margin) {
  std::size_t chosen = 0;
  for (std::size_t i = 1; i < candidates.size(); ++i)
    if (candidates[i].score >= 0.0 && candidates[i].score >= candidates[chosen].score + margin) chosen = i;
  return chosen;
}

const LikelihoodField& SeedScorer::field() const {
  if (!field_) field_ = std::make_shared<const LikelihoodField>(*target_, options_);
  return *field_;
}

double SeedScorer::score(const Points2& scan, const Pose2& pose) const {
  return correlativeScore(field(), scan, pose, options_.max_points);
}

}  // namespace llc
