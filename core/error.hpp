#pragma once
/// Error types. Errors are exceptions whose message names the input and what is wrong; they are
/// caught at command and stage boundaries (see services/).
#include <stdexcept>
#include <string>

namespace planecell {

/// Bad input data: a missing/corrupt file, a size mismatch, a malformed calibration or pose.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A configuration value outside its valid range (from YAML, the CLI or code).
struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A resource failure while writing (full disk, unwritable path, corrupt store).
struct StorageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace planecell
