/// Planecell extraction on a rendered scene with known planes: boundaries, planes, dense
/// disparity, planeless regions, 2D→3D exactness, and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <vector>

#include "core/error.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/planecell/extraction.hpp"

namespace planecell::extraction {
namespace {

/// A 320×240 scene of four regions, each with its colour and disparity plane d = a·u + b·v + c;
/// region 3 ("sky") has no disparity at all.
struct Region {
  cv::Vec3b bgr;
  DisparityPlane plane;
  bool has_disparity;
};

struct SceneOptions {
  const char* name;
  int colour_noise;        ///< ± uniform noise on each channel
  double disparity_noise;  ///< ± uniform noise (px)
  double hole_fraction;    ///< share of pixels with NaN disparity
};

struct Scene {
  cv::Mat left, disparity, region;  // region: CV_32S GT region id
  std::vector<Region> regions;
  StereoCamera camera;
};

/// Level (0..3) of histogram bin q = 16·R + 4·G + B on channel c (0 = R, 1 = G, 2 = B).
int level_of_bin(int q, int c) { return c == 0 ? q / 16 : c == 1 ? (q / 4) % 4 : q % 4; }

/// Weight of level k for an 8-bit value v, from the definition (not the table):
/// t = clamp((v − 31.5) / 64, 0, 3), lo = min(⌊t⌋, 2); lo gets 1 − (t − lo), lo + 1 gets t − lo.
double level_weight(int v, int k) {
  const double t = std::clamp((v - 31.5) / 64.0, 0.0, 3.0);
  const int lo = std::min(static_cast<int>(std::floor(t)), 2);
  return k == lo ? 1.0 - (t - lo) : k == lo + 1 ? t - lo : 0.0;
}

/// Trilinear weight of bin q for the colour (r, g, b).
double soft_weight(int r, int g, int b, int q) {
  return level_weight(r, level_of_bin(q, 0)) * level_weight(g, level_of_bin(q, 1)) *
         level_weight(b, level_of_bin(q, 2));
}

Scene make_scene(const SceneOptions& options) {
  constexpr int kW = 320, kH = 240;
  Scene s;
  s.regions = {
      {cv::Vec3b(60, 60, 200), {0.02, 0.0, 10.0}, true},    // 0: far wall, red
      {cv::Vec3b(60, 170, 60), {0.0, 0.15, 5.0}, true},     // 1: ground, green
      {cv::Vec3b(210, 90, 40), {-0.01, 0.005, 45.0}, true}, // 2: box, blue
      {cv::Vec3b(250, 235, 225), {0.0, 0.0, 0.0}, false},   // 3: sky, near white
  };
  s.camera.fx = s.camera.fy = 300.0;
  s.camera.cx = 160.0;
  s.camera.cy = 120.0;
  s.camera.baseline_m = 0.5;
  s.camera.width = kW;
  s.camera.height = kH;
  s.left.create(kH, kW, CV_8UC3);
  s.disparity.create(kH, kW, CV_32F);
  s.region.create(kH, kW, CV_32S);
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> colour_noise(-options.colour_noise, options.colour_noise);
  std::uniform_real_distribution<double> disp_noise(-options.disparity_noise,
                                                    options.disparity_noise);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      int r = v < 100 ? 0 : 1;
      if (u >= 120 && u < 220 && v >= 60 && v < 180) r = 2;
      if (u < 90 && v < 50) r = 3;
      const Region& region = s.regions[r];
      s.region.at<int>(v, u) = r;
      cv::Vec3b c = region.bgr;
      for (int k = 0; k < 3; ++k) c[k] = cv::saturate_cast<uchar>(c[k] + colour_noise(rng));
      s.left.at<cv::Vec3b>(v, u) = c;
      float d = std::numeric_limits<float>::quiet_NaN();
      if (region.has_disparity && unit(rng) >= options.hole_fraction)
        d = static_cast<float>(region.plane.at(u, v) + disp_noise(rng));
      s.disparity.at<float>(v, u) = d;
    }
  }
  return s;
}

class PlanecellExtraction : public ::testing::TestWithParam<SceneOptions> {
 protected:
  void SetUp() override {
    scene_ = make_scene(GetParam());
    config_.target_cells = 150;
    frame_ = extract_planecells(scene_.left, scene_.disparity, scene_.camera, config_);
    // Majority GT region and purity of every cell.
    const int n = static_cast<int>(frame_.cells.size());
    std::vector<std::array<int, 4>> counts(n, {0, 0, 0, 0});
    for (int v = 0; v < frame_.labels.rows; ++v)
      for (int u = 0; u < frame_.labels.cols; ++u)
        ++counts[frame_.labels.at<int>(v, u)][scene_.region.at<int>(v, u)];
    majority_.resize(n);
    purity_.resize(n);
    for (int k = 0; k < n; ++k) {
      int best = 0, total = 0;
      for (int r = 0; r < 4; ++r) {
        total += counts[k][r];
        if (counts[k][r] > counts[k][best]) best = r;
      }
      majority_[k] = best;
      purity_[k] = total > 0 ? static_cast<double>(counts[k][best]) / total : 0.0;
    }
  }

  Scene scene_;
  ExtractionConfig config_;
  PlanecellFrame frame_;
  std::vector<int> majority_;
  std::vector<double> purity_;
};

TEST_P(PlanecellExtraction, LabelsAreAConnectedPartitionWithConsistentCells) {
  const int n = static_cast<int>(frame_.cells.size());
  ASSERT_GT(n, 100);  // ≈ 150 asked (13 × 10 grid of 21 px cells)
  ASSERT_EQ(frame_.labels.type(), CV_32S);
  std::vector<int> area(n, 0);
  for (int v = 0; v < frame_.labels.rows; ++v)
    for (int u = 0; u < frame_.labels.cols; ++u) {
      const int l = frame_.labels.at<int>(v, u);
      ASSERT_GE(l, 0);
      ASSERT_LT(l, n);
      ++area[l];
    }
  // Each cell: id = index, area matches, 4-connected (flood fill from its first pixel).
  cv::Mat visited = cv::Mat::zeros(frame_.labels.size(), CV_8U);
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(frame_.cells[k].id, static_cast<std::uint32_t>(k));
    EXPECT_EQ(frame_.cells[k].area_px, static_cast<std::uint32_t>(area[k]));
    ASSERT_GT(area[k], 0);
  }
  int components = 0;
  for (int v = 0; v < frame_.labels.rows; ++v)
    for (int u = 0; u < frame_.labels.cols; ++u) {
      if (visited.at<uchar>(v, u)) continue;
      ++components;
      const int l = frame_.labels.at<int>(v, u);
      std::vector<cv::Point> stack = {{u, v}};
      visited.at<uchar>(v, u) = 1;
      while (!stack.empty()) {
        const cv::Point p = stack.back();
        stack.pop_back();
        for (const cv::Point d : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1),
                                  cv::Point(0, -1)}) {
          const cv::Point q = p + d;
          if (q.x < 0 || q.y < 0 || q.x >= frame_.labels.cols || q.y >= frame_.labels.rows)
            continue;
          if (visited.at<uchar>(q) || frame_.labels.at<int>(q) != l) continue;
          visited.at<uchar>(q) = 1;
          stack.push_back(q);
        }
      }
    }
  EXPECT_EQ(components, n) << "some segment is split into several pieces";
}

TEST_P(PlanecellExtraction, CellsRespectThePlaneBoundaries) {
  for (std::size_t k = 0; k < frame_.cells.size(); ++k)
    EXPECT_GE(purity_[k], 0.95) << "cell " << k << " mixes GT planes (majority "
                                << majority_[k] << ")";
}

TEST_P(PlanecellExtraction, FittedPlanesRecoverTheSceneGeometry) {
  int checked = 0;
  for (std::size_t k = 0; k < frame_.cells.size(); ++k) {
    const Planecell& cell = frame_.cells[k];
    const Region& truth = scene_.regions[majority_[k]];
    if (!truth.has_disparity || purity_[k] < 0.99 || cell.area_px < 150) continue;
    ASSERT_TRUE(cell.has_plane) << "cell " << k;
    ++checked;
    EXPECT_NEAR(cell.disparity_plane.a, truth.plane.a, 0.01) << "cell " << k;
    EXPECT_NEAR(cell.disparity_plane.b, truth.plane.b, 0.01) << "cell " << k;
    // c is extrapolated to the image origin; compare the plane where the cell is instead.
    const Eigen::Vector2f& p = cell.vertices_px.front();
    EXPECT_NEAR(cell.disparity_plane.at(p.x(), p.y()), truth.plane.at(p.x(), p.y()), 0.25)
        << "cell " << k;
    EXPECT_GT(cell.inlier_ratio, 0.8f);
    EXPECT_LE(cell.inlier_count, cell.area_px);
    // σ_Z = Z̄²·(t/√3)/(f·B) at the mean vertex depth Z̄.
    double z = 0.0;
    for (const auto& v : cell.vertices_m) z += v.z();
    z /= static_cast<double>(cell.vertices_m.size());
    const double sigma =
        z * z * (config_.inlier_threshold_px / std::sqrt(3.0)) / (scene_.camera.fx * scene_.camera.baseline_m);
    EXPECT_NEAR(cell.depth_sigma_m, sigma, 1e-4 * sigma + 1e-7) << "cell " << k;
  }
  EXPECT_GT(checked, 80);
}

TEST_P(PlanecellExtraction, NormalSigmaIsTheSpreadOfTheFittedNormals) {
  // The scene's disparity noise is independent per pixel (uniform ±t', σ = t'/√3), as the fit's
  // covariance s²·C⁻¹ assumes: each pure cell's normal error α against its region's exact plane
  // is one draw with E[α²] = σ_θ², so RMS(α / σ_θ) over the cells is ≈ 1. Without noise the
  // fit is exact and σ_θ ≈ 0.
  const bool noisy = GetParam().disparity_noise > 0.0;
  double sum_ratio2 = 0.0;
  int checked = 0;
  for (std::size_t k = 0; k < frame_.cells.size(); ++k) {
    const Planecell& cell = frame_.cells[k];
    const Region& truth = scene_.regions[majority_[k]];
    if (!truth.has_disparity || purity_[k] < 0.99 || cell.area_px < 150 || !cell.has_plane) continue;
    ++checked;
    if (!noisy) {
      EXPECT_LT(cell.normal_sigma_rad, 1e-4f) << "cell " << k;
      continue;
    }
    ASSERT_GT(cell.normal_sigma_rad, 0.0f) << "cell " << k;
    const Eigen::Vector3d exact = plane_from_disparity(truth.plane, scene_.camera).normal;
    const double alpha = std::acos(std::min(1.0, std::abs(exact.dot(cell.plane.normal))));
    const double ratio = alpha / cell.normal_sigma_rad;
    sum_ratio2 += ratio * ratio;
  }
  ASSERT_GT(checked, 80);
  if (noisy) {
    const double rms = std::sqrt(sum_ratio2 / checked);
    EXPECT_GT(rms, 0.8);
    EXPECT_LT(rms, 1.25);
  }
}

TEST_P(PlanecellExtraction, DenseDisparityIsAccurateWherePlanesExist) {
  ASSERT_EQ(frame_.dense_disparity.type(), CV_32F);
  int n = 0, within_1px = 0;
  double abs_error = 0.0;
  for (int v = 0; v < frame_.labels.rows; ++v)
    for (int u = 0; u < frame_.labels.cols; ++u) {
      const Region& truth = scene_.regions[scene_.region.at<int>(v, u)];
      if (!truth.has_disparity) continue;
      const float d = frame_.dense_disparity.at<float>(v, u);
      ASSERT_TRUE(std::isfinite(d)) << "hole at (" << u << ", " << v << ")";
      const double e = std::abs(d - truth.plane.at(u, v));
      abs_error += e;
      within_1px += e <= 1.0;
      ++n;
    }
  EXPECT_LT(abs_error / n, 0.3);
  EXPECT_GT(static_cast<double>(within_1px) / n, 0.99);
}

TEST_P(PlanecellExtraction, RegionWithoutDisparityIsPlaneless) {
  int sky_cells = 0, planeless = 0;
  for (std::size_t k = 0; k < frame_.cells.size(); ++k) {
    planeless += !frame_.cells[k].has_plane;
    if (majority_[k] != 3) continue;
    ++sky_cells;
    EXPECT_FALSE(frame_.cells[k].has_plane) << "sky cell " << k;
    EXPECT_TRUE(frame_.cells[k].vertices_m.empty());
  }
  EXPECT_GT(sky_cells, 3);
  EXPECT_DOUBLE_EQ(frame_.plane_fraction,
                   1.0 - static_cast<double>(planeless) / frame_.cells.size());
}

TEST_P(PlanecellExtraction, OutliersAreTheValidDisparitiesOffTheirCellPlane) {
  ASSERT_EQ(frame_.outliers.type(), CV_8U);
  ASSERT_EQ(frame_.outliers.size(), frame_.labels.size());
  int marked = 0;
  for (int v = 0; v < frame_.labels.rows; ++v)
    for (int u = 0; u < frame_.labels.cols; ++u) {
      const Planecell& cell = frame_.cells[frame_.labels.at<int>(v, u)];
      const float d = scene_.disparity.at<float>(v, u);
      const bool off = !std::isnan(d) && cell.has_plane &&
                       std::abs(cell.disparity_plane.at(u, v) - d) > config_.inlier_threshold_px;
      ASSERT_EQ(frame_.outliers.at<std::uint8_t>(v, u), off ? 255 : 0)
          << "pixel (" << u << ", " << v << ")";
      marked += off;
    }
  // Clean planes: only pixels at a cell that straddles a depth edge; never a large share.
  EXPECT_LT(marked, frame_.labels.total() / 20);
}

TEST_P(PlanecellExtraction, VerticesLieOnTheCellPlaneIn3D) {
  for (const Planecell& cell : frame_.cells) {
    if (!cell.has_plane) continue;
    ASSERT_EQ(cell.vertices_m.size(), cell.vertices_px.size());
    ASSERT_GE(cell.vertices_px.size(), 3u);
    for (std::size_t j = 0; j < cell.vertices_px.size(); ++j) {
      const Eigen::Vector3d x = cell.vertices_m[j].cast<double>();
      const Eigen::Vector2f& p = cell.vertices_px[j];
      EXPECT_NEAR(cell.plane.signed_distance(x), 0.0, 1e-4 * x.norm());
      const Eigen::Vector3d uvd = scene_.camera.project(x);
      EXPECT_NEAR(uvd.x(), p.x(), 1e-3);
      EXPECT_NEAR(uvd.y(), p.y(), 1e-3);
      EXPECT_NEAR(uvd.z(), cell.disparity_plane.at(p.x(), p.y()), 1e-3);
    }
  }
}

TEST_P(PlanecellExtraction, CellColourAndHistogramDescribeTheRegion) {
  for (std::size_t k = 0; k < frame_.cells.size(); ++k) {
    if (purity_[k] < 0.999) continue;
    const Planecell& cell = frame_.cells[k];
    const cv::Vec3b bgr = scene_.regions[majority_[k]].bgr;
    // Within one uniform region, cells split the noise by colour bin, so a cell's mean can be
    // biased — but never beyond the noise amplitude.
    const double tolerance = 1.0 + GetParam().colour_noise;
    EXPECT_NEAR(cell.mean_rgb.x(), bgr[2], tolerance);
    EXPECT_NEAR(cell.mean_rgb.y(), bgr[1], tolerance);
    EXPECT_NEAR(cell.mean_rgb.z(), bgr[0], tolerance);
    float sum = 0.0f;
    for (float h : cell.histogram) sum += h;
    EXPECT_NEAR(sum, 1.0f, 1e-4);
    // Soft binning is linear between the end levels' centres: the histogram's mean level of a
    // channel whose values all lie in [31.5, 223.5] is (mean value − 31.5) / 64.
    const int noise = GetParam().colour_noise;
    const int channel_of_rgb[3] = {2, 1, 0};  // R, G, B in the BGR region colour
    for (int c = 0; c < 3; ++c) {
      const int v = bgr[channel_of_rgb[c]];
      if (v - noise < 32 || v + noise > 223) continue;
      double level = 0.0;
      for (int q = 0; q < kColourHistogramBins; ++q) level += cell.histogram[q] * level_of_bin(q, c);
      EXPECT_NEAR(level, (cell.mean_rgb[c] - 31.5) / 64.0, 1e-4) << "cell " << k << " channel " << c;
    }
    // Without noise every pixel has the region's colour: the histogram is its trilinear weights.
    if (noise == 0) {
      for (int q = 0; q < kColourHistogramBins; ++q)
        EXPECT_NEAR(cell.histogram[q], soft_weight(bgr[2], bgr[1], bgr[0], q), 1e-6) << "cell " << k << " bin " << q;
    }
  }
}

/// A uniform colour a shade either side of a histogram level edge (127 and 129 on every channel)
/// gives nearly the same cell histogram, two colours a level apart share no bin: the CRF's
/// histogram intersection follows the colour, not where the bin edges fall.
TEST(PlanecellExtractionColour, HistogramsOfNearColoursOverlapAcrossALevelEdge) {
  const StereoCamera camera;
  const cv::Mat disparity(60, 80, CV_32F, cv::Scalar(8.0f));
  auto histogram_of = [&](int value) {
    const cv::Mat left(60, 80, CV_8UC3, cv::Scalar(value, value, value));
    const PlanecellFrame frame = extract_planecells(left, disparity, camera, {});
    EXPECT_FALSE(frame.cells.empty());
    return frame.cells.front().histogram;
  };
  // Per channel 127 → levels 1, 2 with weights 65/128, 63/128; 129 → 61/128, 67/128. Overlap per
  // channel (61 + 63) / 128; the bins are products, so the intersection is at least its cube.
  const double near = map::colour_similarity(histogram_of(127), histogram_of(129));
  EXPECT_GE(near, std::pow(124.0 / 128.0, 3) - 1e-6);
  EXPECT_LT(near, 1.0);
  // 64 → levels 0, 1 and 192 → levels 2, 3: no common bin.
  EXPECT_NEAR(map::colour_similarity(histogram_of(64), histogram_of(192)), 0.0, 1e-9);
}

TEST(PlanecellExtractionColour, SoftBinWeightsAreTheHandComputedOnes) {
  // 2v − 63 = 128·t before clamping; level lo gets 128 − (2v − 63 − 128·lo), lo + 1 the rest.
  struct Case {
    int v, lo;
    std::uint32_t w_lo, w_hi;
  };
  for (const Case& c : {Case{0, 0, 128, 0}, Case{31, 0, 128, 0}, Case{32, 0, 127, 1}, Case{95, 0, 1, 127},
                        Case{96, 1, 127, 1}, Case{127, 1, 65, 63}, Case{128, 1, 63, 65},
                        Case{223, 2, 1, 127}, Case{224, 2, 0, 128}, Case{255, 2, 0, 128}}) {
    const SoftBin& bin = soft_bin_table()[c.v];
    EXPECT_EQ(bin.lo, c.lo) << "v " << c.v;
    EXPECT_EQ(bin.w[0], c.w_lo) << "v " << c.v;
    EXPECT_EQ(bin.w[1], c.w_hi) << "v " << c.v;
  }
  for (int v = 0; v < 256; ++v) EXPECT_EQ(soft_bin_table()[v].w[0] + soft_bin_table()[v].w[1], kSoftBinUnit);
}

INSTANTIATE_TEST_SUITE_P(Scenes, PlanecellExtraction,
                         ::testing::Values(SceneOptions{"clean", 0, 0.0, 0.0},
                                           SceneOptions{"noisy_with_holes", 10, 0.4, 0.3}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(PlanecellExtractionInput, RejectsBadInputWithClearErrors) {
  const StereoCamera camera;
  const cv::Mat left(40, 60, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat disparity(40, 60, CV_32F, cv::Scalar(5.0f));
  EXPECT_THROW(extract_planecells(cv::Mat(), disparity, camera, {}), InputError);
  EXPECT_THROW(extract_planecells(left, cv::Mat(41, 60, CV_32F), camera, {}), InputError);
  EXPECT_THROW(extract_planecells(left, cv::Mat(40, 60, CV_16U), camera, {}), InputError);
  ExtractionConfig bad;
  bad.target_cells = 0;
  EXPECT_THROW(extract_planecells(left, disparity, camera, bad), ConfigError);
  try {
    extract_planecells(left, cv::Mat(41, 60, CV_32F), camera, {});
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("60x41"), std::string::npos) << e.what();
  }
  // A frontoparallel uniform frame: every cell gets the plane d = 5.
  ExtractionConfig few;
  few.target_cells = 6;
  const PlanecellFrame frame = extract_planecells(left, disparity, camera, few);
  ASSERT_FALSE(frame.cells.empty());
  for (const Planecell& cell : frame.cells) {
    ASSERT_TRUE(cell.has_plane);
    EXPECT_NEAR(cell.disparity_plane.at(30, 20), 5.0, 1e-6);
  }
  EXPECT_DOUBLE_EQ(frame.plane_fraction, 1.0);
}

}  // namespace
}  // namespace planecell::extraction
