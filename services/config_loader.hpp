#pragma once
/// YAML → AppConfig. A file holds one top-level section per stage (sgm, extraction, map, voxel,
/// synth); keys absent from the file keep their built-in defaults.
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "core/config/app_config.hpp"

namespace planecell::services {

/// Loads `path` over the defaults. Throws ConfigError naming the file and key on an unknown
/// section or key, or a value of the wrong type.
AppConfig load_config(const std::filesystem::path& path);

/// Applies YAML text over `config` (same rules; `source` names it in errors).
void apply_config_yaml(const std::string& yaml_text, const std::string& source, AppConfig& config);

/// The configuration as YAML (every key with its current value) of the sections named in
/// `sections`, every section when it is empty.
std::string config_to_yaml(const AppConfig& config, std::span<const std::string_view> sections = {});

}  // namespace planecell::services
