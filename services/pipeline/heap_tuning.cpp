#include "services/pipeline/heap_tuning.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <climits>
#include <string>

#include "core/error.hpp"

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace planecell::services {

bool retain_freed_heap(std::size_t retain_bytes) {
  if (retain_bytes == 0) return true;
#ifdef __GLIBC__
  // glibc caps M_MMAP_THRESHOLD at HEAP_MAX_SIZE / 2 (32 MB on 64-bit); larger blocks (the SGM
  // volume) stay mmap'd, and are kept by their owners anyway.
  constexpr std::size_t kMaxMmapThreshold = std::size_t{32} << 20;
  const std::size_t trim = std::min<std::size_t>(retain_bytes, INT_MAX);
  const std::size_t mmap = std::min(trim, kMaxMmapThreshold);
  return mallopt(M_MMAP_THRESHOLD, static_cast<int>(mmap)) == 1 &&
         mallopt(M_TRIM_THRESHOLD, static_cast<int>(trim)) == 1;
#else
  return false;
#endif
}

void apply_heap_config(const PipelineConfig& config) {
  if (config.heap_retain_mb < 0)
    throw ConfigError("pipeline.heap_retain_mb = " + std::to_string(config.heap_retain_mb) +
                      ": must be 0 (allocator defaults) or positive");
  const std::size_t bytes = static_cast<std::size_t>(config.heap_retain_mb) << 20;
  if (!retain_freed_heap(bytes))
    spdlog::debug("pipeline.heap_retain_mb = {}: not applied (allocator is not glibc's or refused)",
                  config.heap_retain_mb);
}

}  // namespace planecell::services
