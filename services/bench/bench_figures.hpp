#pragma once
/// The bench report's charts, drawn with services/bench/plot.
#include <opencv2/core/mat.hpp>

#include "services/bench/bench_report.hpp"

namespace planecell::services::bench {

/// Reconstruction accuracy (the paper's Fig. "Reconstruction accuracy"): share of GT pixels within
/// x of their GT point, x from 0 to 1 m, one curve per representation (pooled over the frames).
cv::Mat accuracy_figure(const BenchReport& report);

/// Bytes of every representation versus frames mapped (log scale): planecell RAM and store,
/// point cloud, OctoMap memoryUsage and .bt.
cv::Mat memory_figure(const BenchReport& report);

/// Per-stage latency p50 / p95 / p99 (ms): the pipeline's stages and the baselines' own.
cv::Mat latency_figure(const BenchReport& report);

}  // namespace planecell::services::bench
