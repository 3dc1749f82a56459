#include "services/pipeline/lcm_link.hpp"

#include <chrono>
#include <csignal>

#include "core/error.hpp"

namespace planecell::services {
namespace {

/// Set by the signal handler (a signal handler can only reach static storage).
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void on_stop_signal(int number) { g_stop_signal = number; }

struct sigaction g_previous_int, g_previous_term;

}  // namespace

std::unique_ptr<lcm::LCM> open_lcm(const std::string& url) {
  auto lcm = std::make_unique<lcm::LCM>(url);
  if (!lcm->good())
    throw ConfigError("LCM URL '" + url +
                      "' cannot be opened (bad URL, or no multicast route: run scripts/lcm-route.sh as root)");
  return lcm;
}

StopSignals::StopSignals() {
  g_stop_signal = 0;
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &g_previous_int);
  sigaction(SIGTERM, &action, &g_previous_term);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &g_previous_int, nullptr);
  sigaction(SIGTERM, &g_previous_term, nullptr);
}

bool StopSignals::requested() const { return g_stop_signal != 0; }
int StopSignals::signal_number() const { return g_stop_signal; }

std::int64_t now_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

planecell_lcm::map_stats_t to_lcm(const PipelineStats& stats, std::size_t messages_rejected, std::int64_t utime) {
  planecell_lcm::map_stats_t m;
  m.utime = utime;
  m.frames_in = static_cast<std::int64_t>(stats.frames_in);
  m.frames_done = static_cast<std::int64_t>(stats.frames_done);
  m.frames_dropped = static_cast<std::int64_t>(stats.frames_dropped);
  m.frames_failed = static_cast<std::int64_t>(stats.frames_failed);
  m.messages_rejected = static_cast<std::int64_t>(messages_rejected);
  for (const auto& [stage, s] : stats.latency) {
    m.stage.push_back(stage);
    m.p50_ms.push_back(static_cast<float>(s.p50_ms));
    m.p95_ms.push_back(static_cast<float>(s.p95_ms));
    m.p99_ms.push_back(static_cast<float>(s.p99_ms));
  }
  m.num_stages = static_cast<std::int32_t>(m.stage.size());
  for (const auto& [queue, depth] : stats.queue_depths) {
    m.queue.push_back(queue);
    m.queue_depth.push_back(static_cast<std::int32_t>(depth));
  }
  m.num_queues = static_cast<std::int32_t>(m.queue.size());
  m.map_cells = static_cast<std::int64_t>(stats.map_cells);
  m.map_surfaces = static_cast<std::int64_t>(stats.map_surfaces);
  return m;
}

}  // namespace planecell::services
