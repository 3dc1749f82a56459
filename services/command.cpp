#include "services/command.hpp"

#include "services/config_loader.hpp"

namespace planecell::services {

AppConfig CommandContext::load_app_config() const {
  if (config_path.empty()) return AppConfig{};
  return load_config(config_path);
}

}  // namespace planecell::services
