/// `planecell listen` — an example map subscriber for path planning: mirrors the daemon's map from
/// map updates only, prints its stats, answers clearance and ground-height queries.
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <memory>
#include <sstream>

#include "core/error.hpp"
#include "services/commands/commands.hpp"
#include "services/pipeline/lcm_link.hpp"
#include "services/pipeline/mirror_map.hpp"

namespace planecell::services {
namespace {

Eigen::Vector3d parse_point(const std::string& text) {
  std::istringstream in(text);
  Eigen::Vector3d p;
  char c1 = 0, c2 = 0;
  if (!(in >> p.x() >> c1 >> p.y() >> c2 >> p.z()) || c1 != ',' || c2 != ',' || !in.eof() || !p.allFinite())
    throw ConfigError("--query '" + text + "': expected x,y,z in metres (world frame)");
  return p;
}

class Listener {
 public:
  void on_update(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    last_update_ = std::chrono::steady_clock::now();
    try {
      const auto chunk = io::decode_map_update({static_cast<const std::uint8_t*>(buffer->data), buffer->data_size});
      if (auto update = assembler_.add(chunk)) {
        mirror_.apply(*update);
        if (update->settled)
          settled_ = true;
        else
          ++updates_;
      }
    } catch (const InputError& e) {
      ++rejected_;
      spdlog::warn("listen: skipped a message on {}: {}", channel, e.what());
    }
  }
  void on_stats(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    try {
      const auto s = io::decode_map_stats({static_cast<const std::uint8_t*>(buffer->data), buffer->data_size});
      spdlog::info("daemon: {} frames in, {} mapped, {} dropped, {} failed, {} rejected; map {} cells", s.frames_in,
                   s.frames_done, s.frames_dropped, s.frames_failed, s.messages_rejected, s.map_cells);
    } catch (const InputError& e) {
      ++rejected_;
      spdlog::warn("listen: skipped a message on {}: {}", channel, e.what());
    }
  }
  const io::MapMirror& mirror() const { return mirror_; }
  std::size_t updates() const { return updates_; }  ///< frame updates (not the settling)
  bool settled() const { return settled_; }
  std::size_t rejected() const { return rejected_; }
  std::size_t incomplete() const { return assembler_.incomplete_frames(); }
  std::chrono::steady_clock::time_point last_update() const { return last_update_; }

 private:
  io::MapUpdateAssembler assembler_;
  io::MapMirror mirror_;
  std::size_t updates_ = 0, rejected_ = 0;
  bool settled_ = false;
  std::chrono::steady_clock::time_point last_update_ = std::chrono::steady_clock::now();
};

}  // namespace

void add_listen_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand(
      "listen",
      "Subscribe to the daemon's map updates: keep a mirror of the map from updates only, print the "
      "daemon's stats, and answer clearance (distance to the nearest planecell) and ground-height "
      "queries on the mirror when done.");
  struct Args {
    std::string lcm_url, mirror;
    std::vector<std::string> queries;
    std::size_t count = 0;
    double timeout_s = 0.0;
    double max_distance_m = 50.0;
  };
  auto args = std::make_shared<Args>();
  command->add_option("--lcm", args->lcm_url, "LCM URL (default: lcm.url of the config)");
  command->add_option("--mirror", args->mirror, "Write the mirrored map to this new map store when done");
  command->add_option("--query", args->queries, "World point x,y,z to query (repeatable)");
  command->add_option("--count", args->count, "Stop after this many complete frame updates (0 = no limit)");
  command->add_option("--timeout", args->timeout_s, "Stop after this many seconds without a map update (0 = never)")
      ->check(CLI::NonNegativeNumber);
  command->add_option("--max-distance", args->max_distance_m, "Clearance search radius (m)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  command->footer("Example:\n  planecell listen --count 50 --mirror /tmp/mirror.db --query 0,1.5,12");
  context.add(command, [args](const CommandContext& ctx) {
    AppConfig config = ctx.load_app_config();
    if (!args->lcm_url.empty()) config.lcm.url = args->lcm_url;
    std::vector<Eigen::Vector3d> points;
    for (const auto& q : args->queries) points.push_back(parse_point(q));
    auto lcm = open_lcm(config.lcm.url);
    Listener listener;
    lcm->subscribe(config.lcm.map_update_channel, &Listener::on_update, &listener);
    lcm->subscribe(config.lcm.stats_channel, &Listener::on_stats, &listener);
    const StopSignals signals;
    spdlog::info("listen: subscribed to {} + {} on {}", config.lcm.map_update_channel, config.lcm.stats_channel,
                 config.lcm.url);
    const auto timeout = std::chrono::duration<double>(args->timeout_s);
    while (!signals.requested()) {
      if (lcm->handleTimeout(50) < 0 && !signals.requested())  // a signal interrupts the wait
        throw InputError("LCM: receiving on '" + config.lcm.url + "' failed");
      if (args->count > 0 && listener.updates() >= args->count) break;
      if (args->timeout_s > 0.0 && std::chrono::steady_clock::now() - listener.last_update() > timeout) break;
    }
    const io::MapMirror& mirror = listener.mirror();
    std::cout << "listen: " << listener.updates() << " frame updates applied (last frame " << mirror.last_frame_id
              << (listener.settled() ? ", the map settled after it" : "") << "), " << listener.rejected()
              << " messages rejected, " << listener.incomplete()
              << " frames incomplete; mirror " << mirror.cells.size() << " cells\n";
    const map::GlobalMap map = mirror_to_map(mirror, config.map);
    for (const auto& p : points) {
      std::cout << "  query (" << p.x() << ", " << p.y() << ", " << p.z() << "): ";
      if (const auto near = map.nearest_cell(p, args->max_distance_m))
        std::cout << "clearance " << near->distance_m << " m (cell " << near->cell_id << ")";
      else
        std::cout << "clearance > " << args->max_distance_m << " m";
      if (const auto ground = map.ground_under(p))
        std::cout << ", ground " << ground->height_above_m << " m below (surface " << ground->surface_id << ")";
      else
        std::cout << ", no ground below";
      std::cout << "\n";
    }
    if (!args->mirror.empty()) {
      write_mirror_store(map, mirror.last_frame_id, args->mirror);
      std::cout << "  mirror: " << args->mirror << "\n";
    }
    return signals.requested() ? kExitInterrupted : kExitOk;
  });
}

}  // namespace planecell::services
