/// Writes the binary seed inputs of the fuzz targets with the project's own writers (the text
/// seeds are committed in tests/fuzz/corpus/<target>/): usage `fuzz_make_seeds OUT_DIR` creates
/// OUT_DIR/<target>/seed_*. Run by scripts/fuzz.sh before fuzzing.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include "core/error.hpp"
#include "core/plane.hpp"
#include "io/disparity_io.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "io/extraction_cache.hpp"
#include "io/map_store.hpp"
#include "io/planecell_codec.hpp"
#include "support/planecell_fixtures.hpp"

namespace fs = std::filesystem;
using namespace planecell;

namespace {

cv::Mat small_disparity() {
  cv::Mat d(3, 4, CV_32F);
  for (int r = 0; r < d.rows; ++r)
    for (int c = 0; c < d.cols; ++c) d.at<float>(r, c) = 1.5f + static_cast<float>(r * 4 + c);
  d.at<float>(1, 2) = std::numeric_limits<float>::quiet_NaN();  // one invalid pixel
  return d;
}

/// Image-space cells on the pixel lattice with disparity planes (what extraction produces).
std::vector<Planecell> codec_cells(const StereoCamera& camera) {
  std::vector<Planecell> cells;
  for (std::uint32_t k = 0; k < 3; ++k) {
    Planecell c;
    c.id = k;
    const float x0 = 10.0f * k - 0.5f;
    c.vertices_px = {{x0, -0.5f}, {x0 + 10, -0.5f}, {x0 + 10, 9.5f}, {x0, 9.5f}};
    c.has_plane = k != 1;
    c.disparity_plane = {0.01 * k, -0.02, 20.0 + k};
    c.mean_rgb = Eigen::Vector3f(10.0f * k, 100, 200);
    c.area_px = 100;
    c.inlier_count = 90;
    c.inlier_ratio = 0.9f;
    c.histogram.fill(0.0f);
    c.histogram[k] = 1.0f;
    if (c.has_plane) c.plane = plane_from_disparity(c.disparity_plane, camera);
    cells.push_back(c);
  }
  return cells;
}

/// A 3 × 3 grid of 8 px lattice squares in raster order: every cell after the first shares
/// vertices and edges with earlier ones (frontier references, backward and forward runs).
std::vector<Planecell> codec_tiling(const StereoCamera& camera) {
  std::vector<Planecell> cells;
  for (std::uint32_t k = 0; k < 9; ++k) {
    Planecell c;
    c.id = k;
    const float x0 = 8.0f * static_cast<float>(k % 3) - 0.5f;
    const float y0 = 8.0f * static_cast<float>(k / 3) - 0.5f;
    c.vertices_px = {{x0, y0}, {x0 + 8, y0}, {x0 + 8, y0 + 8}, {x0, y0 + 8}};
    c.has_plane = k != 4;
    c.disparity_plane = {0.01, 0.0, 10.0 + k};
    c.mean_rgb = Eigen::Vector3f(20.0f * k, 50, 90);
    if (c.has_plane) c.plane = plane_from_disparity(c.disparity_plane, camera);
    cells.push_back(c);
  }
  return cells;
}

void write_bytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

/// fuzz_lcm input: the selector byte of the message type, then the encoded message.
template <class Message>
void write_lcm_seed(const fs::path& path, std::uint8_t selector, const Message& message) {
  std::vector<std::uint8_t> bytes{selector};
  const auto encoded = io::encode_bytes(message);
  bytes.insert(bytes.end(), encoded.begin(), encoded.end());
  write_bytes(path, bytes);
}

/// One seed per LCM message type fuzz_lcm handles (selectors as in fuzz_lcm.cpp).
void write_lcm_seeds(const fs::path& dir) {
  StereoFrame frame;
  frame.frame_id = 3;
  frame.left = cv::Mat(6, 8, CV_8UC3, cv::Scalar(10, 20, 30));
  frame.right = cv::Mat(6, 8, CV_8UC3, cv::Scalar(11, 21, 31));
  frame.camera.width = 8;
  frame.camera.height = 6;
  write_lcm_seed(dir / "seed_frame_raw", 0, io::to_lcm(frame, io::ImageEncoding::kRaw, 1000));
  write_lcm_seed(dir / "seed_frame_png", 0, io::to_lcm(frame, io::ImageEncoding::kPng, 1000));
  Pose pose = Pose::Identity();
  pose.translation() = Eigen::Vector3d(1, 2, 3);
  write_lcm_seed(dir / "seed_pose", 1, io::to_lcm(3, pose, 1000));
  io::MapUpdate update;
  update.frame_id = 4;
  const Eigen::Vector3f x(1, 0, 0), z(0, 0, 1);
  update.added_cells = {map::map_cell_of(test::rect_cell(2, {2, 1.5f, 5}, x, z, 3), 2, 4, 0)};
  update.relabelled_cells = {{1, 0}};
  update.surface_merges = {map::SurfaceMerge{4, 1, 0}};
  update.removed_surfaces = {1};
  update.next_cell_id = 3;
  update.next_surface_id = 2;
  update.map_cells = 3;
  update.map_surfaces = 1;
  write_lcm_seed(dir / "seed_map_update", 2, io::encode_map_update(update, 1000).at(0));
  planecell_lcm::map_stats_t stats{};
  stats.num_stages = 1;
  stats.stage = {"sgm"};
  stats.p50_ms = {60.0f};
  stats.p95_ms = {70.0f};
  stats.p99_ms = {80.0f};
  stats.num_queues = 1;
  stats.queue = {"frames"};
  stats.queue_depth = {2};
  write_lcm_seed(dir / "seed_map_stats", 3, stats);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  const fs::path out = argv[1];
  try {
    for (const char* target : {"pfm", "kitti_disparity_png", "planecell_codec", "map_store", "lcm", "extraction_cache"}) {
      fs::remove_all(out / target);  // only this program's seeds live here
      fs::create_directories(out / target);
    }
    io::write_pfm(out / "pfm" / "seed_small.pfm", small_disparity());
    io::write_kitti_disparity(out / "kitti_disparity_png" / "seed_small.png", small_disparity());

    StereoCamera camera;
    camera.width = 64;
    camera.height = 32;
    const auto cells = codec_cells(camera);
    write_bytes(out / "planecell_codec" / "seed_compact", io::encode_planecells(cells, camera, 7));
    write_bytes(out / "planecell_codec" / "seed_full",
                io::encode_planecells(cells, camera, 8, {true, true, true}));
    write_bytes(out / "planecell_codec" / "seed_tiling",
                io::encode_planecells(codec_tiling(camera), camera, 9, {false, false, true}));

    // A two-frame map store (rolled into one file: WAL checkpointed when the store closes).
    const fs::path db = out / "map_store" / "seed_two_frames.db";
    fs::remove(db);
    {
      io::MapStore store(db);
      map::GlobalMap map{MapConfig{}};
      const Eigen::Vector3f x(1, 0, 0), z(0, 0, 1);
      for (std::uint64_t f = 0; f < 2; ++f) {
        Pose pose = Pose::Identity();
        pose.translation() = Eigen::Vector3d(0, 0, static_cast<double>(f));
        std::vector<Planecell> frame{test::rect_cell(0, {0, 1.5f, 5.0f + f}, x, z, 3),
                                     test::rect_cell(1, {1, 1.5f, 5.0f + f}, x, z, 3)};
        const auto report = map.integrate(f, pose, frame);
        store.commit_frame(f, pose, report, map);
      }
    }
    for (const char* side : {"-wal", "-shm"}) fs::remove(db.string() + side);
    write_lcm_seeds(out / "lcm");
    // A frame of the codec's cells in the extraction cache (fuzz_extraction_cache's fingerprint
    // and frame id), labels in four vertical strips.
    extraction::PlanecellFrame frame;
    frame.cells = cells;
    frame.labels.create(8, 12, CV_32S);
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 12; ++x)
        frame.labels.at<std::int32_t>(y, x) = std::min<int>(x / 3, static_cast<int>(cells.size()) - 1);
    io::write_extraction_cache(out / "extraction_cache" / "seed_frame.pcx", 0x5eed, 3, frame);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_make_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
