#include "services/pipeline/stage_cost_log.hpp"

namespace planecell::services {

void StageCostLog::add(const FrameWork& work) {
  for (const auto& [stage, cost] : work.stage_cost) {
    cpu_ms_.add(stage, cost.cpu_ms);
    auto& [sum, runs] = faults_[stage];
    sum += cost.minor_faults;
    ++runs;
  }
}

std::vector<std::pair<std::string, StageCostSummary>> StageCostLog::summaries() const {
  std::vector<std::pair<std::string, StageCostSummary>> out;
  for (const auto& [stage, cpu] : cpu_ms_.summaries()) {
    const auto& [fault_sum, runs] = faults_.at(stage);
    StageCostSummary summary{cpu, 0.0};
    if (runs > 0)
      summary.minor_faults_mean = static_cast<double>(fault_sum) / static_cast<double>(runs);
    out.emplace_back(stage, summary);
  }
  return out;
}

}  // namespace planecell::services
