/// Replay end to end on a small generated street: the whole single-threaded pipeline, the map
/// store, resuming, and frame-range parsing.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "io/kitti_odometry.hpp"
#include "io/map_store.hpp"
#include "io/sequence_ground_truth.hpp"
#include "io/synthetic/synthetic_world.hpp"
#include "services/replay.hpp"
#include "support/expect_error.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

class ReplayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::write_small_street(scratch_ / "seq", 4, 5);
    config_ = test::small_street_config();
  }
  /// Replay of the fixture's street, quietly (no progress bar).
  ReplayOptions street_options() const {
    ReplayOptions options;
    options.sequence_dir = scratch_ / "seq";
    options.progress = false;
    return options;
  }
  /// Overwrites frame `stem`'s file in the sequence's GT folder `folder` with bytes no image
  /// decoder accepts.
  void corrupt_gt_file(const char* folder, const char* stem) const {
    for (const auto& entry : std::filesystem::directory_iterator(scratch_ / "seq" / folder))
      if (entry.path().stem() == stem) std::ofstream(entry.path(), std::ios::trunc) << "not a png";
  }
  test::ScratchDir scratch_;
  AppConfig config_;
};

TEST_F(ReplayTest, MapsEveryFrameAndStoresThem) {
  ReplayOptions options = street_options();
  options.map_path = scratch_ / "map.db";
  const ReplayReport report = run_replay(options, config_);
  EXPECT_EQ(report.frames, 4u);
  EXPECT_GT(report.cells_extracted, 4u * 50u);
  EXPECT_GT(report.cells_in_map, 0u);
  EXPECT_LE(report.cells_in_map, report.cells_extracted);  // fused re-observations are not stored
  EXPECT_GT(report.surfaces, 0u);
  EXPECT_LT(report.surfaces, report.cells_in_map);  // coplanar cells share surfaces
  EXPECT_GT(report.map_bytes, 0u);
  EXPECT_EQ(report.map_parts.total(), report.map_bytes);
  EXPECT_GT(report.map_parts.vertices, 0u);
  EXPECT_GT(report.store_bytes, 0u);
  // The store is compacted and its WAL checkpointed at the end: its pages are the whole file.
  ASSERT_TRUE(report.store_parts.has_value());
  EXPECT_EQ(report.store_parts->total(), report.store_bytes);
  EXPECT_EQ(report.store_parts->free, 0u);
  EXPECT_GT(report.store_parts->cells, 0u);
  const auto json = to_json(report);
  EXPECT_EQ(json["store_bytes_by_part"]["cell_bounds_rtree"].get<std::size_t>(),
            report.store_parts->bounds);
  EXPECT_EQ(json["map_bytes_by_part"]["footprints"].get<std::size_t>(),
            report.map_parts.footprints);
  // The synthetic sequence has GT surface ids: merging is scored against them.
  ASSERT_TRUE(report.merge_metrics.has_value());
  EXPECT_GT(report.merge_metrics->cells, 0u);
  EXPECT_GT(report.merge_metrics->area_in_dominant_label, 0.0);
  EXPECT_LE(report.merge_metrics->area_in_dominant_label, 1.0);
  EXPECT_LE(report.merge_metrics->area_one_label, report.merge_metrics->area_in_dominant_label);
  // The scene's kinds (road, facade, …) break the area not in one label down: the shares add up
  // to what area_one_label leaves, and the report names each kind.
  double kinds_area = 0.0, kinds_lost = 0.0;
  for (const auto& k : report.merge_metrics->by_kind) {
    EXPECT_NE(k.kind, "unknown");
    kinds_area += k.area;
    kinds_lost += k.lost;
  }
  EXPECT_NEAR(kinds_area, 1.0, 1e-9);
  EXPECT_NEAR(kinds_lost, 1.0 - report.merge_metrics->area_one_label, 1e-9);
  ASSERT_EQ(json["merge_vs_ground_truth"]["by_kind"].size(), report.merge_metrics->by_kind.size());
  // Every counted cell has the path that placed it: the paths' shares add up to all cells, their
  // crossed shares to the cells across GT planes; a rejected cell is never counted.
  double fate_cells = 0.0, fate_crossed = 0.0;
  for (const auto& f : report.merge_metrics->crossed_by_fate) {
    EXPECT_NE(f.fate, "rejected");
    EXPECT_LE(f.crossed, f.cells);
    fate_cells += f.cells;
    fate_crossed += f.crossed;
  }
  EXPECT_NEAR(fate_cells, 1.0, 1e-9);
  EXPECT_NEAR(fate_crossed, report.merge_metrics->cross_merged_cells_between_planes, 1e-9);
  EXPECT_EQ(json["merge_vs_ground_truth"]["crossed_planes_by_fate"].size(),
            report.merge_metrics->crossed_by_fate.size());
  // The scene's weakly textured surfaces (its glass windows at least) get their own share: some
  // of the GT area, split into one label and not.
  std::size_t weak_in_scene = 0;
  for (const auto& surface : io::read_scene_surfaces(scratch_ / "seq" / "scene.yaml"))
    weak_in_scene += io::is_weakly_textured(surface.texture) ? 1 : 0;
  const auto& weak = report.merge_metrics->weak_texture;
  EXPECT_GT(weak_in_scene, 0u);
  EXPECT_LE(weak.gt_surfaces, weak_in_scene);
  EXPECT_LE(weak.area, 1.0);
  EXPECT_NEAR(weak.one_label + weak.lost, weak.area, 1e-12);
  EXPECT_GE(weak.lost, 0.0);
  EXPECT_NEAR(json["merge_vs_ground_truth"]["weak_texture"]["area"].get<double>(), weak.area, 1e-12);
  EXPECT_EQ(json["merge_vs_ground_truth"]["weak_texture"]["gt_surfaces"].get<std::size_t>(), weak.gt_surfaces);
  EXPECT_LE(report.merge_metrics->weak_plane_error_cells, report.merge_metrics->plane_error_cells);
  EXPECT_EQ(json["cell_planes_vs_ground_truth"]["weak_texture"]["cells"].get<std::size_t>(),
            report.merge_metrics->weak_plane_error_cells);
  // The plane error split: a cell's centroid offset is the mean of its vertices' signed distances,
  // so it is at most their RMS, cell by cell and hence in the median; angles lie in [0°, 90°].
  const auto& metrics = *report.merge_metrics;
  EXPECT_LE(metrics.centroid_offset_median_m, metrics.plane_error_median_m + 1e-6);
  EXPECT_LE(metrics.weak_centroid_offset_median_m, metrics.weak_plane_error_median_m + 1e-6);
  EXPECT_GE(metrics.normal_error_median_deg, 0.0);
  EXPECT_LE(metrics.normal_error_median_deg, 90.0);
  EXPECT_LE(metrics.weak_normal_error_median_deg, 90.0);
  EXPECT_NEAR(json["cell_planes_vs_ground_truth"]["normal_angle_median_deg"].get<double>(),
              metrics.normal_error_median_deg, 1e-9);
  EXPECT_NEAR(json["cell_planes_vs_ground_truth"]["weak_texture"]["centroid_distance_median_m"].get<double>(),
              metrics.weak_centroid_offset_median_m, 1e-9);
  ASSERT_EQ(report.stage_latency.size(), 6u);  // load, sgm, extract, transform, merge, store
  // One integrate() time per frame, each inside its frame's merge stage.
  ASSERT_EQ(report.merge_ms.size(), 4u);
  double merge_stage_max_ms = 0.0;
  for (const auto& [stage, summary] : report.stage_latency)
    if (stage == "merge") merge_stage_max_ms = summary.max_ms;
  for (double ms : report.merge_ms) {
    EXPECT_GT(ms, 0.0);
    EXPECT_LE(ms, merge_stage_max_ms + 1e-3);
  }
  const io::MapStore store(scratch_ / "map.db");
  EXPECT_EQ(store.frame_count(), 4u);
  EXPECT_EQ(io::load_map(store).cells().size(), report.cells_in_map);
}

TEST_F(ReplayTest, ResumesAfterTheLastCommittedFrameAndMatchesAnUninterruptedRun) {
  // Stopped without settling (as a killed run is): the store holds the map as frame 1 left it.
  AppConfig config = config_;
  config.map.settle_at_close = false;
  ReplayOptions options = street_options();
  options.map_path = scratch_ / "split.db";
  options.last_frame = 2;
  EXPECT_EQ(run_replay(options, config).frames, 2u);
  EXPECT_FALSE(io::MapStore(scratch_ / "split.db").load().settled);
  options.last_frame = std::numeric_limits<std::size_t>::max();
  const ReplayReport resumed = run_replay(options, config);
  EXPECT_EQ(resumed.frames, 2u);
  EXPECT_EQ(resumed.frames_resumed, 2u);

  options.map_path = scratch_ / "whole.db";
  const ReplayReport whole = run_replay(options, config);
  EXPECT_EQ(whole.frames, 4u);
  const auto split_map = io::load_map(io::MapStore(scratch_ / "split.db"), config.map);
  const auto whole_map = io::load_map(io::MapStore(scratch_ / "whole.db"), config.map);
  EXPECT_TRUE(split_map.same_content(whole_map));
}

TEST_F(ReplayTest, AFinishedReplaySettlesTheMapAndAResumedOneGoesOnFromIt) {
  ReplayOptions options = street_options();
  options.map_path = scratch_ / "settled.db";
  options.last_frame = 2;
  const ReplayReport first = run_replay(options, config_);
  ASSERT_TRUE(config_.map.settle_at_close);
  EXPECT_TRUE(first.settled);
  EXPECT_LT(first.map_bytes, first.map_bytes_live);  // the last frames' working set is gone
  {
    const io::MapStore store(scratch_ / "settled.db");
    EXPECT_TRUE(store.load().settled);
    const auto stored = io::load_map(store, config_.map);
    EXPECT_EQ(stored.cells().size(), first.cells_in_map);
    EXPECT_EQ(map::dormant_surface_count(stored), stored.surfaces().size());
  }
  options.last_frame = std::numeric_limits<std::size_t>::max();
  const ReplayReport resumed = run_replay(options, config_);
  EXPECT_EQ(resumed.frames, 2u);
  EXPECT_EQ(resumed.frames_resumed, 2u);
  const io::MapStore store(scratch_ / "settled.db");
  EXPECT_EQ(store.frame_count(), 4u);
  EXPECT_TRUE(store.load().settled);
  EXPECT_EQ(io::load_map(store, config_.map).cells().size(), resumed.cells_in_map);
}

TEST_F(ReplayTest, TheExtractionCacheRerunsTheMappingOnTheSameCells) {
  ReplayOptions options = street_options();
  options.extraction_cache_dir = scratch_ / "cache";
  options.map_path = scratch_ / "computed.db";
  const ReplayReport computed = run_replay(options, config_);
  EXPECT_EQ(computed.frames_from_extraction_cache, 0u);
  EXPECT_TRUE(std::filesystem::exists(scratch_ / "cache" / "000003.pcx"));
  options.map_path = scratch_ / "cached.db";
  const ReplayReport cached = run_replay(options, config_);
  EXPECT_EQ(cached.frames, 4u);
  EXPECT_EQ(cached.frames_from_extraction_cache, 4u);
  EXPECT_EQ(cached.cells_extracted, computed.cells_extracted);
  // The same cells make the same map, and score the same against the ground truth.
  const auto a = io::load_map(io::MapStore(scratch_ / "computed.db"), config_.map);
  const auto b = io::load_map(io::MapStore(scratch_ / "cached.db"), config_.map);
  EXPECT_TRUE(a.same_content(b));
  ASSERT_TRUE(computed.merge_metrics && cached.merge_metrics);
  EXPECT_EQ(cached.merge_metrics->area_one_label, computed.merge_metrics->area_one_label);
  EXPECT_EQ(cached.merge_metrics->cells, computed.merge_metrics->cells);
  // Other extraction settings make other cells: the cache is stale and rewritten, not used.
  AppConfig other = config_;
  other.extraction.target_cells += 40;
  options.map_path.reset();
  EXPECT_EQ(run_replay(options, other).frames_from_extraction_cache, 0u);
  EXPECT_EQ(run_replay(options, other).frames_from_extraction_cache, 4u);
  // Map settings do not make the cells: the cache still holds.
  AppConfig other_map = other;
  other_map.map.neighbour_gap_m += 0.1;
  EXPECT_EQ(run_replay(options, other_map).frames_from_extraction_cache, 4u);
  // A corrupt cache file is a clear error naming it; the voxel baseline needs the disparity.
  {
    const auto file = scratch_ / "cache" / "000002.pcx";
    std::string bytes;
    {
      std::ifstream in(file, std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    ASSERT_GT(bytes.size(), 100u);
    bytes[bytes.size() / 2] ^= 0x08;
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  }
  EXPECT_NE(test::error_of<StorageError>([&] { run_replay(options, other); }).find("000002.pcx"), std::string::npos);
  options.voxel = true;
  EXPECT_NE(test::error_of<ConfigError>([&] { run_replay(options, other); }).find("--voxel"), std::string::npos);
}

TEST_F(ReplayTest, VoxelBaselineIsFedTheSameFrames) {
  ReplayOptions options = street_options();
  options.voxel = true;
  options.last_frame = 2;
  const ReplayReport report = run_replay(options, config_);
  EXPECT_EQ(report.frames, 2u);
  EXPECT_GT(report.voxel_leaves, 1000u);
  EXPECT_GT(report.voxel_bytes, report.voxel_bt_bytes);
  EXPECT_GT(report.voxel_ot_bytes, report.voxel_bt_bytes);  // colour costs bytes
  EXPECT_EQ(to_json(report)["voxel"]["voxel_leaves"].get<std::size_t>(), report.voxel_leaves);
  // Scored like the map: every occupied voxel against the scene, the map's GT points against them.
  ASSERT_TRUE(report.voxel_accuracy.has_value());
  EXPECT_EQ(report.voxel_accuracy->voxels, report.voxel_leaves);
  ASSERT_TRUE(report.voxel_completeness.has_value() && report.map_completeness.has_value());
  EXPECT_EQ(report.voxel_completeness->points, report.map_completeness->points);
  EXPECT_GT(report.voxel_completeness->within[2], 0.9);  // SGM's points of the same frames
  EXPECT_DOUBLE_EQ(to_json(report)["voxel"]["accuracy_vs_ground_truth"]["within_0_10_m"].get<double>(),
                   report.voxel_accuracy->within[0]);
  // Without a store only the RAM ratio is reported.
  const auto ram_only = to_json(report)["map_vs_voxel"];
  EXPECT_DOUBLE_EQ(ram_only["ram_times_smaller"].get<double>(),
                   double(report.voxel_bytes) / double(report.map_bytes));
  EXPECT_FALSE(ram_only.contains("store_over_bt"));
}

TEST_F(ReplayTest, ReportComparesTheMapWithTheVoxelBaselineAsTheTargetsStateIt) {
  ReplayOptions options = street_options();
  options.voxel = true;
  options.map_path = scratch_ / "map.db";
  options.last_frame = 2;
  ReplayReport report = run_replay(options, config_);
  ASSERT_GT(report.store_bytes, 0u);
  const auto c = compare_with_voxel(report);
  ASSERT_TRUE(c.has_value());
  ASSERT_TRUE(c->store_times_smaller_than_ot && c->store_over_bt);
  const auto json = to_json(report)["map_vs_voxel"];
  EXPECT_DOUBLE_EQ(json["store_times_smaller_than_ot"].get<double>(),
                   double(report.voxel_ot_bytes) / double(report.store_bytes));
  EXPECT_DOUBLE_EQ(json["store_over_bt"].get<double>(),
                   double(report.store_bytes) / double(report.voxel_bt_bytes));
  // The summary line, on round figures: RAM 4000 / 1000 B, .ot 3000 / 1000 B, 1000 / 4000 B .bt.
  report.map_bytes = 1000, report.voxel_bytes = 4000;
  report.store_bytes = 1000, report.voxel_ot_bytes = 3000, report.voxel_bt_bytes = 4000;
  EXPECT_CONTAINS(summary_text(report),
                  "map vs voxel baseline: 4.0x smaller in RAM; store 3.0x smaller than the .ot, "
                  "0.25x the .bt\n");
  report.voxel = false;  // no baseline: nothing to compare with
  EXPECT_FALSE(compare_with_voxel(report).has_value());
  EXPECT_FALSE(to_json(report).contains("map_vs_voxel"));
}

TEST_F(ReplayTest, SequenceWithoutPosesIsRejectedWithAClearError) {
  std::filesystem::remove_all(scratch_ / "seq" / "poses");
  ReplayOptions options = street_options();
  try {
    run_replay(options, config_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no poses"), std::string::npos) << e.what();
  }
}

TEST_F(ReplayTest, GtDisparityReplacesSgmWithTheSequencesGroundTruth) {
  ReplayOptions options = street_options();
  options.gt_disparity = true;
  const io::KittiOdometrySequence sequence = io::open_kitti_odometry(options.sequence_dir);
  std::size_t frames_seen = 0;
  options.observe = [&](const FrameWork& work) {
    const cv::Mat gt = io::load_disparity_ground_truth(sequence, work.frame_id, work.disparity.cols,
                                                       work.disparity.rows);
    ASSERT_FALSE(gt.empty());
    // The same pixels, NaN where the ground truth has none: the map was built from it.
    cv::Mat differs;
    cv::compare(work.disparity, gt, differs, cv::CMP_NE);  // NaN != NaN: count NaNs apart
    const int nan_pixels = cv::countNonZero(gt != gt);
    EXPECT_EQ(cv::countNonZero(differs), nan_pixels) << "frame " << work.frame_id;
    EXPECT_EQ(cv::countNonZero(work.disparity != work.disparity), nan_pixels) << "frame " << work.frame_id;
    ++frames_seen;
  };
  const ReplayReport report = run_replay(options, config_);
  EXPECT_EQ(report.frames, 4u);
  EXPECT_EQ(frames_seen, 4u);
  EXPECT_GT(report.cells_in_map, 0u);
  // Map completeness from frame 0's GT points (frame stride 10): exact disparity, exact poses.
  ASSERT_TRUE(report.map_completeness.has_value());
  EXPECT_GT(report.map_completeness->points, 0u);
  const auto& held = report.map_completeness->within;
  EXPECT_LE(held[0], held[1]);
  EXPECT_LE(held[1], held[2]);
  EXPECT_GT(held[0], 0.5);  // exact planes: most seen points lie on a stored cell
  // A map cut to 5 m holds less of what the frames saw within the fixed 20 m: the score counts
  // what the map leaves out, not only how well it fits what it keeps.
  AppConfig short_range = config_;
  short_range.map.max_range_m = 5.0;
  const ReplayReport cut = run_replay(options, short_range);
  ASSERT_TRUE(cut.map_completeness.has_value());
  EXPECT_EQ(cut.map_completeness->points, report.map_completeness->points);
  EXPECT_LT(cut.map_completeness->within[2], held[2] - 0.1);
  // Map accuracy against the scene's GT polygons: exact planes lie on the surfaces they came from.
  ASSERT_TRUE(report.map_accuracy.has_value());
  EXPECT_EQ(report.map_accuracy->cells, report.cells_in_map);
  const auto& on = report.map_accuracy->within;
  EXPECT_GT(on[0], 0.95);
  EXPECT_LE(on[0], on[1]);
  EXPECT_LE(on[1], on[2]);

  options.observe = nullptr;
  options.threads = true;
  EXPECT_THROW(run_replay(options, config_), ConfigError);
  options.threads = false;
  std::filesystem::remove_all(scratch_ / "seq" / "disp_occ_0");
  try {
    run_replay(options, config_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("disp_occ_0"), std::string::npos) << e.what();
  }
}

TEST_F(ReplayTest, CorruptGtDisparityDropsTheCompletenessScoreNotTheMap) {
  ReplayOptions options = street_options();
  const ReplayReport scored = run_replay(options, config_);
  ASSERT_TRUE(scored.map_completeness.has_value());
  // Frame 0's GT disparity (the only one scored, every 10th frame) becomes garbage.
  corrupt_gt_file("disp_occ_0", "000000");
  const ReplayReport report = run_replay(options, config_);
  EXPECT_EQ(report.frames, 4u);
  EXPECT_EQ(report.cells_in_map, scored.cells_in_map);  // the same map
  EXPECT_FALSE(report.map_completeness.has_value());
}

TEST_F(ReplayTest, CorruptSceneDropsTheAccuracyScoreNotTheMap) {
  ReplayOptions options = street_options();
  const ReplayReport scored = run_replay(options, config_);
  ASSERT_TRUE(scored.map_accuracy.has_value());
  std::ofstream(scratch_ / "seq" / "scene.yaml", std::ios::trunc) << "surfaces: [ {id: 1, kind: nonsense";
  const ReplayReport report = run_replay(options, config_);
  EXPECT_EQ(report.cells_in_map, scored.cells_in_map);  // the same map
  EXPECT_FALSE(report.map_accuracy.has_value());
  EXPECT_TRUE(report.map_completeness.has_value());  // the other scores stay
}

TEST_F(ReplayTest, CorruptGtSurfaceIdsDropTheMergeScoresNotTheMap) {
  ReplayOptions options = street_options();
  const ReplayReport scored = run_replay(options, config_);
  ASSERT_TRUE(scored.merge_metrics.has_value());
  // Frame 2's surface ids become garbage: the scores end there, the map does not.
  corrupt_gt_file("surface_0", "000002");
  const ReplayReport report = run_replay(options, config_);
  EXPECT_EQ(report.frames, 4u);
  EXPECT_EQ(report.cells_in_map, scored.cells_in_map);  // the same map
  EXPECT_EQ(report.surfaces, scored.surfaces);
  EXPECT_FALSE(report.merge_metrics.has_value());
  EXPECT_TRUE(report.map_completeness.has_value());  // the other scores stay
}

TEST(ReplayFrameRange, ParsesBoundsAndRejectsNonsense) {
  using Range = std::pair<std::size_t, std::size_t>;
  EXPECT_EQ(parse_frame_range("3:10"), Range(3, 10));
  EXPECT_EQ(parse_frame_range("5:").first, 5u);
  EXPECT_EQ(parse_frame_range("5:").second, std::numeric_limits<std::size_t>::max());
  EXPECT_EQ(parse_frame_range(":7"), Range(0, 7));
  EXPECT_THROW(parse_frame_range("7"), ConfigError);
  EXPECT_THROW(parse_frame_range("7:3"), ConfigError);
  EXPECT_THROW(parse_frame_range("a:b"), ConfigError);
  EXPECT_THROW(parse_frame_range("-1:4"), ConfigError);
}

}  // namespace
}  // namespace planecell::services
