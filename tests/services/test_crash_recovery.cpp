/// Crash recovery of the map store under `planecell replay`: the replay is SIGKILLed at 20
/// seeded random points (before the store opens, between frames, as the WAL grows i.e. inside a
/// commit); after every kill SQLite's integrity check passes, every frame committed before the
/// kill is still there, and the next replay resumes. The final map equals an uninterrupted run's.
/// Also: the replay on a nearly full disk (RLIMIT_FSIZE) fails with exit code 3 naming the store
/// and leaves the committed frames intact.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fcntl.h>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include "io/map_store.hpp"
#include "services/config_loader.hpp"
#include "support/expect_error.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int kFrames = 24;  // enough that 20 kills never see the whole sequence committed
constexpr int kKills = 20;

/// A small, fast pipeline configuration (also written as the --config file of the child).
/// Old cells are consolidated after 4 frames: the resumed runs must also pick up the
/// consolidation where the killed run left it.
const char* const kConfigYaml =
    "sgm:\n  max_disparity: 32\n  threads: 1\nextraction:\n  target_cells: 60\n"
    "map:\n  consolidate_after_frames: 4\n";

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A `planecell replay` child process; stdout+stderr go to `log`.
class Replay {
 public:
  /// `file_size_limit`: RLIMIT_FSIZE of the child (bytes), SIGXFSZ ignored so writes fail with
  /// EFBIG instead of killing it.
  Replay(const fs::path& seq, const fs::path& config, const fs::path& map, const fs::path& log,
         std::optional<rlim_t> file_size_limit = std::nullopt) {
    const std::string binary = test::planecell_binary();
    std::vector<std::string> args{binary,     "--log-level", "warn",         "--config",
                                  config.string(), "replay", seq.string(), "--map",
                                  map.string(), "--no-progress"};
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
      }
      if (file_size_limit) {
        ::signal(SIGXFSZ, SIG_IGN);
        const rlimit limit{*file_size_limit, *file_size_limit};
        ::setrlimit(RLIMIT_FSIZE, &limit);
      }
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(binary.c_str(), argv.data());
      ::_exit(127);
    }
  }
  ~Replay() {
    if (pid_ > 0 && !status_) {
      ::kill(pid_, SIGKILL);
      wait();
    }
  }
  Replay(const Replay&) = delete;
  Replay& operator=(const Replay&) = delete;

  bool started() const { return pid_ > 0; }
  /// True once the child has exited (reaps it).
  bool exited() {
    if (status_) return true;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) status_ = status;
    return status_.has_value();
  }
  void kill() {
    if (!exited()) ::kill(pid_, SIGKILL);
    wait();
  }
  int wait() {
    if (!status_) {
      int status = 0;
      ::waitpid(pid_, &status, 0);
      status_ = status;
    }
    return *status_;
  }
  /// Exit code, or −signal when killed.
  int exit_code() {
    const int s = wait();
    return WIFEXITED(s) ? WEXITSTATUS(s) : -WTERMSIG(s);
  }

 private:
  pid_t pid_ = -1;
  std::optional<int> status_;
};

/// Committed frames as a separate read-only connection sees them (0 when there is no store
/// yet); what a kill right after this call must not lose.
std::size_t committed_frames(const fs::path& map) {
  if (!fs::exists(map)) return 0;
  sqlite3* db = nullptr;
  std::size_t count = 0;
  if (sqlite3_open_v2(map.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_busy_timeout(db, 1000);
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db, "SELECT count(*) FROM frames", -1, &stmt, nullptr) == SQLITE_OK &&
        sqlite3_step(stmt) == SQLITE_ROW)
      count = static_cast<std::size_t>(sqlite3_column_int64(stmt, 0));
    sqlite3_finalize(stmt);
  }
  sqlite3_close(db);
  return count;
}

/// PRAGMA integrity_check of the store (after recovering its WAL) — "ok" when sound.
std::string integrity_check(const fs::path& map) {
  sqlite3* db = nullptr;
  std::string verdict;
  if (sqlite3_open_v2(map.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) == SQLITE_OK) {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db, "PRAGMA integrity_check", -1, &stmt, nullptr) == SQLITE_OK)
      while (sqlite3_step(stmt) == SQLITE_ROW)
        verdict += reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
    sqlite3_finalize(stmt);
  } else {
    verdict = std::string("cannot open: ") + sqlite3_errmsg(db);
  }
  sqlite3_close(db);
  return verdict;
}

std::uintmax_t file_size_or_zero(const fs::path& p) {
  std::error_code ec;
  const auto size = fs::file_size(p, ec);
  return ec ? 0 : size;
}

class CrashRecovery : public ::testing::Test {
 protected:
  void SetUp() override {
    test::write_small_street(seq_, kFrames, 3, 320, 96);
    std::ofstream(config_) << kConfigYaml;
    // The uninterrupted reference run, also timing a frame for the kill delays.
    const auto start = Clock::now();
    Replay reference(seq_, config_, scratch_ / "reference.db", scratch_ / "reference.log");
    ASSERT_EQ(reference.exit_code(), 0) << read_text(scratch_ / "reference.log");
    run_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
  map::GlobalMap load(const fs::path& map) const {
    const io::MapStore store(map);
    return io::load_map(store, load_config(config_).map);
  }
  test::ScratchDir scratch_;
  fs::path seq_ = scratch_ / "seq";
  fs::path config_ = scratch_ / "config.yaml";
  double run_ms_ = 0.0;
};

TEST_F(CrashRecovery, TwentyKillsLoseNoCommittedFrameAndTheMapEqualsAnUninterruptedRun) {
  const fs::path map = scratch_ / "crash.db";
  const fs::path wal = map.string() + "-wal";
  const fs::path log = scratch_ / "crash.log";
  const double frame_ms = run_ms_ / kFrames;
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int kills = 0, early = 0, between = 0, in_commit = 0;
  std::size_t before = 0;  // frames committed before this run
  for (int k = 0; k < kKills; ++k) {
    Replay replay(seq_, config_, map, log);
    ASSERT_TRUE(replay.started());
    const auto spawned = Clock::now();
    const auto elapsed_ms = [&] {
      return std::chrono::duration<double, std::milli>(Clock::now() - spawned).count();
    };
    const std::uintmax_t wal_at_spawn = file_size_or_zero(wal);
    // Kill kinds: 0 = a random time after spawn (start-up, opening the store, first frame),
    // 1 = a random time after this run's first new commit (between frames or inside one),
    // 2 = as soon as the WAL grows (a transaction being written).
    const int kind = k % 3;
    const double delay_ms = unit(rng) * (kind == 0 ? 2.0 * frame_ms : frame_ms);
    std::size_t committed = before;
    bool killed = false;
    std::optional<double> trigger_ms;
    while (!replay.exited() && elapsed_ms() < 60000.0) {
      committed = committed_frames(map);
      if (kind == 0) trigger_ms = 0.0;
      else if (kind == 1 && !trigger_ms && committed > before) trigger_ms = elapsed_ms();
      else if (kind == 2 && file_size_or_zero(wal) != wal_at_spawn) {
        committed = committed_frames(map);
        replay.kill();
        killed = true;
        break;
      }
      if (trigger_ms && elapsed_ms() >= *trigger_ms + delay_ms) {
        committed = committed_frames(map);  // read just before the kill
        replay.kill();
        killed = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(300));
    }
    if (!killed) {
      // Finished before the kill point (all frames in): it must have exited cleanly.
      ASSERT_EQ(replay.exit_code(), 0) << read_text(log);
      committed = committed_frames(map);
    } else {
      ++kills;
      (kind == 0 ? early : kind == 1 ? between : in_commit)++;
    }
    SCOPED_TRACE("kill " + std::to_string(k) + " kind " + std::to_string(kind));
    if (fs::exists(map)) {
      EXPECT_EQ(integrity_check(map), "ok");
      const io::MapStore store(map);  // reopens (recovers the WAL), never refuses its own file
      const auto ids = store.frame_ids();
      EXPECT_GE(ids.size(), committed) << "a committed frame was lost";
      for (std::size_t i = 0; i < ids.size(); ++i) EXPECT_EQ(ids[i], i);  // resumes in order
      before = ids.size();
    } else {
      EXPECT_EQ(committed, 0u);
    }
  }
  EXPECT_EQ(kills, kKills) << "runs finished before their kill point; the sequence is too short";
  EXPECT_GT(early + between + in_commit, 0);
  // The last run completes the map; it must equal the uninterrupted one.
  Replay final_run(seq_, config_, map, log);
  ASSERT_EQ(final_run.exit_code(), 0) << read_text(log);
  EXPECT_EQ(integrity_check(map), "ok");
  EXPECT_EQ(io::MapStore(map).frame_count(), static_cast<std::size_t>(kFrames));
  EXPECT_TRUE(load(map).same_content(load(scratch_ / "reference.db")));
}

TEST_F(CrashRecovery, NearlyFullDiskFailsWithExitCode3AndKeepsCommittedFrames) {
  const fs::path map = scratch_ / "full.db";
  const fs::path log = scratch_ / "full.log";
  // Two frames committed normally.
  {
    Replay first(seq_, config_, map, log);
    // Kill it once two frames are in (the replay resumes anyway).
    const auto start = Clock::now();
    while (!first.exited() && committed_frames(map) < 2 &&
           Clock::now() - start < std::chrono::seconds(60))
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    first.kill();
  }
  const std::size_t committed = io::MapStore(map).frame_count();  // also checkpoints the WAL
  ASSERT_GE(committed, 2u);
  ASSERT_LT(committed, static_cast<std::size_t>(kFrames));
  const auto size = fs::file_size(map);
  // Files may grow 4 KiB beyond the store's current size: the next frames cannot all fit.
  Replay limited(seq_, config_, map, log, static_cast<rlim_t>(size + 4096));
  EXPECT_EQ(limited.exit_code(), 3) << read_text(log);
  const std::string message = read_text(log);
  EXPECT_CONTAINS(message, map.string());
  EXPECT_EQ(integrity_check(map), "ok");
  const io::MapStore store(map);
  EXPECT_GE(store.frame_count(), committed);
  const auto ids = store.frame_ids();
  for (std::size_t i = 0; i < ids.size(); ++i) EXPECT_EQ(ids[i], i);
  // With space again the replay completes the same map as an uninterrupted run.
  Replay rest(seq_, config_, map, log);
  ASSERT_EQ(rest.exit_code(), 0) << read_text(log);
  EXPECT_TRUE(load(map).same_content(load(scratch_ / "reference.db")));
}

}  // namespace
}  // namespace planecell::services
