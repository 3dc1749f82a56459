/// Matching cost of Eq. 1: Census Hamming distance + λ_grad · truncated gradient difference.
#include <sys/mman.h>

#include <cstdlib>
#include <new>
#include <opencv2/imgproc.hpp>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo::detail {

void* allocate_volume_bytes(std::size_t bytes) {
  constexpr std::size_t kHugePage = std::size_t{2} << 20;
  const std::size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
  void* p = std::aligned_alloc(kHugePage, std::max(rounded, kHugePage));
  if (p == nullptr) throw std::bad_alloc();
#if defined(MADV_HUGEPAGE)
  ::madvise(p, rounded, MADV_HUGEPAGE);  // a hint: failure only costs speed
#endif
  return p;
}

void free_volume_bytes(void* p) noexcept { std::free(p); }

namespace {

#if defined(__AVX2__)
/// C(p, d … d+15) of Eq. 1 in AVX2: Hamming distances by a nibble-table popcount summed per
/// 64-bit descriptor (psadbw), packed back into disparity order, plus the truncated and
/// weighted gradient difference; saturated to uint8.
inline void cost_block16(std::uint64_t census_l, const std::uint64_t* census_r, int grad_l,
                         const std::int16_t* grad_r, int cap, int lq4, std::uint8_t* out) {
  const __m256i nibble_count =
      _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4, 0, 1, 1, 2, 1, 2, 2, 3, 1,
                       2, 2, 3, 2, 3, 3, 4);
  const __m256i low4 = _mm256_set1_epi8(0x0F);
  const __m256i cl = _mm256_set1_epi64x(static_cast<long long>(census_l));
  __m256i counts[4];
  for (int k = 0; k < 4; ++k) {
    const __m256i x = _mm256_xor_si256(
        cl, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(census_r + 4 * k)));
    const __m256i lo = _mm256_shuffle_epi8(nibble_count, _mm256_and_si256(x, low4));
    const __m256i hi =
        _mm256_shuffle_epi8(nibble_count, _mm256_and_si256(_mm256_srli_epi16(x, 4), low4));
    counts[k] = _mm256_sad_epu8(_mm256_add_epi8(lo, hi), _mm256_setzero_si256());
  }
  // counts[k] holds d = 4k … 4k+3 as 64-bit lanes; two 32→16 packs give, per 128-bit half,
  // pairs (d0,d1),(d4,d5),(d8,d9),(d12,d13) | (d2,d3),(d6,d7),(d10,d11),(d14,d15).
  const __m256i p01 = _mm256_packus_epi32(counts[0], counts[1]);
  const __m256i p23 = _mm256_packus_epi32(counts[2], counts[3]);
  const __m256i mixed = _mm256_packus_epi32(p01, p23);
  const __m256i ham =
      _mm256_permutevar8x32_epi32(mixed, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
  const __m256i gr = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(grad_r));
  __m256i g = _mm256_abs_epi16(_mm256_sub_epi16(_mm256_set1_epi16(static_cast<short>(grad_l)), gr));
  g = _mm256_min_epi16(g, _mm256_set1_epi16(static_cast<short>(cap)));
  g = _mm256_srli_epi16(
      _mm256_add_epi16(_mm256_mullo_epi16(g, _mm256_set1_epi16(static_cast<short>(lq4))),
                       _mm256_set1_epi16(8)),
      4);
  const __m256i total = _mm256_min_epu16(_mm256_add_epi16(ham, g), _mm256_set1_epi16(255));
  const __m256i bytes = _mm256_permute4x64_epi64(_mm256_packus_epi16(total, total), 0x08);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(out), _mm256_castsi256_si128(bytes));
}
#endif

}  // namespace

cv::Mat epipolar_gradient(const cv::Mat& gray) {
  cv::Mat gradient;
  // Sobel x sums to 4·Δ for a step of Δ grey levels; scale 1/4 → grey levels per pixel.
  cv::Sobel(gray, gradient, CV_16S, 1, 0, 3, 0.25, 0.0, cv::BORDER_REPLICATE);
  return gradient;
}

std::vector<std::uint16_t> p2_table(const SgmConfig& c) {
  std::vector<std::uint16_t> table(256);
  for (int step = 0; step < 256; ++step) {
    const long p2 = c.p2_adaptive ? std::lround(c.p2 - c.p2_slope * step) : c.p2;
    table[static_cast<std::size_t>(step)] =
        static_cast<std::uint16_t>(std::max<long>(c.p1, std::min<long>(c.p2, p2)));
  }
  return table;
}

CostInputs cost_inputs(const CensusImage& census_l, const CensusImage& census_r,
                       const cv::Mat& gradient_l, const cv::Mat& gradient_r,
                       const SgmConfig& config) {
  CV_Assert(census_l.width == census_r.width && census_l.height == census_r.height);
  CV_Assert(gradient_l.type() == CV_16S && gradient_r.type() == CV_16S);
  CostInputs in;
  in.census_l = &census_l;
  in.census_r = &census_r;
  in.gradient_l = &gradient_l;
  in.gradient_r = &gradient_r;
  in.max_disparity = config.max_disparity;
  in.dp = padded_disparities(config.max_disparity);
  in.grad_cap = config.grad_cap;
  in.lambda_q4 = lambda_q4(config.lambda_grad);
  in.out_of_image = static_cast<std::uint8_t>(out_of_image_cost(config));
  in.padding = static_cast<std::uint8_t>(largest_cost(config));
  return in;
}

/// Reversed rows padded by D_p + 64 zero entries: a kernel may read one 64-lane block past D_p.
void ReversedRightRow::load(const CostInputs& in, int row) {
  y = row;
  const int width = in.census_r->width;
  const std::size_t length = static_cast<std::size_t>(width + in.dp + 64);
  if (census.size() != length) {
    census.assign(length, 0);
    gradient.assign(length, 0);
  }
  const std::uint64_t* c = in.census_r->bits.data() + static_cast<std::size_t>(y) * width;
  const std::int16_t* g = in.gradient_r->ptr<std::int16_t>(y);
  for (int j = 0; j < width; ++j) {
    census[static_cast<std::size_t>(j)] = c[width - 1 - j];
    gradient[static_cast<std::size_t>(j)] = g[width - 1 - j];
  }
}

/// C(x, y, d) for x ∈ [x_begin, x_end), [x][d]: the match q = x − d is entry W − 1 − x + d of
/// the reversed right row.
void cost_row(const CostInputs& in, const ReversedRightRow& right, int x_begin, int x_end,
              std::uint8_t* out) {
  const int y = right.y;
  const int width = in.census_l->width, dp = in.dp, d_max = in.max_disparity;
  const int cap = in.grad_cap, lq4 = in.lambda_q4;  // copies: no aliasing with the uint8 stores
  const std::uint8_t out_of_image = in.out_of_image, padding = in.padding;
  const std::uint64_t* census_l = in.census_l->bits.data() + static_cast<std::size_t>(y) * width;
  const std::int16_t* gl = in.gradient_l->ptr<std::int16_t>(y);
  for (int x = x_begin; x < x_end; ++x) {
    std::uint8_t* c = out + static_cast<std::size_t>(x - x_begin) * dp;
    const int valid = std::min(d_max, x + 1);  // q = x − d ≥ 0
    const std::uint64_t cl = census_l[x];
    const std::uint64_t* cr = right.census.data() + (width - 1 - x);
    const std::int16_t* g_r = right.gradient.data() + (width - 1 - x);
    const int g_l = gl[x];
#if defined(__AVX2__)
    // Whole blocks (reads past the row stay inside the padded reversed rows); the lanes
    // d ≥ valid are overwritten below.
    for (int d = 0; d < valid; d += 16) cost_block16(cl, cr + d, g_l, g_r + d, cap, lq4, c + d);
#else
    for (int d = 0; d < valid; ++d) {
      const int g = std::min(std::abs(g_l - g_r[d]), cap);
      c[d] = static_cast<std::uint8_t>(
          std::min(255, std::popcount(cl ^ cr[d]) + ((g * lq4 + 8) >> 4)));
    }
#endif
    for (int d = valid; d < d_max; ++d) c[d] = out_of_image;
    for (int d = std::max(valid, d_max); d < dp; ++d) c[d] = padding;
  }
}

}  // namespace planecell::stereo::detail
