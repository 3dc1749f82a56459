#pragma once
/// Non-throwing file-system checks shared by the dataset readers and the CLI.
#include <cctype>
#include <filesystem>
#include <string>

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

/// The extension of `path` with its dot, lower-cased ("IMG.PNG" → ".png"; "" when it has none).
inline std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace planecell::io
