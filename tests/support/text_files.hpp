#pragma once
/// Whole-file text helpers for tests that write inputs and read outputs.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace planecell::test {

/// Writes `text` to `path` byte for byte, creating the parent directories.
inline void write_text(const std::filesystem::path& path, const std::string& text) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

/// The whole content of `path` ("" when it cannot be read).
inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace planecell::test
