/// `planecell config` — prints the effective configuration (defaults overridden by --config).
#include <iostream>

#include "services/commands/commands.hpp"
#include "services/config_loader.hpp"

namespace planecell::services {

void add_config_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand(
      "config", "Print the effective configuration as YAML (defaults, overridden by --config).\n"
                "Use it as a template: planecell config > my.yaml");
  context.add(command, [](const CommandContext& ctx) {
    std::cout << config_to_yaml(ctx.load_app_config()) << "\n";
    return kExitOk;
  });
}

}  // namespace planecell::services
