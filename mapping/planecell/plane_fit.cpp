/// Plane function estimation (paper §4.4): RANSAC + least squares per segment, on lanes of
/// kSampleLane samples (Eigen fixed-size arrays: one AVX register of floats, two of doubles).
#include "mapping/planecell/plane_fit.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction {
namespace {

/// RANSAC scores hypotheses in float lanes; the least squares and the final inlier count, which
/// decide the plane, run in double lanes (the samples are stored as float).
template <class Scalar>
using Lane = Eigen::Array<Scalar, kSampleLane, 1>;

template <class Scalar>
[[gnu::always_inline]] inline Lane<Scalar> load(const float* p) {
  return Lane<float>::Map(p).template cast<Scalar>();
}

/// Hypotheses are scored on at most this many samples; the final count uses all of them.
constexpr int kScoringSamples = 96;
static_assert(kScoringSamples % kSampleLane == 0);

/// A plane around the origin (u0, v0) of the fit: d = a·(u − u0) + b·(v − v0) + c.
struct LocalPlane {
  double a = 0.0, b = 0.0, c = 0.0;
};

/// The fit's frame: samples are read relative to (u0, v0), which keeps float sums well
/// conditioned wherever the segment lies in the image.
struct Origin {
  float u0 = 0.0f, v0 = 0.0f;
};

/// Plane through three local (u, v, d) samples; false when they are (nearly) collinear in the
/// image.
bool plane_through(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& r,
                   LocalPlane& out) {
  const double u1 = q.x() - p.x(), v1 = q.y() - p.y(), d1 = q.z() - p.z();
  const double u2 = r.x() - p.x(), v2 = r.y() - p.y(), d2 = r.z() - p.z();
  const double det = u1 * v2 - u2 * v1;  // twice the triangle's image area (px²)
  if (std::abs(det) < 1.0) return false;
  out.a = (d1 * v2 - d2 * v1) / det;
  out.b = (u1 * d2 - u2 * d1) / det;
  out.c = p.z() - out.a * p.x() - out.b * p.y();
  return true;
}

/// 1 where |θ(p) − d(p)| ≤ threshold, else 0, for the lane of samples starting at k (always
/// inlined: it is the body of every sample loop).
template <class Scalar>
[[gnu::always_inline]] inline Lane<Scalar> inlier_lane(const SampleLanes& s, int k, const Origin& o,
                                                       const LocalPlane& p, Scalar threshold) {
  const auto a = static_cast<Scalar>(p.a), b = static_cast<Scalar>(p.b);
  const auto c = static_cast<Scalar>(p.c);
  const Lane<Scalar> residual = a * (load<Scalar>(s.u + k) - static_cast<Scalar>(o.u0)) +
                                b * (load<Scalar>(s.v + k) - static_cast<Scalar>(o.v0)) + c -
                                load<Scalar>(s.d + k);
  return (residual.abs() <= threshold).select(Lane<Scalar>::Ones(), Lane<Scalar>::Zero());
}

/// Number of samples with |θ(p) − d(p)| ≤ threshold (padding never counts).
template <class Scalar>
int count_inliers(const SampleLanes& s, const Origin& o, const LocalPlane& p, double threshold) {
  Lane<Scalar> count = Lane<Scalar>::Zero();
  for (int k = 0; k < s.padded_count(); k += kSampleLane)
    count += inlier_lane<Scalar>(s, k, o, p, static_cast<Scalar>(threshold));
  return static_cast<int>(count.sum());  // exact: integers far below 2²⁴
}

/// One pass over the lanes: the inliers of `plane` (|r| ≤ threshold, r = θ(p) − d(p)) with their
/// means (ū, v̄, d̄; disparities relative to plane.c, which keeps the sums well conditioned), centred
/// moments C_xy = Σ (x − x̄)(y − ȳ) and residual sum of squares Σ r². Means and moments are zero
/// without inliers.
struct InlierSums {
  double count = 0.0;
  double mean_u = 0.0, mean_v = 0.0, mean_d = 0.0;
  double cuu = 0.0, cuv = 0.0, cvv = 0.0, cud = 0.0, cvd = 0.0;
  double residual_ss = 0.0;
};

InlierSums inlier_sums(const SampleLanes& s, const Origin& o, const LocalPlane& plane, double threshold) {
  using L = Lane<double>;
  const double d0 = plane.c;
  L n = L::Zero(), su = n, sv = n, sd = n, suu = n, suv = n, svv = n, sud = n, svd = n, srr = n;
  for (int k = 0; k < s.padded_count(); k += kSampleLane) {
    const L u = load<double>(s.u + k) - o.u0, v = load<double>(s.v + k) - o.v0;
    const L r = plane.a * u + plane.b * v + plane.c - load<double>(s.d + k);
    const L m = (r.abs() <= threshold).select(L::Ones(), L::Zero());
    const L d = m * (load<double>(s.d + k) - d0);  // 0 on outliers and padding
    const L mu = m * u, mv = m * v;
    n += m;
    su += mu;
    sv += mv;
    sd += d;
    suu += mu * u;
    suv += mu * v;
    svv += mv * v;
    sud += mu * d;
    svd += mv * d;
    srr += m * r * r;
  }
  InlierSums out;
  out.count = n.sum();
  if (out.count <= 0.0) return out;
  out.mean_u = su.sum() / out.count;
  out.mean_v = sv.sum() / out.count;
  out.mean_d = sd.sum() / out.count;
  out.cuu = suu.sum() - su.sum() * out.mean_u;
  out.cuv = suv.sum() - su.sum() * out.mean_v;
  out.cvv = svv.sum() - sv.sum() * out.mean_v;
  out.cud = sud.sum() - su.sum() * out.mean_d;
  out.cvd = svd.sum() - sv.sum() * out.mean_d;
  out.residual_ss = srr.sum();
  return out;
}

/// Least squares on the inliers of `plane`: the normal equations reduce to
///   [C_uu C_uv; C_uv C_vv]·(a, b)ᵀ = (C_ud, C_vd)ᵀ,  c = d̄ − a·ū − b·v̄
/// (InlierSums). False (plane kept) with fewer than 3 inliers or when they lie on a line.
bool refine(const SampleLanes& s, const Origin& o, double threshold, LocalPlane& plane) {
  const InlierSums m = inlier_sums(s, o, plane, threshold);
  if (m.count < 3.0) return false;
  const double det = m.cuu * m.cvv - m.cuv * m.cuv;
  // Degenerate spread (all inliers on a line): keep the hypothesis.
  if (!(det >= 1e-6 * m.count * m.count)) return false;
  const double a = (m.cud * m.cvv - m.cvd * m.cuv) / det;
  const double b = (m.cvd * m.cuu - m.cud * m.cuv) / det;
  if (!std::isfinite(a) || !std::isfinite(b)) return false;
  plane.c = plane.c + m.mean_d - a * m.mean_u - b * m.mean_v;
  plane.a = a;
  plane.b = b;
  return true;
}

/// Copies an even subset of at most kScoringSamples samples (stride |samples| / 96) into
/// `storage` and returns it as lanes (the samples themselves when there are few).
SampleLanes scoring_subset(const SampleLanes& s, std::array<float, 3 * kScoringSamples>& storage) {
  if (s.count <= kScoringSamples) return s;
  float* u = storage.data();
  float* v = u + kScoringSamples;
  float* d = v + kScoringSamples;
  const double stride = static_cast<double>(s.count) / kScoringSamples;
  for (int k = 0; k < kScoringSamples; ++k) {
    const auto j = static_cast<std::size_t>(k * stride);
    u[k] = s.u[j];
    v[k] = s.v[j];
    d[k] = s.d[j];
  }
  return {u, v, d, kScoringSamples};
}

/// RANSAC + least squares (see fit_disparity_plane) drawing from `rng`, a std::mt19937 stream.
template <class Urng>
PlaneFitResult fit_with(const SampleLanes& samples, const ExtractionConfig& config, Urng& rng) {
  PlaneFitResult result;
  result.valid = samples.count;
  if (result.valid < std::max(3, config.min_valid_pixels)) return result;
  const double threshold = config.inlier_threshold_px;
  const Origin origin{samples.u[0], samples.v[0]};
  auto local = [&](std::size_t k) {
    return Eigen::Vector3d(samples.u[k] - origin.u0, samples.v[k] - origin.v0, samples.d[k]);
  };

  std::array<float, 3 * kScoringSamples> subset_storage;
  const SampleLanes scoring = scoring_subset(samples, subset_storage);
  std::uniform_int_distribution<std::size_t> pick(0, samples.count - 1);
  const int target = static_cast<int>(std::ceil(config.target_inlier_ratio * scoring.count));
  LocalPlane best;
  int best_inliers = -1;
  for (int it = 0; it < config.ransac_iterations; ++it) {
    const std::size_t k = pick(rng), j = pick(rng), i = pick(rng);  // the plane through i, j, k
    LocalPlane hypothesis;
    if (!plane_through(local(i), local(j), local(k), hypothesis)) continue;
    const int inliers = count_inliers<float>(scoring, origin, hypothesis, threshold);
    if (inliers > best_inliers) {
      best_inliers = inliers;
      best = hypothesis;
      if (inliers >= target) break;
    }
  }
  if (best_inliers < 3) return result;
  for (int pass = 0; pass < 2; ++pass)
    if (!refine(samples, origin, threshold, best)) break;
  result.plane = {best.a, best.b, best.c - best.a * origin.u0 - best.b * origin.v0};
  // The final inliers: their count, and the slopes' covariance s²·C⁻¹ with s² = Σ r²/(n − 3).
  const InlierSums final_inliers = inlier_sums(samples, origin, best, threshold);
  result.inliers = static_cast<int>(final_inliers.count);
  Eigen::Matrix2d scatter;
  scatter << final_inliers.cuu, final_inliers.cuv, final_inliers.cuv, final_inliers.cvv;
  if (final_inliers.count > 3.0 && final_inliers.residual_ss > 0.0 && scatter.determinant() > 0.0) {
    result.slope_covariance = final_inliers.residual_ss / (final_inliers.count - 3.0) * scatter.inverse();
    result.inlier_centroid_px = {final_inliers.mean_u + origin.u0, final_inliers.mean_v + origin.v0};
  }
  result.ok = result.inliers >= 3 && result.inlier_ratio() >= config.min_inlier_ratio;
  return result;
}

}  // namespace

PlaneFitResult fit_disparity_plane(const SampleLanes& samples, const ExtractionConfig& config,
                                   std::uint32_t seed) {
  std::mt19937 rng(seed);
  return fit_with(samples, config, rng);
}

PlaneFitResult fit_disparity_plane(std::span<const Eigen::Vector3f> samples,
                                   const ExtractionConfig& config, std::uint32_t seed) {
  const int n = static_cast<int>(samples.size());
  const int padded = (n + kSampleLane - 1) / kSampleLane * kSampleLane;
  std::vector<float> u(padded, 0.0f), v(padded, 0.0f), d(padded, kPaddingDisparity);
  for (int k = 0; k < n; ++k) {
    u[k] = samples[k].x();
    v[k] = samples[k].y();
    d[k] = samples[k].z();
  }
  return fit_disparity_plane(SampleLanes{u.data(), v.data(), d.data(), n}, config, seed);
}

namespace detail {

void mt19937_first_outputs(const std::uint32_t* seeds, std::uint32_t* out) {
  constexpr int kM = 397, kWords = kPrecomputedDraws + kM;
  std::array<std::array<std::uint32_t, kSeedBatch>, kWords> x;
  for (int j = 0; j < kSeedBatch; ++j) x[0][j] = seeds[j];
  for (int i = 1; i < kWords; ++i)
    for (int j = 0; j < kSeedBatch; ++j)  // kSeedBatch independent chains: one vector lane each
      x[i][j] = 1812433253u * (x[i - 1][j] ^ (x[i - 1][j] >> 30)) + static_cast<std::uint32_t>(i);
  for (int k = 0; k < kPrecomputedDraws; ++k)
    for (int j = 0; j < kSeedBatch; ++j) {
      const std::uint32_t y = (x[k][j] & 0x80000000u) | (x[k + 1][j] & 0x7FFFFFFFu);
      std::uint32_t z = x[k + kM][j] ^ (y >> 1) ^ ((y & 1u) ? 0x9908B0DFu : 0u);
      z ^= z >> 11;
      z ^= (z << 7) & 0x9D2C5680u;
      z ^= (z << 15) & 0xEFC60000u;
      out[j * kPrecomputedDraws + k] = z ^ (z >> 18);
    }
}

SegmentSamples gather_segment_samples(const SuperpixelState& s) {
  const int n = s.num_segments;
  SegmentSamples g;
  g.area.assign(s.size.begin(), s.size.begin() + n);
  g.begin.resize(n + 1);
  g.begin[0] = 0;
  for (int k = 0; k < n; ++k)  // room for every pixel of the segment (plus padding)
    g.begin[k + 1] = g.begin[k] + (g.area[k] + kSampleLane - 1) / kSampleLane * kSampleLane;
  const std::size_t room = static_cast<std::size_t>(g.begin[n]);
  // No zero fill: the slots past each segment's padded samples are never read.
  g.u = std::make_unique_for_overwrite<float[]>(room);
  g.v = std::make_unique_for_overwrite<float[]>(room);
  g.d = std::make_unique_for_overwrite<float[]>(room);
  std::vector<std::int32_t> cursor(g.begin.begin(), g.begin.end() - 1);
  for (int v = 0; v < s.height; ++v) {
    const std::int32_t* labels = s.labels.data() + static_cast<std::size_t>(v) * s.width;
    const float* disparity = s.disparity.data() + static_cast<std::size_t>(v) * s.width;
    for (int u = 0; u < s.width;) {  // one run of equal labels at a time, its cursor in a register
      const int l = labels[u];
      int at = cursor[l];
      for (; u < s.width && labels[u] == l; ++u) {
        const float d = disparity[u];
        if (std::isnan(d)) continue;
        g.u[at] = static_cast<float>(u);
        g.v[at] = static_cast<float>(v);
        g.d[at] = d;
        ++at;
      }
      cursor[l] = at;
    }
  }
  g.count.resize(n);
  for (int k = 0; k < n; ++k) {
    g.count[k] = cursor[k] - g.begin[k];
    const int padded_end = g.begin[k] + (g.count[k] + kSampleLane - 1) / kSampleLane * kSampleLane;
    for (int at = cursor[k]; at < padded_end; ++at) {
      g.u[at] = g.v[at] = 0.0f;
      g.d[at] = kPaddingDisparity;
    }
  }
  return g;
}

void fit_segment_planes(SuperpixelState& s, const SegmentSamples& samples,
                        const ExtractionConfig& config, SegmentPlaneFits& fits) {
  const int n = s.num_segments;
  fits.inliers.assign(n, 0);
  fits.valid.assign(n, 0);
  fits.slope_covariance.assign(n, Eigen::Matrix2d::Zero());
  fits.inlier_centroid_px.assign(n, Eigen::Vector2d::Zero());
  s.planes.resize(n);
  s.has_plane.assign(n, 0);
  // Segment k draws from std::mt19937(random_seed·7919 + k); the first draws of all segments
  // are computed together.
  const int batches = (n + kSeedBatch - 1) / kSeedBatch;
  std::vector<std::uint32_t> first_draws(static_cast<std::size_t>(batches) * kSeedBatch *
                                         kPrecomputedDraws);
  auto seed_of = [&](int seg) {
    return static_cast<std::uint32_t>(config.random_seed) * 7919u + static_cast<std::uint32_t>(seg);
  };
  for (int batch = 0; batch < batches; ++batch) {
    std::array<std::uint32_t, kSeedBatch> seeds;
    for (int j = 0; j < kSeedBatch; ++j) seeds[j] = seed_of(batch * kSeedBatch + j);
    mt19937_first_outputs(seeds.data(), first_draws.data() + static_cast<std::size_t>(batch) *
                                                                 kSeedBatch * kPrecomputedDraws);
  }
  for (int seg = 0; seg < n; ++seg) {
    const SampleLanes lanes = samples.lanes(seg);
    fits.valid[seg] = lanes.count;
    if (lanes.count < config.min_valid_ratio * samples.area[seg]) continue;
    ReplayedMt19937 rng(seed_of(seg),
                        first_draws.data() + static_cast<std::size_t>(seg) * kPrecomputedDraws);
    const auto fit = fit_with(lanes, config, rng);
    fits.inliers[seg] = fit.inliers;
    if (!fit.ok) continue;
    fits.slope_covariance[seg] = fit.slope_covariance;
    fits.inlier_centroid_px[seg] = fit.inlier_centroid_px;
    s.planes[seg] = fit.plane;
    s.has_plane[seg] = 1;
  }
}

}  // namespace detail
}  // namespace planecell::extraction
