/// The `planecell` command-line tool: one subcommand per job, see `planecell --help`.
#include <spdlog/spdlog.h>

#include <iostream>

#include "core/error.hpp"
#include "services/command.hpp"
#include "services/commands/commands.hpp"
#include "services/logging.hpp"

int main(int argc, char** argv) {
  using namespace planecell;
  using namespace planecell::services;

  CLI::App app{
      "planecell — streaming stereo mapping with planes.\n"
      "Stereo frames in, a compact map of planar cells (planecells) out.\n\n"
      "Typical session:\n"
      "  planecell synth --out /tmp/street --frames 50     # make a synthetic KITTI-layout sequence\n"
      "  planecell info /tmp/street                        # what is in it\n"
      "Run `planecell <command> --help` for the options of each command.",
      "planecell"};
  app.set_version_flag("--version", "planecell 0.1.0");
  CommandContext context;
  app.add_option("--log-level", context.log_level,
                 "Logging verbosity: trace, debug, info, warn, error, critical, off")
      ->capture_default_str();
  app.add_option("-c,--config", context.config_path,
                 "YAML file overriding built-in defaults (see config/*.yaml, `planecell config`)")
      ->check(CLI::ExistingFile);
  app.require_subcommand(1, 1);
  app.fallthrough();

  add_config_command(app, context);
  add_disparity_command(app, context);
  add_eval_stereo_command(app, context);
  add_synth_command(app, context);
  add_import_euroc_command(app, context);
  add_info_command(app, context);
  add_extract_command(app, context);
  add_replay_command(app, context);
  add_export_command(app, context);
  add_run_command(app, context);
  add_feed_command(app, context);
  add_listen_command(app, context);
  add_bench_command(app, context);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    setup_logging(context.log_level);
    for (auto& [command, action] : context.actions)
      if (command->parsed()) return action(context);
    std::cerr << "planecell: no command given (see --help)\n";
    return kExitUsage;
  } catch (const ConfigError& e) {
    spdlog::error("configuration error: {}", e.what());
    return kExitUsage;
  } catch (const InputError& e) {
    spdlog::error("input error: {}", e.what());
    return kExitFailure;
  } catch (const StorageError& e) {
    spdlog::error("storage error: {}", e.what());
    return kExitStorage;
  } catch (const std::exception& e) {
    spdlog::error("failed: {}", e.what());
    return kExitFailure;
  }
}
