#pragma once
/// Configuration of the threaded pipeline (services/pipeline) and of its LCM endpoints
/// (`planecell run`, `feed`, `listen`).
#include <string>

namespace planecell {

/// Threaded pipeline: one thread per stage (ingest → sgm → extract → transform → merge(+store)
/// → publish) joined by bounded single-producer/single-consumer queues.
struct PipelineConfig {
  int queue_capacity = 2;  ///< frames waiting between two stages (≥ 1); bounds memory and latency
  /// SGM worker threads while pipelined (0 = keep sgm.threads). SGM is the longest stage; with 2
  /// its half-passes use whichever core extract and load leave idle. On the 2-core machine at
  /// 10 Hz (1242×375) this cut end-to-end p50 from ~145 to ~115 ms and p99 from 188–247 to
  /// 152–217 ms (docs/PERFORMANCE.md, "Streaming pipeline").
  int sgm_threads = 2;
  double stats_period_s = 1.0;  ///< how often the daemon publishes map stats (s)
  /// Frame size the daemon (`planecell run`) warms its sgm and extract stages up with before it
  /// listens (Pipeline::warm_up): without it the first frames pay ~0.5 s of first-touch page
  /// faults and lazy set-up and the next ones queue behind them. Default: KITTI's 1242×375;
  /// 0 = no warm-up. Replay warms up with its sequence's own size.
  int warm_up_width = 1242;
  int warm_up_height = 375;
  /// Freed heap memory the process keeps for the next frame instead of returning it to the kernel
  /// (MB; glibc trim threshold, see services/pipeline/heap_tuning.hpp; 0 = allocator defaults).
  /// Saves ~3000 page faults (~8 ms CPU) per 1242×375 frame for a few tens of MB of RSS.
  int heap_retain_mb = 256;
};

template <class Visitor>
void visit_fields(PipelineConfig& c, Visitor&& visit) {
  visit("queue_capacity", c.queue_capacity);
  visit("sgm_threads", c.sgm_threads);
  visit("stats_period_s", c.stats_period_s);
  visit("warm_up_width", c.warm_up_width);
  visit("warm_up_height", c.warm_up_height);
  visit("heap_retain_mb", c.heap_retain_mb);
}

/// LCM endpoints. Receivers need a large kernel receive buffer (recv_buf_size in the URL): a
/// stereo frame arrives as one burst of fragments.
struct LcmConfig {
  std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608";
  std::string stereo_channel = "PLANECELL_STEREO";
  std::string pose_channel = "PLANECELL_POSE";
  std::string map_update_channel = "PLANECELL_MAP_UPDATE";
  std::string stats_channel = "PLANECELL_STATS";
};

template <class Visitor>
void visit_fields(LcmConfig& c, Visitor&& visit) {
  visit("url", c.url);
  visit("stereo_channel", c.stereo_channel);
  visit("pose_channel", c.pose_channel);
  visit("map_update_channel", c.map_update_channel);
  visit("stats_channel", c.stats_channel);
}

}  // namespace planecell
