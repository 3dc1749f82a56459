#include "services/pipeline/thread_usage.hpp"

#include <sys/resource.h>

#include <ctime>

namespace planecell::services {

ThreadUsage thread_usage() {
  ThreadUsage usage;
  // CPU time from the thread CPU clock: exact to the nanosecond, whereas getrusage's times of a
  // running thread lag by up to a scheduler tick.
  timespec cpu{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cpu) == 0)
    usage.cpu_ms = 1e3 * static_cast<double>(cpu.tv_sec) + 1e-6 * static_cast<double>(cpu.tv_nsec);
#ifdef RUSAGE_THREAD
  rusage r{};
  if (getrusage(RUSAGE_THREAD, &r) == 0) {
    usage.minor_faults = r.ru_minflt;
    usage.major_faults = r.ru_majflt;
  }
#endif
  return usage;
}

}  // namespace planecell::services
