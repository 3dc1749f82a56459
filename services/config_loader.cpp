#include "services/config_loader.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <fstream>
#include <set>
#include <sstream>
#include <type_traits>

#include "core/error.hpp"

namespace planecell::services {
namespace {

/// The text of a mapping key; ConfigError when it is not a plain scalar (e.g. `[a]: 1`).
std::string key_text(const YAML::Node& key, const std::string& where) {
  if (!key.IsScalar())
    throw ConfigError(where + ": a key must be a plain name, got '" + YAML::Dump(key) + "'");
  return key.Scalar();
}

/// Rejects unknown and repeated keys (YAML would silently keep the first of two).
void check_keys(const YAML::Node& node, const std::string& where,
                const std::set<std::string>& known, const char* what) {
  std::set<std::string> seen;
  for (const auto& entry : node) {
    const auto key = key_text(entry.first, where);
    if (!known.contains(key)) throw ConfigError(where + ": unknown " + what + " '" + key + "'");
    if (!seen.insert(key).second)
      throw ConfigError(where + ": " + what + " '" + key + "' appears twice");
  }
}

/// Reads every known key of one section from `node`; rejects unknown keys.
template <class Section>
void read_section(const YAML::Node& node, const std::string& where, Section& section) {
  if (!node.IsMap()) throw ConfigError(where + ": expected a mapping of key: value");
  std::set<std::string> known;
  visit_fields(section, [&](const char* key, auto&) { known.insert(key); });
  check_keys(node, where, known, "key");
  visit_fields(section, [&](const char* key, auto& field) {
    const YAML::Node value = node[key];
    if (!value) return;
    using T = std::decay_t<decltype(field)>;
    try {
      field = value.as<T>();
    } catch (const YAML::Exception&) {
      throw ConfigError(where + "." + key + ": value '" + YAML::Dump(value) +
                        "' has the wrong type");
    }
  });
}

void apply_root(const YAML::Node& root, const std::string& source, AppConfig& config) {
  if (!root || root.IsNull()) return;  // empty file: defaults
  if (!root.IsMap()) throw ConfigError(source + ": expected sections (sgm:, extraction:, ...)");
  std::set<std::string> known;
  visit_sections(config, [&](const char* name, auto&) { known.insert(name); });
  check_keys(root, source, known, "section");
  visit_sections(config, [&](const char* name, auto& section) {
    if (root[name]) read_section(root[name], source + ": " + name, section);
  });
}

}  // namespace

void apply_config_yaml(const std::string& yaml_text, const std::string& source, AppConfig& config) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(source + ": not valid YAML (" + e.what() + ")");
  }
  apply_root(root, source, config);
}

AppConfig load_config(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError("config '" + path.string() + "': file not found or unreadable");
  std::stringstream text;
  text << in.rdbuf();
  AppConfig config;
  apply_config_yaml(text.str(), "config '" + path.string() + "'", config);
  return config;
}

std::string config_to_yaml(const AppConfig& config_in, std::span<const std::string_view> sections) {
  AppConfig config = config_in;
  YAML::Emitter out;
  out << YAML::BeginMap;
  visit_sections(config, [&](const char* name, auto& section) {
    if (!sections.empty() && std::find(sections.begin(), sections.end(), name) == sections.end()) return;
    out << YAML::Key << name << YAML::Value << YAML::BeginMap;
    visit_fields(section, [&](const char* key, auto& field) {
      out << YAML::Key << key << YAML::Value;
      if constexpr (std::is_same_v<std::decay_t<decltype(field)>, double>) {
        // Shortest text that reads back as the same double: 0.3, not 0.29999999999999999.
        char text[32];
        const auto end = std::to_chars(text, text + sizeof text, field).ptr;
        out << std::string(text, end);
      } else {
        out << field;
      }
    });
    out << YAML::EndMap;
  });
  out << YAML::EndMap;
  return out.c_str();
}

}  // namespace planecell::services
