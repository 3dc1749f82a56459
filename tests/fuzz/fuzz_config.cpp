/// libFuzzer target: YAML configuration text → services::apply_config_yaml over the defaults,
/// then printed back (config_to_yaml) and re-applied, which must succeed.
#include <string>

#include "fuzz_support.hpp"
#include "services/config_loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  const std::string text(reinterpret_cast<const char*>(data), size);
  AppConfig config;
  bool applied = false;
  fuzz::expect_only_planecell_errors([&] {
    services::apply_config_yaml(text, "fuzz input", config);
    applied = true;
  });
  if (applied) {
    // Whatever was accepted must print as YAML that loads again without error.
    AppConfig again;
    services::apply_config_yaml(services::config_to_yaml(config), "round trip", again);
  }
  return 0;
}
