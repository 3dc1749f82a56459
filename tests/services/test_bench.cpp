/// `planecell bench` end to end on a 3-frame small street: the report's fields against the
/// sequence's own ground truth, the figures, the markdown's "regenerate" lines, the threaded run,
/// the CLI, and `eval-stereo --report-md`.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "io/map_store.hpp"
#include "services/bench/run_bench.hpp"
#include "services/eval/stereo_markdown.hpp"
#include "services/report/markdown.hpp"
#include "support/expect_error.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"
#include "support/text_files.hpp"

namespace planecell::services::bench {
namespace {

using test::read_text;

namespace fs = std::filesystem;

/// GT pixels (GT disparity > 0) of the sequence's frames, read from disp_occ_0/ directly.
long gt_pixels_of(const fs::path& sequence, int frames) {
  long count = 0;
  for (int i = 0; i < frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", i);
    const cv::Mat gt = io::read_kitti_disparity(sequence / "disp_occ_0" / name);
    for (int v = 0; v < gt.rows; ++v)
      for (int u = 0; u < gt.cols; ++u) count += gt.at<float>(v, u) > 0.0f;
  }
  return count;
}

class BenchTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scratch_ = new test::ScratchDir();
    test::write_small_street(*scratch_ / "seq", 3, 11);
    BenchOptions options;
    options.sequence_dir = *scratch_ / "seq";
    options.out_dir = *scratch_ / "report";
    options.progress = false;
    report_ = new BenchReport(run_bench(options, test::small_street_config()));
    json_ =
        new nlohmann::json(nlohmann::json::parse(read_text(*scratch_ / "report" / "report.json")));
  }
  static void TearDownTestSuite() {
    delete json_;
    delete report_;
    delete scratch_;
  }
  static test::ScratchDir* scratch_;
  static BenchReport* report_;
  static nlohmann::json* json_;
};
test::ScratchDir* BenchTest::scratch_ = nullptr;
BenchReport* BenchTest::report_ = nullptr;
nlohmann::json* BenchTest::json_ = nullptr;

TEST_F(BenchTest, ReportJsonHoldsEveryRepresentationOnTheSameGroundTruth) {
  const auto& j = *json_;
  EXPECT_EQ(j["frames"]["count"], 3);
  EXPECT_EQ(j["accuracy"]["frames_scored"], 3);
  const long gt_pixels = gt_pixels_of(*scratch_ / "seq", 3);
  ASSERT_GT(gt_pixels, 0);
  for (const char* name : {"planecell", "points", "voxel"}) {
    const auto& r = j["accuracy"]["representations"][name];
    ASSERT_TRUE(r.is_object()) << name;
    EXPECT_EQ(r["gt_pixels"].get<long>(), gt_pixels)
        << name;  // every GT pixel, every representation
    EXPECT_EQ(r["curve"]["threshold_m"].size(), 101u) << name;
    EXPECT_DOUBLE_EQ(r["curve"]["threshold_m"].back().get<double>(), 1.0);
    const auto& within = r["curve"]["within_pct"];
    for (std::size_t k = 1; k < within.size(); ++k)
      EXPECT_GE(within[k].get<double>(), within[k - 1].get<double>()) << name << " is cumulative";
    EXPECT_LE(within.back().get<double>(), r["density_pct"].get<double>() + 1e-9) << name;
    for (const char* key :
         {"within_10cm_pct", "within_20cm_pct", "within_50cm_pct", "within_100cm_pct"})
      EXPECT_TRUE(r[key].is_number()) << name << " " << key;
    // The pooled figures are the sum of the per-frame ones.
    long per_frame_gt = 0;
    for (const auto& f : j["accuracy"]["per_frame"])
      per_frame_gt += f[name]["gt_pixels"].get<long>();
    EXPECT_EQ(per_frame_gt, gt_pixels) << name;
  }
  const auto& reps = j["accuracy"]["representations"];
  // Planes fill SGM's holes: planecell reaches at least the point map at 1 m.
  EXPECT_GE(reps["planecell"]["within_100cm_pct"].get<double>(),
            reps["points"]["within_100cm_pct"].get<double>());
  // The voxel map holds a subset of the same SGM points (those within range).
  EXPECT_LE(reps["voxel"]["density_pct"].get<double>(),
            reps["points"]["density_pct"].get<double>());
  EXPECT_GT(reps["voxel"]["density_pct"].get<double>(), 0.0);
}

TEST_F(BenchTest, MemoryGrowsWithFramesAndCountsFifteenBytesPerPoint) {
  const auto& samples = (*json_)["memory"]["samples"];
  ASSERT_EQ(samples.size(), 3u);  // 3 frames, fewer than max_memory_samples: every frame
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto& m = samples[i];
    EXPECT_EQ(m["frames"].get<std::size_t>(), i + 1);
    EXPECT_EQ(m["point_bytes"].get<std::size_t>(), m["points"].get<std::size_t>() * 15);
    EXPECT_GT(m["planecell_ram_bytes"].get<std::size_t>(), 0u);
    EXPECT_GT(m["octomap_ram_bytes"].get<std::size_t>(), 0u);
    EXPECT_GT(m["octomap_bt_bytes"].get<std::size_t>(), 0u);
    if (i > 0) {
      EXPECT_GT(m["points"].get<std::size_t>(), samples[i - 1]["points"].get<std::size_t>());
      EXPECT_GE(m["voxels"].get<std::size_t>(), samples[i - 1]["voxels"].get<std::size_t>());
    }
  }
  // Point cloud size = valid SGM pixels; the points are at least as many as the GT pixels the
  // point representation scored as having a point.
  long with_point = 0;
  for (const auto& f : (*json_)["accuracy"]["per_frame"])
    with_point += f["points"]["with_point"].get<long>();
  EXPECT_GE(samples.back()["points"].get<long>(), with_point);
  // The final figures: the store after closing, and the map that the top views show.
  const auto& final_sample = (*json_)["memory"]["final"];
  EXPECT_EQ(final_sample["planecell_store_bytes"].get<std::size_t>(), report_->replay.store_bytes);
  EXPECT_EQ(report_->map_cells,
            io::load_map(io::MapStore(*scratch_ / "report" / "map.db")).cells().size());
  EXPECT_DOUBLE_EQ((*json_)["memory"]["bytes_per_frame"]["points"].get<double>(),
                   final_sample["point_bytes"].get<double>() / 3.0);
}

TEST_F(BenchTest, TimeHasEveryStageOncePerFrame) {
  const auto& time = (*json_)["time"];
  for (const char* stage : {"load", "sgm", "extract", "transform", "merge", "store"})
    EXPECT_EQ(time["stages"][stage]["count"], 3) << stage;
  for (const char* stage : {"points", "voxel", "scoring", "sampling"})
    EXPECT_EQ(time["bench_stages"][stage]["count"], 3) << stage;
  EXPECT_GT(time["peak_rss_bytes"].get<std::size_t>(), 0u);
  for (const char* name : {"planecell", "points", "voxel"})
    EXPECT_TRUE(time["estimated_single_thread_frames_per_s"][name].is_number()) << name;
}

TEST_F(BenchTest, FiguresExistWithTheirSizes) {
  const fs::path dir = *scratch_ / "report";
  const cv::Mat accuracy = io::read_image(dir / "accuracy.png");
  EXPECT_EQ(accuracy.size(), cv::Size(960, 600));
  const cv::Mat memory = io::read_image(dir / "memory.png");
  EXPECT_EQ(memory.size(), cv::Size(1100, 600));
  EXPECT_GE(io::read_image(dir / "latency.png").cols, 960);
  // The overlay is the frame itself, the size of the sequence's images.
  const cv::Mat overlay = io::read_image(dir / "overlay_000000.png");
  EXPECT_EQ(overlay.size(), cv::Size(414, 125));
  ASSERT_TRUE(report_->top_views);
  for (const char* name : {"map_top_height.png", "map_top_surfaces.png"}) {
    const cv::Mat view = io::read_image(dir / name);
    EXPECT_GT(view.cols, 200) << name;
    EXPECT_GT(view.rows, 200) << name;
  }
}

TEST_F(BenchTest, MarkdownEmbedsTheFiguresAndFollowsEveryTableWithItsCommand) {
  const std::string md = read_text(*scratch_ / "report" / "report.md");
  for (const char* figure : {"accuracy.png", "memory.png", "latency.png", "map_top_height.png",
                             "map_top_surfaces.png", "overlay_000000.png"})
    EXPECT_CONTAINS(md, std::string("](") + figure + ")");
  EXPECT_CONTAINS(md, report_->command);
  EXPECT_CONTAINS(report_->command, "planecell bench ");
  // After every table block and every image (or group of images), the next non-empty line is
  // the regenerate line.
  std::istringstream in(md);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  int blocks = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const bool table_end =
        lines[i].rfind("|", 0) == 0 && (i + 1 == lines.size() || lines[i + 1].rfind("|", 0) != 0);
    if (!table_end && lines[i].rfind("![", 0) != 0) continue;
    std::size_t next = i + 1;
    while (next < lines.size() && (lines[next].empty() || lines[next].rfind("![", 0) == 0)) ++next;
    ASSERT_LT(next, lines.size()) << "nothing after line " << i << ": " << lines[i];
    EXPECT_EQ(lines[next].rfind("_Regenerate:_ `" + report_->command + "`", 0), 0u)
        << "line " << i << " '" << lines[i] << "' is followed by '" << lines[next] << "'";
    ++blocks;
  }
  EXPECT_GE(blocks, 8);
}

TEST_F(BenchTest, MarkdownStatesThePapersFiguresNextToThisRun) {
  const std::string md = read_text(*scratch_ / "report" / "report.md");
  EXPECT_CONTAINS(md, "## Against the paper");
  EXPECT_CONTAINS(md, "200 ms for ~700 cells");
  EXPECT_CONTAINS(md, "| CRF merging per frame | 100 ms |");
  EXPECT_CONTAINS(md, "33.49 / 50.23 / 72.91 / 80.84 %");
  // This run's merge p50 and planecell accuracy, as in report.json.
  const auto& merge = (*json_)["time"]["stages"]["merge"];
  std::ostringstream p50;
  p50 << std::fixed << std::setprecision(1) << merge["p50_ms"].get<double>();
  EXPECT_CONTAINS(md, p50.str() + " ms p50 |");
  // The merge's GT breakdown by kind of surface, one row per kind of the rendered scene.
  EXPECT_CONTAINS(md, "| kind | GT surfaces | GT area % | in one label % | not in one label % |");
  EXPECT_CONTAINS(md, "| road |");
  // The scene's weakly textured surfaces (glass windows at least) get a row of their own.
  const auto& weak = (*json_)["replay"]["merge_vs_ground_truth"]["weak_texture"];
  ASSERT_GT(weak["gt_surfaces"].get<std::size_t>(), 0u);
  EXPECT_CONTAINS(md, "| *weakly textured (any kind, included above)* | " +
                          std::to_string(weak["gt_surfaces"].get<std::size_t>()) + " |");
}

TEST_F(BenchTest, ThreadedRunScoresTheSameFramesTheSame) {
  BenchOptions options;
  options.sequence_dir = *scratch_ / "seq";
  options.out_dir = *scratch_ / "threaded";
  options.progress = false;
  options.threads = true;
  const BenchReport threaded = run_bench(options, test::small_street_config());
  EXPECT_TRUE(threaded.threaded);
  ASSERT_EQ(threaded.frame_scores.size(), 3u);
  for (std::size_t k = 0; k < kRepresentations; ++k) {
    EXPECT_EQ(threaded.accuracy[k].gt_pixels(), report_->accuracy[k].gt_pixels())
        << representation_name(k);
    EXPECT_EQ(threaded.accuracy[k].with_point(), report_->accuracy[k].with_point())
        << representation_name(k);
    for (int i = 0; i <= threaded.accuracy[k].steps(); i += 10)
      EXPECT_EQ(threaded.accuracy[k].within(i), report_->accuracy[k].within(i))
          << representation_name(k);
  }
  EXPECT_EQ(threaded.memory.back().point_bytes, report_->memory.back().point_bytes);
  EXPECT_EQ(threaded.map_cells, report_->map_cells);
}

TEST_F(BenchTest, RejectsAnEmptyFrameRangeAndABadOverlayFrame) {
  BenchOptions options;
  options.sequence_dir = *scratch_ / "seq";
  options.out_dir = *scratch_ / "bad";
  options.progress = false;
  options.first_frame = 5;
  const std::string message =
      test::input_error_of([&] { run_bench(options, test::small_street_config()); });
  EXPECT_CONTAINS(message, "has 3 frames");
  options.first_frame = 0;
  options.overlay_frame = 7;
  EXPECT_THROW(run_bench(options, test::small_street_config()), ConfigError);
}

TEST_F(BenchTest, CommandLineRunsAndAppendsAnEvalStereoReport) {
  const fs::path dir = *scratch_ / "cli";
  fs::create_directories(dir);
  {
    std::ofstream yaml(dir / "small.yaml");
    yaml << "sgm:\n  max_disparity: 48\nextraction:\n  target_cells: 150\n";
  }
  const std::string bin = test::planecell_binary();
  const std::string seq = (*scratch_ / "seq").string();
  std::string output;
  ASSERT_EQ(test::run_command(bin + " --config " + (dir / "small.yaml").string() +
                                  " eval-stereo --dataset synthetic --root " + seq +
                                  " --max-pairs 1 --report-md " + (dir / "stereo.md").string(),
                              &output),
            0)
      << output;
  const std::string stereo = read_text(dir / "stereo.md");
  EXPECT_CONTAINS(stereo, "# Stereo accuracy: synthetic (1 pair)");
  EXPECT_CONTAINS(stereo, "## 3D accuracy (paper Table 1)");
  EXPECT_CONTAINS(stereo, "_Regenerate:_ `planecell --config ");
  ASSERT_EQ(
      test::run_command(bin + " --config " + (dir / "small.yaml").string() + " bench " + seq +
                            " --out " + (dir / "out").string() +
                            " --frames 1:3 --no-progress --append " + (dir / "stereo.md").string(),
                        &output),
      0)
      << output;
  EXPECT_CONTAINS(output, "report: ");
  EXPECT_CONTAINS(output, "planecell:");
  const auto j = nlohmann::json::parse(read_text(dir / "out" / "report.json"));
  EXPECT_EQ(j["frames"]["first"], 1);
  EXPECT_EQ(j["frames"]["count"], 2);
  EXPECT_EQ(j["overlay_frame"], 1);
  const std::string md = read_text(dir / "out" / "report.md");
  EXPECT_CONTAINS(md, "## Stereo accuracy: synthetic (1 pair)");  // appended one level deeper
  EXPECT_CONTAINS(md, "--frames 1:3");
  EXPECT_TRUE(fs::exists(dir / "out" / "overlay_000001.png"));
  // An empty range is bad input data (exit 1), named in the message.
  EXPECT_EQ(
      test::run_command(
          bin + " bench " + seq + " --out " + (dir / "none").string() + " --frames 7:9", &output),
      1);
  EXPECT_CONTAINS(output, "has 3 frames");
}

TEST(StereoMarkdown, RowsCarryTheScoredFigures) {
  // One pair, one method: 200 GT pixels, 150 estimated, 10 bad-2 → bad-2 over all GT pixels is
  // (10 + 50 missing) / 200 = 30 %; 3D: 80 of 200 within 10 cm = 40 %.
  eval::StereoMethod method{"m", "params", {}};
  eval::MethodResult m;
  m.method = "m";
  m.all.gt_pixels = 200;
  m.all.estimated = 150;
  m.all.bad2 = 10;
  m.all.abs_error_sum_px = 75;
  m.points.gt_pixels = 200;
  m.points.within = {80, 100, 120, 140};
  eval::PairResult pair;
  pair.pair = "p1";
  pair.methods = {m};
  const std::string md =
      eval::format_markdown("demo", "planecell eval-stereo --dataset demo", {pair}, {method});
  EXPECT_CONTAINS(md,
                  "| p1 | m | 25.00 | 30.00 | 25.00 | 25.00 | 75.0 | 6.67 | 0.00 | 0.50 | – | 0 |");
  EXPECT_CONTAINS(md, "| p1 | m | 40.00 | 50.00 | 60.00 | 70.00 | 200 |");
  EXPECT_CONTAINS(md, "_Regenerate:_ `planecell eval-stereo --dataset demo`");
  EXPECT_CONTAINS(md, "- **m**: params");
}

TEST(ReportMarkdown, TablesNumbersAndQuoting) {
  EXPECT_EQ(report::table({"a", "b"}, {{"1", "x|y"}, {"–", "z"}}),
            "| a | b |\n|---:|---|\n| 1 | x\\|y |\n| – | z |\n");
  EXPECT_EQ(report::bytes(812), "812 B");
  EXPECT_EQ(report::bytes(1536), "1.50 KiB");
  EXPECT_EQ(report::bytes(5.0 * 1024 * 1024 * 42), "210 MiB");
  EXPECT_EQ(report::number(NAN), "–");
  EXPECT_EQ(report::number(2.346, 2), "2.35");
  EXPECT_EQ(report::shell_quote("/tmp/a b"), "'/tmp/a b'");
  EXPECT_EQ(report::shell_quote("/tmp/ab:1"), "/tmp/ab:1");
  EXPECT_EQ(report::demote_headings("# T\n```\n# not a heading\n```\n## S\n"),
            "## T\n```\n# not a heading\n```\n### S\n");
}

}  // namespace
}  // namespace planecell::services::bench
