#pragma once
/// spdlog set-up for the CLI: one stderr logger, level from --log-level.
#include <string>

namespace planecell::services {

/// Sets the default logger to a coloured stderr sink at `level` (trace, debug, info, warn,
/// error, critical, off). Throws ConfigError on an unknown level name.
void setup_logging(const std::string& level);

}  // namespace planecell::services
