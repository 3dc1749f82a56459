#pragma once
/// What every CLI subcommand shares: global options, the loaded config, and how a command
/// registers the action that main() runs after parsing.
#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

#include "core/config/app_config.hpp"

namespace planecell::services {

/// Process exit codes of the `planecell` CLI.
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,      ///< bad input data (missing/corrupt file, bad calibration, ...)
  kExitUsage = 2,        ///< bad command line or configuration
  kExitStorage = 3,      ///< cannot write outputs (full disk, permissions)
  kExitInterrupted = 130 ///< stopped by SIGINT
};

struct CommandContext {
  std::string log_level = "info";
  std::string config_path;  ///< --config; empty = built-in defaults
  std::vector<std::pair<CLI::App*, std::function<int(const CommandContext&)>>> actions;

  /// Built-in defaults, overridden by --config when given.
  AppConfig load_app_config() const;
  /// Registers `action` to run when subcommand `command` is the one parsed.
  void add(CLI::App* command, std::function<int(const CommandContext&)> action) {
    actions.emplace_back(command, std::move(action));
  }
};

}  // namespace planecell::services
