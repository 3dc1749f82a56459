/// SGM stage (paper Eq. 1–2): the fast path against the scalar reference, and both against
/// rendered scenes with exactly known disparity.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <random>

#include "core/error.hpp"
#include "mapping/stereo/sgm.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo {
namespace {

/// A smooth random texture (uniform noise, Gaussian-blurred) larger than the views.
cv::Mat random_texture(int width, int height, std::uint32_t seed, double blur_sigma = 1.0) {
  cv::Mat noise(height, width, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 255.0);
  if (blur_sigma > 0) cv::GaussianBlur(noise, noise, cv::Size(0, 0), blur_sigma);
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  return noise;
}

/// A rendered stereo pair: right(x, y) = T(x, y); left(x, y) = T(x − d(x, y), y) for the
/// disparity field d (bilinear sampling), so the true left disparity is d exactly.
struct RenderedPair {
  cv::Mat left, right;  // CV_8UC1
  cv::Mat truth;        // CV_32F, NaN where the match falls outside the right image
};

constexpr int kMargin = 8;  // texture columns left of the right view (keeps samples inside)

RenderedPair render(int width, int height, const std::function<float(int, int)>& disparity,
                    std::uint32_t seed) {
  const cv::Mat texture = random_texture(width + 2 * kMargin, height, seed);
  cv::Mat map_x(height, width, CV_32F), map_y(height, width, CV_32F);
  RenderedPair pair;
  pair.truth.create(height, width, CV_32F);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float d = disparity(x, y);
      map_x.at<float>(y, x) = static_cast<float>(x + kMargin) - d;
      map_y.at<float>(y, x) = static_cast<float>(y);
      pair.truth.at<float>(y, x) = x - d >= 0 ? d : std::numeric_limits<float>::quiet_NaN();
    }
  cv::Mat left_f, right_f;
  cv::remap(texture, left_f, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  texture(cv::Rect(kMargin, 0, width, height)).copyTo(right_f);
  left_f.convertTo(pair.left, CV_8U);
  right_f.convertTo(pair.right, CV_8U);
  return pair;
}

/// Fraction of pixels with known truth whose estimate is within `tolerance_px` (NaN = miss).
double fraction_correct(const cv::Mat& estimate, const cv::Mat& truth, float tolerance_px,
                        int skip_left_px = 0) {
  int total = 0, good = 0;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = skip_left_px; x < truth.cols; ++x) {
      const float t = truth.at<float>(y, x);
      if (std::isnan(t)) continue;
      ++total;
      const float e = estimate.at<float>(y, x);
      if (!std::isnan(e) && std::abs(e - t) <= tolerance_px) ++good;
    }
  return total == 0 ? 0.0 : static_cast<double>(good) / total;
}

bool same_maps(const cv::Mat& a, const cv::Mat& b, int* mismatches) {
  *mismatches = 0;
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x) {
      const float u = a.at<float>(y, x), v = b.at<float>(y, x);
      const bool same = (std::isnan(u) && std::isnan(v)) || u == v;
      if (!same) ++*mismatches;
    }
  return *mismatches == 0;
}

// ---- fast path (SIMD, row buffers, 2 threads) vs scalar reference ---------------------------

struct Variant {
  int max_disparity;
  int paths;
  int threads;
  bool adaptive_p2;
  int census_w, census_h;
  int p2 = SgmConfig{}.p2;
  int uniqueness_ratio = SgmConfig{}.uniqueness_ratio;
};

class SgmVsReference : public ::testing::TestWithParam<Variant> {};

TEST_P(SgmVsReference, BitExactOnRandomImages) {
  const Variant v = GetParam();
  SgmConfig config;
  config.max_disparity = v.max_disparity;
  config.paths = v.paths;
  config.threads = v.threads;
  config.p2_adaptive = v.adaptive_p2;
  config.census_width = v.census_w;
  config.census_height = v.census_h;
  config.p2 = v.p2;
  config.uniqueness_ratio = v.uniqueness_ratio;
  // Pure noise (no scene) and a shifted texture (a real match), both 96×64.
  cv::Mat noise_l(64, 96, CV_8UC1), noise_r(64, 96, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(noise_l, cv::RNG::UNIFORM, 0, 256);
  rng.fill(noise_r, cv::RNG::UNIFORM, 0, 256);
  const auto scene = render(96, 64, [](int x, int) { return 6.0f + 0.05f * x; }, 11);
  for (const bool is_scene : {false, true}) {
    const cv::Mat& l = is_scene ? scene.left : noise_l;
    const cv::Mat& r = is_scene ? scene.right : noise_r;
    const cv::Mat fast = compute_disparity(l, r, config);
    const cv::Mat reference = compute_disparity_reference(l, r, config);
    ASSERT_EQ(fast.type(), CV_32F);
    ASSERT_EQ(fast.size(), l.size());
    int mismatches = 0;
    EXPECT_TRUE(same_maps(fast, reference, &mismatches)) << mismatches << " pixels differ";
    // On the scene the comparison is not vacuous: most pixels are valid (pure noise may
    // legitimately be rejected everywhere by the uniqueness and left-right checks).
    if (is_scene) {
      EXPECT_GT(cv::countNonZero(fast == fast), 96 * 64 / 2);
    }
    // Every aggregation kernel this machine runs gives the reference's result.
    using detail::AggregationKernel;
    for (const auto kernel :
         {AggregationKernel::portable, AggregationKernel::avx2, AggregationKernel::avx512}) {
      if (!detail::aggregation_kernel_supported(kernel)) continue;
      const cv::Mat with_kernel = detail::compute_disparity_with(l, r, config, kernel);
      int kernel_mismatches = 0;
      EXPECT_TRUE(same_maps(with_kernel, reference, &kernel_mismatches))
          << "kernel " << static_cast<int>(kernel) << ": " << kernel_mismatches
          << " pixels differ";
    }
  }
}

// The SIMD kernels keep uint8 row buffers when the largest cost + P2 ≤ 255 (AVX2 also needs D_p a
// multiple of 32) and uint16 ones otherwise: P2 = 250 (with 9×7 census: 77 + 250) and, for AVX2,
// D = 37, 40, 48 take the uint16 paths, the others the uint8 ones.
INSTANTIATE_TEST_SUITE_P(
    Variants, SgmVsReference,
    ::testing::Values(Variant{32, 8, 1, true, 9, 7}, Variant{64, 8, 2, true, 9, 7},
                      Variant{64, 4, 2, false, 5, 5}, Variant{40, 8, 2, false, 5, 5},
                      Variant{23, 4, 1, true, 9, 7}, Variant{48, 8, 2, true, 9, 7},
                      Variant{64, 8, 1, true, 9, 7, 250}, Variant{40, 4, 2, false, 9, 7, 250},
                      Variant{48, 8, 2, true, 9, 7, 120, 5},
                      Variant{37, 8, 1, false, 5, 5, 250, 10}),
    [](const auto& info) {
      const Variant& v = info.param;
      return "D" + std::to_string(v.max_disparity) + "_paths" + std::to_string(v.paths) + "_t" +
             std::to_string(v.threads) + (v.adaptive_p2 ? "_adaptiveP2" : "_fixedP2") + "_census" +
             std::to_string(v.census_w) + "x" + std::to_string(v.census_h) + "_P2_" +
             std::to_string(v.p2) + "_unique" + std::to_string(v.uniqueness_ratio);
    });

TEST(SgmKernels, BothRowBufferWidthsAreCoveredByTheVariants) {
  SgmConfig narrow;
  EXPECT_TRUE(detail::narrow_entries_fit(narrow));
  SgmConfig wide;
  wide.p2 = 250;
  EXPECT_FALSE(detail::narrow_entries_fit(wide));
}

/// Every cost-row kernel the machine runs gives matching_cost (Eq. 1) for every pixel and
/// disparity, out_of_image_cost left of the right image and largest_cost for the padding d ≥ D
/// (d_max 37 and 100 have padding lanes; 16 … 128 with the out-of-image shares below). Each image is
/// 150 px wide so that the left border (x < D) and whole-row chunks are both covered.
TEST(SgmKernels, CostRowsMatchTheScalarFormula) {
  cv::Mat left(9, 150, CV_8UC1), right(9, 150, CV_8UC1);
  cv::RNG rng(3);
  rng.fill(left, cv::RNG::UNIFORM, 0, 256);
  rng.fill(right, cv::RNG::UNIFORM, 0, 256);
  for (const int d_max : {16, 37, 64, 100, 128}) {
    for (const auto& [lambda, cap] : {std::pair{0.5, 30}, std::pair{8.0, 30}, std::pair{1.5, 63},
                                      std::pair{0.75, 200}}) {
     for (const double share : {0.0, 0.3, 1.0}) {
      SgmConfig c;
      c.max_disparity = d_max;
      c.lambda_grad = lambda;  // 8: the gradient term alone saturates the uint8 cost
      c.grad_cap = cap;
      c.out_of_image_cost = share;
      const auto census_l = detail::census_transform(left, 9, 7, 1);
      const auto census_r = detail::census_transform(right, 9, 7, 1);
      const cv::Mat grad_l = detail::epipolar_gradient(left);
      const cv::Mat grad_r = detail::epipolar_gradient(right);
      const auto in = detail::cost_inputs(census_l, census_r, grad_l, grad_r, c);
      std::vector<detail::CostRowFunction> kernels = {&detail::cost_row};
      if (detail::cost_row_avx512_supported()) kernels.push_back(&detail::cost_row_avx512);
      for (const auto kernel : kernels) {
        std::vector<std::uint8_t> row(static_cast<std::size_t>(left.cols) * in.dp, 0);
        detail::ReversedRightRow right_row;
        int mismatches = 0, saturated = 0;
        for (int y = 0; y < left.rows; ++y) {
          right_row.load(in, y);
          // In chunks of 37 pixels, as the passes ask for them (a chunk starts at out).
          for (int x0 = 0; x0 < left.cols; x0 += 37)
            kernel(in, right_row, x0, std::min(left.cols, x0 + 37),
                   row.data() + static_cast<std::size_t>(x0) * in.dp);
          for (int x = 0; x < left.cols; ++x)
            for (int d = 0; d < in.dp; ++d) {
              const int expected =
                  d >= d_max  ? detail::largest_cost(c)
                  : x - d < 0 ? detail::out_of_image_cost(c)
                      : detail::matching_cost(census_l.at(x, y), census_r.at(x - d, y),
                                              grad_l.at<std::int16_t>(y, x),
                                              grad_r.at<std::int16_t>(y, x - d), c.grad_cap,
                                              detail::lambda_q4(c.lambda_grad));
              const int got = row[static_cast<std::size_t>(x) * in.dp + d];
              mismatches += got != expected ? 1 : 0;
              saturated += expected == 255 ? 1 : 0;
            }
        }
        EXPECT_EQ(mismatches, 0) << "D " << d_max << " lambda " << lambda << " cap " << cap << " share " << share << " kernel "
                                 << (kernel == &detail::cost_row ? "baseline" : "avx512");
        if (detail::largest_cost(c) == 255) {  // the saturation is exercised
          EXPECT_GT(saturated, 0);
        }
      }
     }
    }
  }
}

/// The census descriptor against its definition (bit w·h − 2 − k set when the k-th window
/// pixel, row-major without the centre, is darker than the centre; clamped border).
TEST(SgmKernels, CensusMatchesItsDefinition) {
  cv::Mat image(23, 77, CV_8UC1);
  cv::RNG rng(5);
  rng.fill(image, cv::RNG::UNIFORM, 0, 8);  // few grey levels: many ties (not darker)
  for (const auto& [w, h] : {std::pair{9, 7}, std::pair{5, 5}, std::pair{3, 3}, std::pair{13, 5}}) {
    const auto census = detail::census_transform(image, w, h, 2);
    int mismatches = 0;
    for (int y = 0; y < image.rows; ++y)
      for (int x = 0; x < image.cols; ++x) {
        std::uint64_t bits = 0;
        for (int dy = -h / 2; dy <= h / 2; ++dy)
          for (int dx = -w / 2; dx <= w / 2; ++dx) {
            if (dx == 0 && dy == 0) continue;
            const int qx = std::clamp(x + dx, 0, image.cols - 1);
            const int qy = std::clamp(y + dy, 0, image.rows - 1);
            bits = (bits << 1) | (image.at<std::uint8_t>(qy, qx) < image.at<std::uint8_t>(y, x));
          }
        mismatches += census.at(x, y) != bits ? 1 : 0;
      }
    EXPECT_EQ(mismatches, 0) << w << "x" << h;
  }
}

// ---- rendered scenes with known disparity ---------------------------------------------------

class SgmScene : public ::testing::TestWithParam<int /*paths*/> {
 protected:
  SgmConfig config() const {
    SgmConfig c;
    c.max_disparity = 48;
    c.paths = GetParam();
    return c;
  }
};

TEST_P(SgmScene, FrontoParallelIntegerShift) {
  const auto pair = render(160, 96, [](int, int) { return 13.0f; }, 3);
  const cv::Mat d = compute_disparity(pair.left, pair.right, config());
  EXPECT_GE(fraction_correct(d, pair.truth, 0.25f), 0.95);
}

TEST_P(SgmScene, FrontoParallelSubpixelShift) {
  const auto pair = render(160, 96, [](int, int) { return 17.5f; }, 4);
  const cv::Mat d = compute_disparity(pair.left, pair.right, config());
  EXPECT_GE(fraction_correct(d, pair.truth, 0.5f), 0.95);
  // Sub-pixel refinement moves estimates off the integers towards 17.5.
  cv::Mat no_subpixel_cfg_result;
  {
    SgmConfig c = config();
    c.subpixel = false;
    no_subpixel_cfg_result = compute_disparity(pair.left, pair.right, c);
  }
  double err_sub = 0, err_int = 0;
  int n = 0;
  for (int y = 0; y < d.rows; ++y)
    for (int x = 20; x < d.cols; ++x) {
      const float a = d.at<float>(y, x), b = no_subpixel_cfg_result.at<float>(y, x);
      if (std::isnan(a) || std::isnan(b)) continue;
      err_sub += std::abs(a - 17.5f);
      err_int += std::abs(b - 17.5f);
      ++n;
    }
  ASSERT_GT(n, 1000);
  EXPECT_LT(err_sub / n, 0.8 * err_int / n);
}

/// The left border strip x < d has no match in the right image. Its out-of-image disparities
/// (d > x) cost SgmConfig::out_of_image_cost · C_max: at the default share (neutral, about an
/// ordinary match) the strip keeps the plane's disparity, which falls outside the image and is
/// reported invalid, and the columns beside it are right. At C_max (share 1, the former cost)
/// the paths force the strip onto the few disparities still inside the image: false matches.
/// (Without the left-right check and speckle filter, which hide part of them afterwards.)
TEST_P(SgmScene, LeftBorderStripIsNotForcedOntoDisparitiesInsideTheImage) {
  constexpr float kD = 28.0f;
  const auto pair = render(160, 80, [](int, int) { return kD; }, 6);
  const auto false_matches_in_strip = [&](const cv::Mat& d) {
    int n = 0;
    for (int y = 0; y < d.rows; ++y)
      for (int x = 0; x < static_cast<int>(kD); ++x) n += std::isnan(d.at<float>(y, x)) ? 0 : 1;
    return n;
  };
  SgmConfig neutral = config();
  neutral.lr_check = false;
  neutral.speckle_window_size = 0;
  SgmConfig largest = neutral;
  largest.out_of_image_cost = 1.0;
  const cv::Mat with_neutral = compute_disparity(pair.left, pair.right, neutral);
  const cv::Mat with_largest = compute_disparity(pair.left, pair.right, largest);
  const int strip = static_cast<int>(kD) * pair.left.rows;
  const int neutral_false = false_matches_in_strip(with_neutral);
  const int largest_false = false_matches_in_strip(with_largest);
  EXPECT_LE(neutral_false, 0.1 * strip);   // measured 98 (8 paths) and 115 (4) of 2240
  EXPECT_GE(largest_false, 0.9 * strip);   // measured: all 2240
  EXPECT_GE(fraction_correct(with_neutral, pair.truth, 1.0f), 0.97);
}

TEST_P(SgmScene, SlantedPlane) {
  // d = 8 + 0.12 x + 0.05 y: from 8 px at the top-left to ~31 px at the bottom-right.
  const auto pair = render(160, 96, [](int x, int y) { return 8.0f + 0.12f * x + 0.05f * y; }, 5);
  const cv::Mat d = compute_disparity(pair.left, pair.right, config());
  EXPECT_GE(fraction_correct(d, pair.truth, 1.0f), 0.95);
}

TEST_P(SgmScene, LeftRightCheckInvalidatesOccludedStrip) {
  // Background at 8 px, a foreground band at 20 px for right-image columns [a, b): left pixels
  // x ∈ [a + 8, a + 20) see background that the foreground hides in the right view.
  constexpr int kA = 60, kB = 110;
  constexpr float kBack = 8.0f, kFront = 20.0f;
  const int width = 180, height = 80;
  const cv::Mat back = random_texture(width + 2 * kMargin, height, 21);
  const cv::Mat front = random_texture(width + 2 * kMargin, height, 22);
  cv::Mat left(height, width, CV_8UC1), right(height, width, CV_8UC1), truth(height, width, CV_32F);
  cv::Mat occluded(height, width, CV_8UC1, cv::Scalar(0));
  auto sample = [](const cv::Mat& t, int x, int y) {
    return cv::saturate_cast<std::uint8_t>(t.at<float>(y, x + kMargin));
  };
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const bool r_front = x >= kA && x < kB;
      right.at<std::uint8_t>(y, x) = r_front ? sample(front, x, y) : sample(back, x, y);
      const int xf = x - static_cast<int>(kFront), xb = x - static_cast<int>(kBack);
      const bool l_front = xf >= kA && xf < kB;
      left.at<std::uint8_t>(y, x) = l_front ? sample(front, xf, y) : sample(back, xb, y);
      const bool hidden = !l_front && xb >= kA && xb < kB;
      occluded.at<std::uint8_t>(y, x) = hidden ? 255 : 0;
      truth.at<float>(y, x) = (hidden || xb < 0) ? std::numeric_limits<float>::quiet_NaN()
                                                  : (l_front ? kFront : kBack);
    }
  ASSERT_EQ(cv::countNonZero(occluded), 12 * height);
  SgmConfig with_check = config();
  with_check.uniqueness_ratio = 0;
  with_check.speckle_window_size = 0;
  SgmConfig without_check = with_check;
  without_check.lr_check = false;
  const cv::Mat checked = compute_disparity(left, right, with_check);
  const cv::Mat unchecked = compute_disparity(left, right, without_check);
  int strip = 0, invalid_checked = 0, invalid_unchecked = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      if (!occluded.at<std::uint8_t>(y, x)) continue;
      ++strip;
      invalid_checked += std::isnan(checked.at<float>(y, x)) ? 1 : 0;
      invalid_unchecked += std::isnan(unchecked.at<float>(y, x)) ? 1 : 0;
    }
  EXPECT_GE(invalid_checked, 0.8 * strip);
  EXPECT_LE(invalid_unchecked, 0.1 * strip);
  // The visible pixels keep their (correct) disparity.
  EXPECT_GE(fraction_correct(checked, truth, 1.0f), 0.9);
}

/// A textured slanted plane with sensor noise on both images: the 3×3 median of the winners
/// (SgmConfig::median_filter) must leave more pixels within 1 px of the truth than no median,
/// both by keeping correct pixels the left-right check would drop and by replacing outliers.
TEST_P(SgmScene, MedianOfTheWinnersLeavesMoreCorrectPixelsOnANoisyPair) {
  auto pair = render(200, 120, [](int x, int y) { return 10.0f + 0.08f * x + 0.04f * y; }, 7);
  cv::RNG rng(11);
  for (cv::Mat* image : {&pair.left, &pair.right}) {
    cv::Mat noise(image->size(), CV_16S);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 12.0);
    cv::Mat noisy;
    cv::add(*image, noise, noisy, cv::noArray(), CV_8U);
    *image = noisy;
  }
  SgmConfig with_median = config();
  SgmConfig without_median = with_median;
  without_median.median_filter = false;
  const double with = fraction_correct(compute_disparity(pair.left, pair.right, with_median),
                                       pair.truth, 1.0f);
  const double without = fraction_correct(
      compute_disparity(pair.left, pair.right, without_median), pair.truth, 1.0f);
  EXPECT_GT(with, without + 0.01) << "with median " << with << ", without " << without;
}

INSTANTIATE_TEST_SUITE_P(Paths, SgmScene, ::testing::Values(8, 4),
                         [](const auto& info) { return std::to_string(info.param) + "paths"; });

/// filter_winners on hand-made winner maps (one row band of 7 × 40, every true disparity 5).
class FilterWinners : public ::testing::Test {
 protected:
  static constexpr int kWidth = 40, kHeight = 7, kTrue = 5;
  detail::Winners winners{kWidth, kHeight};
  void SetUp() override {
    winners.disparity.setTo(static_cast<float>(kTrue) + 0.25f);
    winners.left.setTo(kTrue);
    winners.right.setTo(kTrue);
  }
  /// A deep copy, for running filter_winners (which filters in place) twice on one input.
  detail::Winners copy() const {
    detail::Winners out{kWidth, kHeight};
    winners.disparity.copyTo(out.disparity);
    winners.left.copyTo(out.left);
    winners.right.copyTo(out.right);
    return out;
  }
  SgmConfig config(bool median) const {
    SgmConfig c;
    c.median_filter = median;
    c.lr_max_diff_px = 2;
    return c;
  }
};

TEST_F(FilterWinners, MatchesLeftOfTheRightImageAreInvalid) {
  const cv::Mat d = detail::filter_winners(winners, config(false));
  for (int x = 0; x < kWidth; ++x)
    EXPECT_EQ(std::isnan(d.at<float>(3, x)), x < kTrue) << x;  // x − d < 0
}

TEST_F(FilterWinners, AnIsolatedWrongLeftWinnerIsRejectedWithoutMedianAndReplacedWithIt) {
  // Left pixel (3, 30) wins d = 20: its right pixel 10 wins 5, |20 − 5| > 2.
  winners.left.at<std::uint16_t>(3, 30) = 20;
  winners.disparity.at<float>(3, 30) = 20.0f;
  detail::Winners copied = copy();
  const cv::Mat without = detail::filter_winners(winners, config(false));
  EXPECT_TRUE(std::isnan(without.at<float>(3, 30)));
  const cv::Mat with = detail::filter_winners(copied, config(true));
  EXPECT_FLOAT_EQ(with.at<float>(3, 30), kTrue + 0.25f);  // median of its 3×3 neighbourhood
}

TEST_F(FilterWinners, AnIsolatedWrongRightWinnerNoLongerRejectsACorrectPixel) {
  // Right pixel (3, 20) wins d = 12: left pixel 25 (d = 5) fails the check without the median.
  winners.right.at<std::uint16_t>(3, 20) = 12;
  detail::Winners copied = copy();
  const cv::Mat without = detail::filter_winners(winners, config(false));
  EXPECT_TRUE(std::isnan(without.at<float>(3, 25)));
  EXPECT_EQ(cv::countNonZero(without(cv::Rect(kTrue, 0, kWidth - kTrue, kHeight)) ==
                             without(cv::Rect(kTrue, 0, kWidth - kTrue, kHeight))),
            (kWidth - kTrue) * kHeight - 1);
  const cv::Mat with = detail::filter_winners(copied, config(true));
  EXPECT_FLOAT_EQ(with.at<float>(3, 25), kTrue + 0.25f);
}

TEST_F(FilterWinners, ABandOfOccludedPixelsSurvivesTheMedianAndIsRejected) {
  // Columns 20–23 of every row claim d = 12, inconsistent with the right winners (5): a band
  // 4 px wide, not an isolated outlier, so the median keeps it and the check rejects it.
  for (int y = 0; y < kHeight; ++y)
    for (int x = 20; x < 24; ++x) {
      winners.left.at<std::uint16_t>(y, x) = 12;
      winners.disparity.at<float>(y, x) = 12.0f;
    }
  const cv::Mat d = detail::filter_winners(winners, config(true));
  for (int x = 21; x < 23; ++x) EXPECT_TRUE(std::isnan(d.at<float>(3, x))) << x;
  EXPECT_FLOAT_EQ(d.at<float>(3, 10), kTrue + 0.25f);
}

TEST_F(FilterWinners, APixelRejectedAsNotUniqueStaysRejectedAndDoesNotSpread) {
  // Only the uniqueness test leaves NaN in the winners.
  SgmConfig c = config(true);
  c.uniqueness_ratio = 10;
  winners.disparity.at<float>(3, 30) = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat d = detail::filter_winners(winners, c);
  EXPECT_TRUE(std::isnan(d.at<float>(3, 30)));
  for (int x = 29; x <= 31; x += 2) EXPECT_FLOAT_EQ(d.at<float>(3, x), kTrue + 0.25f) << x;
  EXPECT_FLOAT_EQ(d.at<float>(2, 30), kTrue + 0.25f);
}

TEST(Sgm, ColourAndGreyInputGiveTheSameDisparity) {
  const auto pair = render(120, 64, [](int, int) { return 9.0f; }, 8);
  cv::Mat left_bgr, right_bgr;
  cv::cvtColor(pair.left, left_bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(pair.right, right_bgr, cv::COLOR_GRAY2BGR);
  SgmConfig c;
  c.max_disparity = 32;
  int mismatches = 0;
  EXPECT_TRUE(same_maps(compute_disparity(pair.left, pair.right, c),
                        compute_disparity(left_bgr, right_bgr, c), &mismatches));
}

// ---- bad input ------------------------------------------------------------------------------

TEST(SgmBadInput, ThrowsClearErrors) {
  const cv::Mat image(40, 64, CV_8UC1, cv::Scalar(100));
  SgmConfig c;
  c.max_disparity = 16;
  EXPECT_THROW(compute_disparity(cv::Mat(), image, c), InputError);
  EXPECT_THROW(compute_disparity(image, cv::Mat(), c), InputError);
  EXPECT_THROW(compute_disparity(image, cv::Mat(40, 63, CV_8UC1), c), InputError);
  EXPECT_THROW(compute_disparity(image, cv::Mat(40, 64, CV_32F), c), InputError);
  try {
    compute_disparity(image, cv::Mat(41, 64, CV_8UC1), c);
    FAIL() << "size mismatch not detected";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("64x40 vs 64x41"), std::string::npos) << e.what();
  }
  for (int bad_d : {0, -3, 64, 100}) {
    SgmConfig bad = c;
    bad.max_disparity = bad_d;
    EXPECT_THROW(compute_disparity(image, image, bad), ConfigError) << bad_d;
  }
  SgmConfig bad = c;
  bad.p2 = 9000;
  EXPECT_THROW(compute_disparity(image, image, bad), ConfigError);
  bad = c;
  bad.census_width = 8;
  EXPECT_THROW(compute_disparity(image, image, bad), ConfigError);
  bad = c;
  bad.paths = 6;
  EXPECT_THROW(compute_disparity(image, image, bad), ConfigError);
  for (const double share : {-0.1, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
    bad = c;
    bad.out_of_image_cost = share;
    try {
      compute_disparity(image, image, bad);
      ADD_FAILURE() << "out_of_image_cost " << share << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("sgm.out_of_image_cost"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace planecell::stereo
