#pragma once
/// Every `planecell` subcommand registers itself through one of these functions (main.cpp).
#include "services/command.hpp"

namespace planecell::services {

void add_config_command(CLI::App& app, CommandContext& context);

}  // namespace planecell::services
