#pragma once
/// CPU time and page faults of the calling thread, to tell a stage's own cost (what it burns on
/// its thread) from its wall time (which also counts waiting for a core when more threads than
/// cores are runnable).
#include <cstdint>

namespace planecell::services {

/// Cumulative usage of the calling thread since it started (getrusage RUSAGE_THREAD on Linux;
/// zeros elsewhere). Differences of two calls on the same thread give the usage in between.
struct ThreadUsage {
  double cpu_ms = 0.0;            ///< user + system CPU time
  std::int64_t minor_faults = 0;  ///< page faults served without I/O (first touch of new pages)
  std::int64_t major_faults = 0;  ///< page faults that read from disk
};

ThreadUsage thread_usage();

}  // namespace planecell::services
