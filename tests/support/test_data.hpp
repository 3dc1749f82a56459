#pragma once
/// Helpers shared by the tests: where the optional real data set lives, scratch directories.
#include <filesystem>
#include <optional>
#include <string>

namespace planecell::test {

/// Root of the optional real stereo data: $PLANECELL_DATA if set, else ../shared/data beside the
/// source tree. Empty when absent, so tests can GTEST_SKIP() cleanly.
std::optional<std::filesystem::path> shared_data_root();

/// Path of a sub-folder of the shared data (e.g. "middlebury/teddy"), or nullopt when absent.
std::optional<std::filesystem::path> shared_data(const std::string& relative);

/// A fresh, empty scratch directory unique to the calling test; removed when the object dies.
class ScratchDir {
 public:
  ScratchDir();
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

/// Path of the built `planecell` executable (for end-to-end CLI tests).
std::string planecell_binary();

/// Runs a shell command, returns its exit code; stdout+stderr are captured into `output`.
int run_command(const std::string& command, std::string* output = nullptr);

}  // namespace planecell::test
