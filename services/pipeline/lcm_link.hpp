#pragma once
/// What the LCM commands (run, feed, listen) share: opening an LCM URL with a clear error, the
/// SIGINT/SIGTERM stop flag, and the daemon's stats message.
#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <memory>
#include <string>

#include "core/error.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "services/pipeline/pipeline.hpp"

namespace planecell::services {

/// Opens `url`. Throws ConfigError when LCM cannot use it (bad URL, or no multicast route: on a
/// machine without a network, run scripts/lcm-route.sh).
std::unique_ptr<lcm::LCM> open_lcm(const std::string& url);

/// Publishes `message` on `channel`; throws StorageError when LCM cannot send it.
template <class Message>
void publish_message(lcm::LCM& lcm, const std::string& channel, const Message& message) {
  const auto bytes = io::encode_bytes(message);
  if (lcm.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size())) != 0)
    throw StorageError("LCM: cannot publish " + std::to_string(bytes.size()) + " bytes on '" + channel + "'");
}

/// Installs SIGINT/SIGTERM handlers that set a flag (the previous handlers come back on
/// destruction). The flag is process-wide by nature of signals; only one StopSignals at a time.
class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  bool requested() const;
  int signal_number() const;
};

/// Microseconds since the epoch (LCM's utime).
std::int64_t now_utime();

/// The daemon's stats as a message.
planecell_lcm::map_stats_t to_lcm(const PipelineStats& stats, std::size_t messages_rejected, std::int64_t utime);

}  // namespace planecell::services
