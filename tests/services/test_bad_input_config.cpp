/// Bad configuration text: keys that are not plain names (found writing fuzz_config: they escaped
/// as YAML::TypedBadConversion instead of ConfigError), repeated keys (YAML kept the first silently),
/// huge and non-finite values, and resource limits refused by the stage that owns them.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.hpp"
#include "services/config_loader.hpp"
#include "support/expect_error.hpp"

namespace planecell::services {
namespace {

std::string config_error_of(const std::string& yaml) {
  AppConfig config;
  try {
    apply_config_yaml(yaml, "bad.yaml", config);
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << yaml;
  return {};
}

TEST(BadConfigInput, NonScalarKeysAreConfigErrorsNamingTheSource) {
  // A flow-sequence key at the root, inside a section, a complex key, a null key.
  EXPECT_CONTAINS(config_error_of("[a]: 1\n"), "bad.yaml: a key must be a plain name");
  EXPECT_CONTAINS(config_error_of("sgm: {[x]: 1}\n"), "bad.yaml: sgm: a key must be a plain name");
  EXPECT_CONTAINS(config_error_of("? {a: b}\n: c\n"), "a key must be a plain name");
  EXPECT_CONTAINS(config_error_of("sgm: {~: 1}\n"), "a key must be a plain name, got '~'");
}

TEST(BadConfigInput, RepeatedKeysAndSectionsAreRejected) {
  EXPECT_CONTAINS(config_error_of("sgm:\n  max_disparity: 64\n  max_disparity: 96\n"),
                  "bad.yaml: sgm: key 'max_disparity' appears twice");
  EXPECT_CONTAINS(config_error_of("map:\n  max_range_m: 5\nmap:\n  max_range_m: 6\n"),
                  "bad.yaml: section 'map' appears twice");
}

TEST(BadConfigInput, HugeIntegersAreWrongTypeNotWrappedAround) {
  EXPECT_CONTAINS(config_error_of("sgm:\n  max_disparity: 99999999999\n"),
                  "sgm.max_disparity: value '99999999999' has the wrong type");
}

TEST(BadConfigInput, NonFiniteValuesLoadButTheLimitsRefuseThem) {
  // YAML's .nan/.inf are valid doubles; the owner of the value validates it (here the SGM limits,
  // see tests/mapping/test_bad_input_sgm.cpp). The loader keeps them verbatim.
  AppConfig config;
  apply_config_yaml("sgm:\n  max_cost_volume_mb: .nan\n  max_image_pixels: .inf\n", "nan.yaml", config);
  EXPECT_TRUE(std::isnan(config.sgm.max_cost_volume_mb));
  EXPECT_TRUE(std::isinf(config.sgm.max_image_pixels));
}

TEST(BadConfigInput, LimitKeysAreLoadedAndPrinted) {
  AppConfig config;
  apply_config_yaml("sgm:\n  max_disparity_limit: 256\n  max_image_pixels: 2e6\n  max_cost_volume_mb: 512\n",
                    "limits.yaml", config);
  EXPECT_EQ(config.sgm.max_disparity_limit, 256);
  EXPECT_EQ(config.sgm.max_image_pixels, 2e6);
  EXPECT_EQ(config.sgm.max_cost_volume_mb, 512.0);
  const std::string yaml = config_to_yaml(config);
  EXPECT_CONTAINS(yaml, "max_disparity_limit: 256");
  EXPECT_CONTAINS(yaml, "max_cost_volume_mb: 512");
}

}  // namespace
}  // namespace planecell::services
