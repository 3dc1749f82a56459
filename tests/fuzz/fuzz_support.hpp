#pragma once
/// Shared by the libFuzzer targets (tests/fuzz/fuzz_*.cpp): the fuzz input as a temporary file
/// for readers that only take paths, and the rule every target checks — only the documented
/// planecell errors may escape a reader; anything else (another exception, a crash, a sanitizer
/// report, a hang) is a finding.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <string_view>
#include <system_error>

#include "core/error.hpp"

namespace planecell::fuzz {

/// A per-process scratch folder under the system temp dir, removed when the process exits.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    auto p = std::filesystem::temp_directory_path() /
             ("planecell-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(p);
    return p;
  }();
  static struct Cleanup {
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } cleanup;
  return dir;
}

/// Writes `bytes` to scratch_dir()/name (truncating) and returns the path.
inline std::filesystem::path write_file(const std::string& name,
                                        std::span<const std::uint8_t> bytes) {
  const auto path = scratch_dir() / name;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path;
}

inline std::filesystem::path write_file(const std::string& name, std::string_view text) {
  return write_file(name, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

/// Runs `fn`; the documented errors (InputError, ConfigError, StorageError) are the expected
/// outcome of bad bytes and are swallowed. Any other exception propagates and aborts the fuzzer.
template <class Fn>
void expect_only_planecell_errors(Fn&& fn) {
  try {
    fn();
  } catch (const InputError&) {
  } catch (const ConfigError&) {
  } catch (const StorageError&) {
  }
}

}  // namespace planecell::fuzz
