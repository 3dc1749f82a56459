/// Extraction cache: a frame's planecells and label image come back bit for bit; a file made from
/// other inputs (fingerprint) reads as absent; truncated, corrupted or misplaced files are clear
/// errors, never a crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/error.hpp"
#include "io/extraction_cache.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

/// A frame of `n` cells with every field set to a value of its own, and labels 0..n-1 in strips
/// (one pixel unlabelled, -1).
extraction::PlanecellFrame cached_frame(int n) {
  extraction::PlanecellFrame frame;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uniform(-10.0f, 10.0f);
  for (int k = 0; k < n; ++k) {
    Planecell c;
    c.id = static_cast<std::uint32_t>(k);
    c.frame_id = 7;
    c.has_plane = k % 5 != 2;
    c.disparity_plane = {uniform(rng) * 1e-3, uniform(rng) * 1e-3, 40.0 + uniform(rng)};
    c.plane.normal = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).normalized();
    c.plane.offset = uniform(rng);
    for (int v = 0; v < 3 + k % 4; ++v) {
      c.vertices_px.emplace_back(uniform(rng) + 50.0f, uniform(rng) + 20.0f);
      c.vertices_m.emplace_back(uniform(rng), uniform(rng), uniform(rng) + 20.0f);
    }
    c.mean_rgb = Eigen::Vector3f(uniform(rng) + 100.0f, 20.0f, 200.5f);
    for (float& h : c.histogram) h = std::abs(uniform(rng)) / 640.0f;
    c.area_px = 100u + static_cast<std::uint32_t>(k);
    c.inlier_count = 90u + static_cast<std::uint32_t>(k);
    c.inlier_ratio = 0.9f - 0.001f * static_cast<float>(k);
    c.depth_sigma_m = 0.01f * static_cast<float>(k + 1);
    c.normal_sigma_rad = 0.002f * static_cast<float>(k + 1);
    c.surface = k % 3 == 0 ? kNoSurface : static_cast<std::uint32_t>(k / 3);
    frame.cells.push_back(std::move(c));
  }
  frame.labels.create(30, 40, CV_32S);
  for (int y = 0; y < frame.labels.rows; ++y)
    for (int x = 0; x < frame.labels.cols; ++x) frame.labels.at<std::int32_t>(y, x) = (x * n) / 40;
  frame.labels.at<std::int32_t>(0, 0) = -1;
  frame.plane_fraction = 0.8;
  frame.cell_size_px = 11;
  return frame;
}

bool same_cached_cell(const Planecell& a, const Planecell& b) {
  return a.id == b.id && a.frame_id == b.frame_id && a.has_plane == b.has_plane &&
         a.disparity_plane.a == b.disparity_plane.a && a.disparity_plane.b == b.disparity_plane.b &&
         a.disparity_plane.c == b.disparity_plane.c && a.plane.normal == b.plane.normal &&
         a.plane.offset == b.plane.offset && a.vertices_px == b.vertices_px && a.vertices_m == b.vertices_m &&
         a.mean_rgb == b.mean_rgb && a.histogram == b.histogram && a.area_px == b.area_px &&
         a.inlier_count == b.inlier_count && a.inlier_ratio == b.inlier_ratio &&
         a.depth_sigma_m == b.depth_sigma_m && a.normal_sigma_rad == b.normal_sigma_rad && a.surface == b.surface;
}

std::vector<char> file_bytes_of(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_file_bytes(const std::filesystem::path& path, const std::vector<char>& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::size_t file_count(const std::filesystem::path& dir) {
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) files += entry.is_regular_file();
  return files;
}

class ExtractionCacheTest : public ::testing::Test {
 protected:
  std::filesystem::path path(std::uint64_t frame_id = 7) const { return extraction_cache_path(scratch_.path(), frame_id); }
  test::ScratchDir scratch_;
};

TEST_F(ExtractionCacheTest, ComesBackBitForBit) {
  const auto frame = cached_frame(23);
  write_extraction_cache(path(), 0xabcdef, 7, frame);
  EXPECT_EQ(path().filename(), "000007.pcx");
  EXPECT_EQ(file_count(scratch_.path()), 1u);  // no temporary file left
  const auto back = read_extraction_cache(path(), 0xabcdef, 7);
  ASSERT_TRUE(back.has_value());
  ASSERT_EQ(back->cells.size(), frame.cells.size());
  for (std::size_t i = 0; i < frame.cells.size(); ++i) EXPECT_TRUE(same_cached_cell(back->cells[i], frame.cells[i])) << i;
  ASSERT_EQ(back->labels.type(), CV_32S);
  ASSERT_EQ(back->labels.size(), frame.labels.size());
  EXPECT_EQ(cv::countNonZero(back->labels != frame.labels), 0);
  EXPECT_EQ(back->plane_fraction, frame.plane_fraction);
  EXPECT_EQ(back->cell_size_px, frame.cell_size_px);
  EXPECT_TRUE(back->dense_disparity.empty());  // not kept
}

TEST_F(ExtractionCacheTest, AFrameWithoutCellsOrLabelsComesBackEmpty) {
  write_extraction_cache(path(), 1, 7, extraction::PlanecellFrame{});
  const auto back = read_extraction_cache(path(), 1, 7);
  ASSERT_TRUE(back.has_value());
  EXPECT_TRUE(back->cells.empty());
  EXPECT_TRUE(back->labels.empty());
}

TEST_F(ExtractionCacheTest, OtherInputsOrAMissingFileReadAsAbsent) {
  write_extraction_cache(path(), 41, 7, cached_frame(5));
  EXPECT_FALSE(read_extraction_cache(path(), 42, 7).has_value());  // stale: recomputed
  EXPECT_FALSE(read_extraction_cache(path(8), 41, 8).has_value());  // never written
  EXPECT_TRUE(read_extraction_cache(path(), 41, 7).has_value());
}

TEST_F(ExtractionCacheTest, TruncatedCorruptOrForeignFilesAreClearErrors) {
  write_extraction_cache(path(), 5, 7, cached_frame(9));
  const std::vector<char> good = file_bytes_of(path());
  ASSERT_GT(good.size(), 200u);
  // Every truncation past the header is caught (the checksum or a size), never a crash.
  for (std::size_t keep : {good.size() - 1, good.size() / 2, std::size_t{30}}) {
    write_file_bytes(path(), std::vector<char>(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(keep)));
    const std::string message = test::error_of<StorageError>([&] { (void)read_extraction_cache(path(), 5, 7); });
    EXPECT_CONTAINS(message, path().string());
  }
  std::vector<char> flipped = good;
  flipped[flipped.size() / 2] ^= 0x10;
  write_file_bytes(path(), flipped);
  EXPECT_CONTAINS(test::error_of<StorageError>([&] { (void)read_extraction_cache(path(), 5, 7); }),
                  "checksum mismatch");
  write_file_bytes(path(), {'n', 'o', 't', ' ', 'a', ' ', 'c', 'a', 'c', 'h', 'e', ' ', 'f', 'i', 'l', 'e', '!'});
  EXPECT_CONTAINS(test::error_of<StorageError>([&] { (void)read_extraction_cache(path(), 5, 7); }),
                  "not an extraction cache file");
  // Frame 7's file copied under frame 8's name.
  write_file_bytes(path(), good);
  std::filesystem::copy_file(path(), path(8));
  EXPECT_CONTAINS(test::error_of<StorageError>([&] { (void)read_extraction_cache(path(8), 5, 8); }),
                  "holds frame 7, expected frame 8");
}

TEST_F(ExtractionCacheTest, AHeaderClaimingMorePixelsThanItsStreamHoldsIsRefusedBeforeAllocating) {
  // Found by fuzz_extraction_cache: a valid checksum over a 30000 x 30000 px header with an empty
  // stream asked for 3.6 GB.
  std::vector<std::uint8_t> bytes{'P', 'C', 'X', 'C', kExtractionCacheVersion};
  auto put = [&](auto value) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    bytes.insert(bytes.end(), p, p + sizeof(value));
  };
  put(std::uint64_t{9});  // fingerprint
  put(std::uint64_t{7});  // frame
  put(0.5);               // plane_fraction
  put(std::int32_t{10});  // cell_size_px
  put(std::int32_t{30000});
  put(std::int32_t{30000});
  put(std::uint32_t{0});  // compressed bytes
  put(std::uint32_t{0});  // cells
  put(extraction_cache_crc32(bytes));
  EXPECT_CONTAINS(test::error_of<StorageError>([&] { (void)decode_extraction_cache(bytes, 9, 7, "hand-made"); }),
                  "cannot hold a 30000 x 30000 px label image");
}

TEST_F(ExtractionCacheTest, WritersOfTheSameFrameAtOnceLeaveOneWholeFile) {
  // Two replays sharing a cache folder may write one frame at the same time: each through its
  // own temporary file, so neither finds its file renamed away by the other.
  const auto frame = cached_frame(17);
  std::vector<std::string> errors(4);
  {
    std::vector<std::jthread> writers;
    for (std::size_t w = 0; w < errors.size(); ++w)
      writers.emplace_back([&, w] {
        try {
          for (int i = 0; i < 50; ++i) write_extraction_cache(path(), 0x77, 7, frame);
        } catch (const std::exception& e) {
          errors[w] = e.what();
        }
      });
  }
  for (const auto& error : errors) EXPECT_EQ(error, "");
  const auto back = read_extraction_cache(path(), 0x77, 7);
  ASSERT_TRUE(back.has_value());
  ASSERT_EQ(back->cells.size(), frame.cells.size());
  for (std::size_t i = 0; i < frame.cells.size(); ++i) EXPECT_TRUE(same_cached_cell(back->cells[i], frame.cells[i])) << i;
  EXPECT_EQ(file_count(scratch_.path()), 1u);  // no temporary file left
}

TEST_F(ExtractionCacheTest, AnUnwritableFolderIsAClearError) {
  const auto missing = scratch_.path() / "no such folder" / "000001.pcx";
  EXPECT_CONTAINS(test::error_of<StorageError>([&] { write_extraction_cache(missing, 1, 1, cached_frame(2)); }),
                  "cannot be written");
}

}  // namespace
}  // namespace planecell::io
