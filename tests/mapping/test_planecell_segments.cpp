/// The segment machinery behind planecell extraction on small hand-made label images with known
/// answers: pixel-level hill climbing, connectivity enforcement and renumbering, per-segment
/// sample gathering, and per-segment plane fits against fitting each segment on its own.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "mapping/planecell/plane_fit.hpp"
#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction::detail {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// A state over `labels` (row-major, width w) with the given colour bins and no disparity.
SuperpixelState make_state(int w, int h, std::vector<std::int32_t> labels,
                           std::vector<std::uint8_t> bins, int segments) {
  SuperpixelState s;
  s.width = w;
  s.height = h;
  s.cell_size_px = 4;
  s.labels = std::move(labels);
  s.bins = std::move(bins);
  s.disparity.assign(static_cast<std::size_t>(w) * h, kNaN);
  s.num_segments = segments;
  s.planes.assign(segments, DisparityPlane{});
  s.has_plane.assign(segments, 0);
  s.weights.reg_per_px2 = 0.01;
  recompute_statistics(s);
  return s;
}

/// The statistics recomputed from scratch equal the ones carried along.
void expect_statistics_consistent(const SuperpixelState& s) {
  SuperpixelState fresh = s;
  recompute_statistics(fresh);
  EXPECT_EQ(fresh.histogram, s.histogram);
  EXPECT_EQ(fresh.size, s.size);
  EXPECT_EQ(fresh.sum_u, s.sum_u);
  EXPECT_EQ(fresh.sum_v, s.sum_v);
  for (int l = 0; l < s.num_segments; ++l) {
    EXPECT_EQ(fresh.centre[l].mean_u, s.centre[l].mean_u) << "segment " << l;
    EXPECT_EQ(fresh.centre[l].mean_v, s.centre[l].mean_v) << "segment " << l;
  }
}

TEST(PixelHillClimbing, MisplacedBoundaryMovesOntoTheColourEdge) {
  // 16×8: colour bin 0 in columns 0..7, bin 124 in columns 8..15; the initial boundary sits two
  // columns too far right (segment 0 = columns 0..9).
  constexpr int kW = 16, kH = 8;
  std::vector<std::int32_t> labels(kW * kH);
  std::vector<std::uint8_t> bins(kW * kH);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      labels[v * kW + u] = u < 10 ? 0 : 1;
      bins[v * kW + u] = u < 8 ? 0 : 124;
    }
  SuperpixelState s = make_state(kW, kH, labels, bins, 2);
  hill_climb(s, /*block_levels=*/0, 1, 0, /*pixel_iterations=*/4, Deadline{});
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
      EXPECT_EQ(s.labels[v * kW + u], u < 8 ? 0 : 1) << "pixel (" << u << ", " << v << ")";
  EXPECT_EQ(s.size[0], 64);
  EXPECT_EQ(s.size[1], 64);
  expect_statistics_consistent(s);
}

TEST(PixelHillClimbing, NeverSplitsOrEmptiesASegment) {
  // A one-pixel-wide bridge of segment 0 (column 4) between two blobs, inside colour of
  // segment 1: the bridge pixels would all rather join segment 1, but leaving would cut
  // segment 0 in two (or empty it), so the segment stays 4-connected.
  constexpr int kW = 9, kH = 5;
  std::vector<std::int32_t> labels(kW * kH, 1);
  std::vector<std::uint8_t> bins(kW * kH, 124);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      const bool blob = (u < 2 || u > 6) && v >= 1 && v <= 3;
      const bool bridge = v == 2 && u >= 2 && u <= 6;
      if (blob || bridge) labels[v * kW + u] = 0;
      if (blob) bins[v * kW + u] = 0;
    }
  SuperpixelState s = make_state(kW, kH, labels, bins, 2);
  hill_climb(s, 0, 1, 0, 4, Deadline{});
  // Flood fill segment 0 from one blob: it must reach every pixel of segment 0.
  std::vector<char> seen(kW * kH, 0);
  std::vector<int> stack = {2 * kW + 0};
  seen[stack[0]] = 1;
  int reached = 0;
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    ++reached;
    const int u = i % kW, v = i / kW;
    for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      const int x = u + du, y = v + dv;
      if (x < 0 || y < 0 || x >= kW || y >= kH) continue;
      const int j = y * kW + x;
      if (!seen[j] && s.labels[j] == 0) {
        seen[j] = 1;
        stack.push_back(j);
      }
    }
  }
  EXPECT_GT(s.size[0], 0);
  EXPECT_EQ(reached, s.size[0]);
  expect_statistics_consistent(s);
}

TEST(EnforceConnectivity, OrphanPieceJoinsTheKeptNeighbourOnItsLeft) {
  // Label 0 has a 4-pixel piece and a 1-pixel orphan at (3, 2); the orphan's first neighbour
  // (left) belongs to segment 3's only piece, so it joins segment 3.
  const std::vector<std::int32_t> labels = {0, 0, 1, 1, 2, 2,  //
                                            0, 0, 1, 1, 2, 2,  //
                                            3, 3, 3, 0, 2, 2,  //
                                            3, 3, 3, 3, 2, 2};
  SuperpixelState s = make_state(6, 4, labels, std::vector<std::uint8_t>(24, 7), 4);
  enforce_connectivity(s);
  std::vector<std::int32_t> expected = labels;
  expected[2 * 6 + 3] = 3;
  EXPECT_EQ(s.labels, expected);
  EXPECT_EQ(s.num_segments, 4);
  EXPECT_EQ(s.size, (std::vector<std::int32_t>{4, 4, 8, 8}));
  expect_statistics_consistent(s);
}

TEST(EnforceConnectivity, EqualPiecesKeepTheFirstInRasterOrder) {
  SuperpixelState s = make_state(3, 1, {0, 1, 0}, {1, 2, 3}, 2);
  enforce_connectivity(s);
  EXPECT_EQ(s.labels, (std::vector<std::int32_t>{0, 1, 1}));
  EXPECT_EQ(s.size, (std::vector<std::int32_t>{1, 2}));
  expect_statistics_consistent(s);
}

TEST(EnforceConnectivity, RenumbersInRasterOrderCarryingPlanesAndStatistics) {
  // Labels 4, 2, 0 in raster order of their first pixel; 1 and 3 are unused.
  const std::vector<std::int32_t> labels = {4, 4, 2, 2,  //
                                            4, 4, 2, 2,  //
                                            0, 0, 0, 0};
  const std::vector<std::uint8_t> bins = {1, 1, 2, 2, 1, 1, 2, 2, 3, 3, 3, 3};
  SuperpixelState s = make_state(4, 3, labels, bins, 5);
  for (int l = 0; l < 5; ++l) {
    s.planes[l] = {0.0, 0.0, 10.0 * l};
    s.has_plane[l] = l % 2 == 0;
  }
  enforce_connectivity(s);
  EXPECT_EQ(s.labels, (std::vector<std::int32_t>{0, 0, 1, 1, 0, 0, 1, 1, 2, 2, 2, 2}));
  ASSERT_EQ(s.num_segments, 3);
  EXPECT_EQ(s.planes[0].c, 40.0);
  EXPECT_EQ(s.planes[1].c, 20.0);
  EXPECT_EQ(s.planes[2].c, 0.0);
  EXPECT_EQ(s.size, (std::vector<std::int32_t>{4, 4, 4}));
  EXPECT_EQ(s.histogram[0 * kEnergyBins + 1], 4);  // old segment 4: bin 1
  EXPECT_EQ(s.histogram[1 * kEnergyBins + 2], 4);  // old segment 2: bin 2
  EXPECT_EQ(s.histogram[2 * kEnergyBins + 3], 4);  // old segment 0: bin 3
  expect_statistics_consistent(s);
}

TEST(SegmentSamples, EachSegmentListsItsValidPixelsInRasterOrder) {
  // Two segments (left / right halves of 5×3), a few unmatched pixels.
  constexpr int kW = 5, kH = 3;
  std::vector<std::int32_t> labels(kW * kH);
  for (int i = 0; i < kW * kH; ++i) labels[i] = i % kW < 2 ? 0 : 1;
  SuperpixelState s = make_state(kW, kH, labels, std::vector<std::uint8_t>(kW * kH, 0), 2);
  for (int i = 0; i < kW * kH; ++i) s.disparity[i] = static_cast<float>(10 + i);
  s.disparity[1] = s.disparity[7] = s.disparity[12] = kNaN;
  const SegmentSamples samples = gather_segment_samples(s);
  EXPECT_EQ(samples.area, (std::vector<std::int32_t>{6, 9}));
  for (int l = 0; l < 2; ++l) {
    const SampleLanes lanes = samples.lanes(l);
    EXPECT_EQ(samples.begin[l] % kSampleLane, 0);
    int k = 0;
    for (int i = 0; i < kW * kH; ++i) {
      if (labels[i] != l || std::isnan(s.disparity[i])) continue;
      ASSERT_LT(k, lanes.count);
      EXPECT_EQ(lanes.u[k], static_cast<float>(i % kW));
      EXPECT_EQ(lanes.v[k], static_cast<float>(i / kW));
      EXPECT_EQ(lanes.d[k], s.disparity[i]);
      ++k;
    }
    EXPECT_EQ(k, lanes.count);
    for (; k < lanes.padded_count(); ++k) EXPECT_EQ(lanes.d[k], kPaddingDisparity);
  }
  EXPECT_EQ(samples.count, (std::vector<std::int32_t>{5, 7}));
}

/// Four 20×15 quadrants, each a noisy plane with 15 % gross outliers.
SuperpixelState planar_quadrants() {
  constexpr int kW = 40, kH = 30;
  std::vector<std::int32_t> labels(kW * kH);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) labels[v * kW + u] = (v >= 15) * 2 + (u >= 20);
  SuperpixelState s = make_state(kW, kH, labels, std::vector<std::uint8_t>(kW * kH, 0), 4);
  const DisparityPlane planes[4] = {
      {0.05, 0.0, 20.0}, {-0.02, 0.1, 35.0}, {0.0, 0.3, 5.0}, {0.1, -0.05, 12.0}};
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> noise(-0.3f, 0.3f), wild(3.0f, 30.0f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      const float d = static_cast<float>(planes[labels[v * kW + u]].at(u, v)) + noise(rng);
      s.disparity[v * kW + u] = unit(rng) < 0.15f ? d + wild(rng) : d;
    }
  return s;
}

/// fit_segment_planes against fitting every segment on its own with its documented seed.
void expect_same_fits_as_one_by_one(const ExtractionConfig& config) {
  SuperpixelState s = planar_quadrants();
  const SegmentSamples samples = gather_segment_samples(s);
  SegmentPlaneFits fits;
  fit_segment_planes(s, samples, config, fits);
  for (int l = 0; l < s.num_segments; ++l) {
    std::vector<Eigen::Vector3f> own;
    for (int i = 0; i < s.width * s.height; ++i)
      if (s.labels[i] == l && !std::isnan(s.disparity[i]))
        own.emplace_back(i % s.width, i / s.width, s.disparity[i]);
    const auto seed = static_cast<std::uint32_t>(config.random_seed) * 7919u + l;
    const PlaneFitResult alone = fit_disparity_plane(own, config, seed);
    ASSERT_TRUE(alone.ok) << "segment " << l;
    EXPECT_EQ(s.has_plane[l], 1) << "segment " << l;
    EXPECT_EQ(s.planes[l].a, alone.plane.a) << "segment " << l;
    EXPECT_EQ(s.planes[l].b, alone.plane.b) << "segment " << l;
    EXPECT_EQ(s.planes[l].c, alone.plane.c) << "segment " << l;
    EXPECT_EQ(fits.inliers[l], alone.inliers) << "segment " << l;
    EXPECT_EQ(fits.valid[l], alone.valid) << "segment " << l;
  }
}

TEST(SegmentPlaneFits, EqualFittingEachSegmentAloneWithItsSeed) {
  expect_same_fits_as_one_by_one(ExtractionConfig{});
}

TEST(SegmentPlaneFits, EqualFittingAloneWhenRansacDrawsMoreThanPrecomputed) {
  ExtractionConfig config;
  config.ransac_iterations = 80;     // 240 draws, past the precomputed ones
  config.target_inlier_ratio = 1.0;  // never met with outliers: all hypotheses run
  config.random_seed = 3;
  expect_same_fits_as_one_by_one(config);
}

TEST(RansacDraws, BatchedFirstOutputsAndReplayEqualStdMt19937) {
  const std::array<std::uint32_t, kSeedBatch> seeds = {0u,    1u,         5489u,       7919u,
                                                       7920u, 123456789u, 0x7FFFFFFFu, 0xFFFFFFFFu};
  std::vector<std::uint32_t> first(kSeedBatch * kPrecomputedDraws);
  mt19937_first_outputs(seeds.data(), first.data());
  for (int j = 0; j < kSeedBatch; ++j) {
    std::mt19937 reference(seeds[j]);
    ReplayedMt19937 replayed(seeds[j], first.data() + j * kPrecomputedDraws);
    for (int k = 0; k < 3 * kPrecomputedDraws; ++k) {  // past the precomputed outputs too
      const std::uint32_t expected = reference();
      if (k < kPrecomputedDraws) {
        ASSERT_EQ(first[j * kPrecomputedDraws + k], expected);
      }
      ASSERT_EQ(replayed(), expected) << "seed " << seeds[j] << ", output " << k;
    }
  }
  // The standard's check value: the 10000th output of std::mt19937 with the default seed.
  ReplayedMt19937 default_seed(5489u, first.data() + 2 * kPrecomputedDraws);
  std::uint32_t last = 0;
  for (int k = 0; k < 10000; ++k) last = default_seed();
  EXPECT_EQ(last, 4123659995u);
}

TEST(SegmentPlaneFits, PaddingSamplesNeverCount) {
  // 13 samples exactly on d = 0.5·u − 0.25·v + 7 (not a multiple of the lane width).
  std::vector<Eigen::Vector3f> samples;
  for (int k = 0; k < 13; ++k) {
    const float u = static_cast<float>(k % 5) * 3.0f, v = static_cast<float>(k / 5) * 4.0f;
    samples.emplace_back(u, v, 0.5f * u - 0.25f * v + 7.0f);
  }
  const PlaneFitResult fit = fit_disparity_plane(samples, ExtractionConfig{}, 1);
  ASSERT_TRUE(fit.ok);
  EXPECT_EQ(fit.valid, 13);
  EXPECT_EQ(fit.inliers, 13);
  EXPECT_NEAR(fit.plane.a, 0.5, 1e-6);
  EXPECT_NEAR(fit.plane.b, -0.25, 1e-6);
  EXPECT_NEAR(fit.plane.c, 7.0, 1e-5);
}

}  // namespace
}  // namespace planecell::extraction::detail
