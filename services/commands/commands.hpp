#pragma once
/// Every `planecell` subcommand registers itself through one of these functions (main.cpp).
#include "services/command.hpp"

namespace planecell::services {

void add_config_command(CLI::App& app, CommandContext& context);
void add_replay_command(CLI::App& app, CommandContext& context);
void add_export_command(CLI::App& app, CommandContext& context);
void add_disparity_command(CLI::App& app, CommandContext& context);
void add_eval_stereo_command(CLI::App& app, CommandContext& context);
void add_synth_command(CLI::App& app, CommandContext& context);
void add_import_euroc_command(CLI::App& app, CommandContext& context);
void add_info_command(CLI::App& app, CommandContext& context);
void add_extract_command(CLI::App& app, CommandContext& context);
void add_run_command(CLI::App& app, CommandContext& context);
void add_feed_command(CLI::App& app, CommandContext& context);
void add_listen_command(CLI::App& app, CommandContext& context);
void add_bench_command(CLI::App& app, CommandContext& context);

}  // namespace planecell::services
