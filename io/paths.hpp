#pragma once
/// Non-throwing file-system checks shared by the dataset readers and the CLI.
#include <filesystem>

namespace planecell::io {

/// True when `path` is a regular file (false on any file-system error).
inline bool is_file(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}

/// True when `path` is a directory (false on any file-system error).
inline bool is_dir(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec);
}

}  // namespace planecell::io
