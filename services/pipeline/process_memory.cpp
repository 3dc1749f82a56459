#include "services/pipeline/process_memory.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>

namespace planecell::services {

std::size_t resident_bytes() {
  std::FILE* statm = std::fopen("/proc/self/statm", "r");
  if (!statm) return 0;
  unsigned long total_pages = 0,
                resident_pages = 0;  // statm: size resident shared text lib data dt
  const int fields = std::fscanf(statm, "%lu %lu", &total_pages, &resident_pages);
  std::fclose(statm);
  const long page_bytes = sysconf(_SC_PAGESIZE);
  if (fields != 2 || page_bytes <= 0) return 0;
  return static_cast<std::size_t>(resident_pages) * static_cast<std::size_t>(page_bytes);
}

std::size_t peak_resident_bytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<std::size_t>(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace planecell::services
