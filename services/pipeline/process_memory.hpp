#pragma once
/// Resident memory of this process, for memory-over-time curves (replay --report rss_mb, soak).
#include <cstddef>

namespace planecell::services {

/// Resident set size now, bytes (/proc/self/statm: resident pages × page size). 0 where /proc is
/// not available.
std::size_t resident_bytes();

/// Peak resident set size so far, bytes (getrusage ru_maxrss). 0 where not available.
std::size_t peak_resident_bytes();

}  // namespace planecell::services
