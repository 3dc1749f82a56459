/// The daemon over real LCM, in separate processes: `planecell run` + `feed` + `listen` on a small
/// synthetic sequence. The listener's mirror equals the daemon's map; malformed and out-of-order
/// messages are counted and skipped; SIGTERM mid-stream leaves a map store that reopens. Each test
/// has its own multicast port (ttl=0: nothing leaves the machine). Skips when multicast is unusable.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <thread>

#include "io/kitti_odometry.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "io/map_store.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"
#include "support/text_files.hpp"

namespace planecell::services {
namespace {

using test::read_text;

using namespace std::chrono_literals;

std::string lcm_url(int port) {
  return "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0&recv_buf_size=4194304";
}

/// True when a message published on `url` comes back to this process (multicast route present).
bool multicast_works(const std::string& url) {
  lcm::LCM lcm(url);
  if (!lcm.good()) return false;
  struct Probe {
    bool got = false;
    void on(const lcm::ReceiveBuffer*, const std::string&) { got = true; }
  } probe;
  lcm.subscribe("PLANECELL_PROBE", &Probe::on, &probe);
  const std::uint8_t byte = 1;
  for (int attempt = 0; attempt < 5 && !probe.got; ++attempt) {
    lcm.publish("PLANECELL_PROBE", &byte, 1);
    lcm.handleTimeout(200);
  }
  return probe.got;
}

/// A `planecell` child process with stdout+stderr in a log file.
class Child {
 public:
  Child(const std::vector<std::string>& args, std::filesystem::path log) : log_(std::move(log)) {
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      std::vector<char*> argv;
      static std::string binary = test::planecell_binary();
      argv.push_back(binary.data());
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(binary.c_str(), argv.data());
      ::_exit(127);
    }
  }
  ~Child() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  /// Waits until the log contains `text` (true) or `timeout` passes (false).
  bool wait_for_log(const std::string& text, std::chrono::seconds timeout) const {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      if (log().find(text) != std::string::npos) return true;
      std::this_thread::sleep_for(50ms);
    }
    return false;
  }
  void signal(int number) const { ::kill(pid_, number); }
  /// Exit code, or -1 when it did not exit within `timeout` (then it is killed).
  int wait(std::chrono::seconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    int status = 0;
    while (std::chrono::steady_clock::now() < end) {
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(50ms);
    }
    return -1;
  }
  std::string log() const { return read_text(log_); }

 private:
  std::filesystem::path log_;
  pid_t pid_ = -1;
  bool exited_ = false;
};

class LcmEndToEndTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::write_small_street(scratch_ / "seq", 6, 11);
    std::ofstream(scratch_ / "config.yaml") << "sgm:\n  max_disparity: 48\n"
                                               "extraction:\n  target_cells: 150\n"
                                               "pipeline:\n  queue_capacity: 8\n  stats_period_s: 0.5\n"
                                               "  warm_up_width: 414\n  warm_up_height: 125\n";
  }
  std::vector<std::string> with_config(std::vector<std::string> args) const {
    args.insert(args.begin(), {"--config", (scratch_ / "config.yaml").string()});
    return args;
  }
  test::ScratchDir scratch_;
};

#define SKIP_WITHOUT_MULTICAST(url)                                                                  \
  if (!multicast_works(url))                                                                         \
  GTEST_SKIP() << "LCM multicast is not usable here (no route for 224.0.0.0/4 on loopback; run "    \
                  "scripts/lcm-route.sh as root)"

TEST_F(LcmEndToEndTest, ListenersMirrorEqualsTheDaemonsMap) {
  const std::string url = lcm_url(7711);
  SKIP_WITHOUT_MULTICAST(url);
  Child daemon(with_config({"run", "--lcm", url, "--map", (scratch_ / "daemon.db").string()}), scratch_ / "run.log");
  ASSERT_TRUE(daemon.wait_for_log("listening", 20s)) << daemon.log();
  Child listener(with_config({"listen", "--lcm", url, "--timeout", "4", "--mirror", (scratch_ / "mirror.db").string(),
                              "--query", "0,1,8"}),
                 scratch_ / "listen.log");
  ASSERT_TRUE(listener.wait_for_log("subscribed", 20s)) << listener.log();
  std::string feed_output;
  ASSERT_EQ(test::run_command(test::planecell_binary() + " feed " + (scratch_ / "seq").string() + " --rate 4 --lcm '" +
                                  url + "'",
                              &feed_output),
            0)
      << feed_output;
  std::this_thread::sleep_for(1s);
  daemon.signal(SIGTERM);  // drains: every frame fed is mapped and published before it exits
  ASSERT_EQ(daemon.wait(120s), 0) << daemon.log();
  ASSERT_EQ(listener.wait(60s), 0) << listener.log();
  EXPECT_NE(listener.log().find("0 messages rejected"), std::string::npos) << listener.log();
  EXPECT_NE(listener.log().find("clearance"), std::string::npos) << listener.log();

  const io::MapStore daemon_store(scratch_ / "daemon.db");
  EXPECT_GE(daemon_store.frame_count(), 1u);
  const auto daemon_map = io::load_map(daemon_store);
  const auto mirror_map = io::load_map(io::MapStore(scratch_ / "mirror.db"));
  ASSERT_GT(daemon_map.cells().size(), 0u);
  ASSERT_EQ(mirror_map.cells().size(), daemon_map.cells().size());
  EXPECT_EQ(mirror_map.next_cell_id(), daemon_map.next_cell_id());
  std::set<std::uint32_t> daemon_labels, mirror_labels;
  for (const auto& [id, cell] : daemon_map.cells()) {
    const map::MapCell* m = mirror_map.cell(id);
    ASSERT_NE(m, nullptr) << "cell " << id;
    EXPECT_EQ(m->surface, cell.surface) << "cell " << id;
    EXPECT_EQ(m->plane.normal(), cell.plane.normal()) << "cell " << id;
    EXPECT_EQ(m->plane.offset(), cell.plane.offset()) << "cell " << id;
    EXPECT_EQ(m->vertices_m, cell.vertices_m) << "cell " << id;
    EXPECT_EQ(m->frame_id, cell.frame_id) << "cell " << id;
    daemon_labels.insert(cell.surface);
    mirror_labels.insert(m->surface);
  }
  EXPECT_EQ(mirror_labels, daemon_labels);
  EXPECT_EQ(mirror_map.surfaces().size(), daemon_map.surfaces().size());
  // Clearance answers come from the cells alone: the same on both maps.
  const Eigen::Vector3d probe(0.0, 1.0, 8.0);
  const auto a = daemon_map.nearest_cell(probe, 50.0), b = mirror_map.nearest_cell(probe, 50.0);
  ASSERT_EQ(a.has_value(), b.has_value());
  if (a) {
    EXPECT_EQ(a->distance_m, b->distance_m);
  }
}

TEST_F(LcmEndToEndTest, MalformedAndOutOfOrderMessagesAreCountedAndSkipped) {
  const std::string url = lcm_url(7712);
  SKIP_WITHOUT_MULTICAST(url);
  Child daemon(with_config({"run", "--lcm", url, "--map", (scratch_ / "daemon.db").string()}), scratch_ / "run.log");
  ASSERT_TRUE(daemon.wait_for_log("listening", 20s)) << daemon.log();

  lcm::LCM lcm(url);
  ASSERT_TRUE(lcm.good());
  const auto sequence = io::open_kitti_odometry(scratch_ / "seq");
  auto send = [&](const std::string& channel, const std::vector<std::uint8_t>& bytes) {
    ASSERT_EQ(lcm.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size())), 0);
    std::this_thread::sleep_for(100ms);
  };
  auto send_frame = [&](std::size_t index) {
    StereoFrame frame = io::load_kitti_frame(sequence, index);
    frame.frame_id = index;
    send("PLANECELL_POSE", io::encode_bytes(io::to_lcm(index, *frame.pose, 0)));
    send("PLANECELL_STEREO", io::encode_bytes(io::to_lcm(frame, io::ImageEncoding::kPng, 0)));
  };
  send("PLANECELL_STEREO", std::vector<std::uint8_t>(500, 0x5A));  // 1: garbage
  auto bad_pose = io::to_lcm(2, Pose::Identity(), 0);
  bad_pose.T_world_cam[0] = std::numeric_limits<double>::quiet_NaN();
  send("PLANECELL_POSE", io::encode_bytes(bad_pose));  // 2: NaN pose
  send_frame(3);
  send_frame(1);  // 3 + 4: pose and images of a frame older than one already mapped
  std::this_thread::sleep_for(1s);
  daemon.signal(SIGTERM);
  ASSERT_EQ(daemon.wait(120s), 0) << daemon.log();
  EXPECT_NE(daemon.log().find("run: 1 frames mapped"), std::string::npos) << daemon.log();
  EXPECT_NE(daemon.log().find("4 messages rejected"), std::string::npos) << daemon.log();
  const io::MapStore store(scratch_ / "daemon.db");
  EXPECT_EQ(store.frame_ids(), std::vector<std::uint64_t>{3});
}

TEST_F(LcmEndToEndTest, SigtermMidStreamLeavesAMapThatReopens) {
  const std::string url = lcm_url(7713);
  SKIP_WITHOUT_MULTICAST(url);
  Child daemon(with_config({"run", "--lcm", url, "--map", (scratch_ / "daemon.db").string()}), scratch_ / "run.log");
  ASSERT_TRUE(daemon.wait_for_log("listening", 20s)) << daemon.log();
  Child feed({"feed", (scratch_ / "seq").string(), "--rate", "1", "--lcm", url}, scratch_ / "feed.log");
  std::this_thread::sleep_for(1500ms);  // 2 of the 6 frames sent
  daemon.signal(SIGTERM);
  ASSERT_EQ(daemon.wait(120s), 0) << daemon.log();
  feed.signal(SIGTERM);
  const int feed_exit = feed.wait(30s);
  EXPECT_TRUE(feed_exit == 130 || feed_exit == 0) << feed.log();  // interrupted (or just done)
  const io::MapStore store(scratch_ / "daemon.db");
  EXPECT_LT(store.frame_count(), 6u);
  const auto map = io::load_map(store);  // reopens and rebuilds
  if (store.frame_count() > 0) {
    EXPECT_GT(map.cells().size(), 0u);
  }
}

}  // namespace
}  // namespace planecell::services
