#include "support/test_data.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sys/wait.h>

namespace planecell::test {

std::optional<std::filesystem::path> shared_data_root() {
  if (const char* env = std::getenv("PLANECELL_DATA"); env != nullptr && *env != '\0') {
    if (std::filesystem::is_directory(env)) return std::filesystem::path(env);
    return std::nullopt;
  }
  const std::filesystem::path fallback(PLANECELL_DEFAULT_DATA_DIR);
  if (std::filesystem::is_directory(fallback)) return fallback;
  return std::nullopt;
}

std::optional<std::filesystem::path> shared_data(const std::string& relative) {
  auto root = shared_data_root();
  if (!root) return std::nullopt;
  auto path = *root / relative;
  if (!std::filesystem::exists(path)) return std::nullopt;
  return path;
}

ScratchDir::ScratchDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "_" + info->name() : "scratch";
  for (char& c : name)
    if (c == '/') c = '_';
  std::random_device rd;
  path_ = std::filesystem::temp_directory_path() /
          ("planecell_test_" + name + "_" + std::to_string(rd()));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string planecell_binary() { return PLANECELL_BINARY; }

int run_command(const std::string& command, std::string* output) {
  std::string full = command + " 2>&1";
  FILE* pipe = ::popen(full.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer{};
  std::string captured;
  while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe) != nullptr)
    captured += buffer.data();
  const int status = ::pclose(pipe);
  if (output != nullptr) *output = captured;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return -1;
}

}  // namespace planecell::test
