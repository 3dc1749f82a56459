#pragma once
/// Allocator settings for a process that streams frames: keep freed heap memory for the next frame
/// instead of handing it back to the kernel after every frame.
///
/// Why: the stages allocate and free buffers of a few MB per frame (extraction: ~12 MB). With
/// glibc's defaults the heap is trimmed as soon as its free top exceeds a few MB and every such
/// buffer is faulted in again (and zeroed by the kernel) the next frame: ~3000 page faults and
/// ~8 ms of CPU per 1242×375 frame in the threaded pipeline. Kept memory is bounded by the peak
/// use of each allocator arena; it is reused, not leaked.
#include <cstddef>

#include "core/config/pipeline_config.hpp"

namespace planecell::services {

/// Process-wide (call once at a command's start, before the pipeline threads): glibc's trim
/// threshold to `retain_bytes`, and its mmap threshold to min(retain_bytes, 32 MB) so that
/// buffers below it come from the (kept) heap. 0 leaves the allocator's defaults. Returns false
/// when the allocator refused or is not glibc's (nothing changed then).
bool retain_freed_heap(std::size_t retain_bytes);

/// retain_freed_heap(config.heap_retain_mb MB) for the commands that stream frames (replay, run).
/// Throws ConfigError on a negative value; logs (debug) when the allocator does not take it.
void apply_heap_config(const PipelineConfig& config);

}  // namespace planecell::services
