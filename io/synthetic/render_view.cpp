/// Exact z-buffer rendering of planar convex polygons with procedural, view-consistent textures.
#include <algorithm>
#include <array>
#include <cmath>
#ifdef __AVX2__
#include <immintrin.h>
#endif
#include <cstdint>
#include <limits>
#include <vector>

#include "core/error.hpp"
#include "io/synthetic/synthetic_world.hpp"

namespace planecell::io {
namespace {

constexpr int kOctaves = 5;
constexpr double kOctaveRatio = 3.0;
constexpr std::array<float, kOctaves> kOctaveWeight{0.30f, 0.26f, 0.20f, 0.14f, 0.10f};
constexpr double kNearClipM = 0.05;
/// Averaging octaves shrinks the spread of n (σ ≈ 0.08); the gain restores σ ≈ 0.2.
constexpr float kContrastGain = 2.5f;
constexpr int kTableBits = 8;
constexpr int kTableSize = 1 << kTableBits;
constexpr int kTableMask = kTableSize - 1;

/// SplitMix64 finaliser: a well-mixed 64-bit hash.
std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double unit_from_hash(std::uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

/// Value-noise lattice: 256×256 uniform values in [0, 1] from a fixed hash (a pure constant).
const std::vector<float>& noise_table() {
  static const std::vector<float> table = [] {
    std::vector<float> t(kTableSize * kTableSize);
    for (std::size_t i = 0; i < t.size(); ++i)
      t[i] = static_cast<float>(unit_from_hash(mix64(i * 0x2545F4914F6CDD1Dull + 17)));
    return t;
  }();
  return table;
}

/// Sun direction (world, y down): from above, front-left.
const Eigen::Vector3d kSun = Eigen::Vector3d(-0.35, -0.85, 0.4).normalized();

/// Per-view, per-surface render set-up: everything linear in (u, v).
struct Prepared {
  int index = 0;                // into world.surfaces
  double inv_a = 0, inv_b = 0, inv_c = 0;  // 1/Z = inv_a·u + inv_b·v + inv_c
  double s_a = 0, s_b = 0, s_c = 0, s0 = 0;  // s = Z·(s_a u + s_b v + s_c) + s0
  double t_a = 0, t_b = 0, t_c = 0, t0 = 0;
  double abs_e = 0;              // |e_c|: cos(ray, n) = invZ·|e_c|/|r|
  float shade_r = 0, shade_g = 0, shade_b = 0;  // base colour × Lambert, 0..255
  float amplitude = 0;
  std::array<float, kOctaves> rot_c{}, rot_s{}, off_x{}, off_y{};
  std::array<float, kOctaves> inv_wavelength{};  // 1/λ_k (1/m)
  std::array<float, kOctaves> wavelength{};
  std::vector<Eigen::Vector2d> image_polygon;  // projected, clipped
};

/// Sutherland–Hodgman clip of a camera-frame polygon against z ≥ kNearClipM.
std::vector<Eigen::Vector3d> clip_near(const std::vector<Eigen::Vector3d>& in) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(in.size() + 2);
  for (std::size_t i = 0; i < in.size(); ++i) {
    const Eigen::Vector3d& a = in[i];
    const Eigen::Vector3d& b = in[(i + 1) % in.size()];
    const bool a_in = a.z() >= kNearClipM, b_in = b.z() >= kNearClipM;
    if (a_in) out.push_back(a);
    if (a_in != b_in) {
      const double t = (kNearClipM - a.z()) / (b.z() - a.z());
      out.push_back(a + t * (b - a));
    }
  }
  return out;
}

/// Sets up one surface for one view; false when it is invisible (behind, too far, edge-on).
bool prepare(const SyntheticSurface& surface, int index, const Eigen::Matrix3d& R_cw,
             const Eigen::Vector3d& centre, const StereoCamera& cam, double max_range_m,
             Prepared& p) {
  const auto corners = surface.corners_world();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : corners) mean += c;
  mean /= static_cast<double>(corners.size());
  double radius = 0.0;
  for (const auto& c : corners) radius = std::max(radius, (c - mean).norm());
  if (surface.kind != SurfaceKind::kBackground && (mean - centre).norm() - radius > max_range_m)
    return false;
  std::vector<Eigen::Vector3d> cam_corners;
  cam_corners.reserve(corners.size());
  bool any_in_front = false;
  for (const auto& c : corners) {
    cam_corners.push_back(R_cw * (c - centre));
    any_in_front |= cam_corners.back().z() >= kNearClipM;
  }
  if (!any_in_front) return false;
  const Eigen::Vector3d n_c = R_cw * surface.plane.normal;
  const double e_c = surface.plane.offset + surface.plane.normal.dot(centre);
  if (std::abs(e_c) < 1e-9) return false;  // plane through the optical centre: seen edge-on
  const auto clipped = clip_near(cam_corners);
  if (clipped.size() < 3) return false;
  p.image_polygon.clear();
  for (const auto& c : clipped)
    p.image_polygon.emplace_back(cam.fx * c.x() / c.z() + cam.cx, cam.fy * c.y() / c.z() + cam.cy);
  p.index = index;
  // 1/Z = −n_c·r/e_c with r = ((u − cx)/fx, (v − cy)/fy, 1).
  auto linear = [&](const Eigen::Vector3d& w, double& a, double& b, double& c) {
    a = w.x() / cam.fx;
    b = w.y() / cam.fy;
    c = w.z() - w.x() * cam.cx / cam.fx - w.y() * cam.cy / cam.fy;
  };
  linear(-n_c / e_c, p.inv_a, p.inv_b, p.inv_c);
  const Eigen::Vector3d origin_c = R_cw * (surface.origin - centre);
  const Eigen::Vector3d u_c = R_cw * surface.u_axis, v_c = R_cw * surface.v_axis;
  linear(u_c, p.s_a, p.s_b, p.s_c);
  linear(v_c, p.t_a, p.t_b, p.t_c);
  p.s0 = -u_c.dot(origin_c);
  p.t0 = -v_c.dot(origin_c);
  p.abs_e = std::abs(e_c);
  // Lambert, two-sided, identical for both views: ambient 0.35 + 0.65·|n·sun|.
  const double shade = 0.35 + 0.65 * std::abs(surface.plane.normal.dot(kSun));
  const auto& rgb = surface.texture.colour_rgb;
  p.shade_r = static_cast<float>(255.0 * shade * rgb.x());
  p.shade_g = static_cast<float>(255.0 * shade * rgb.y());
  p.shade_b = static_cast<float>(255.0 * shade * rgb.z());
  p.amplitude = static_cast<float>(surface.texture.amplitude);
  for (int k = 0; k < kOctaves; ++k) {
    const std::uint64_t h = mix64(surface.texture.seed * 0x9E37ull + static_cast<std::uint64_t>(k));
    const double angle = unit_from_hash(h) * 2.0 * M_PI;
    p.rot_c[k] = static_cast<float>(std::cos(angle));
    p.rot_s[k] = static_cast<float>(std::sin(angle));
    p.off_x[k] = static_cast<float>(unit_from_hash(mix64(h + 1)) * kTableSize);
    p.off_y[k] = static_cast<float>(unit_from_hash(mix64(h + 2)) * kTableSize);
    p.wavelength[k] =
        static_cast<float>(surface.texture.base_wavelength_m * std::pow(kOctaveRatio, k));
    p.inv_wavelength[k] = 1.0f / p.wavelength[k];
  }
  return true;
}

/// Texture n(s, t) ∈ [0, 1] of a run of pixels on one surface: weighted value-noise octaves, each
/// faded in once its wavelength spans ≥ 3 px of the surface footprint (fully on at 6 px):
///   n = 0.5 + G·(Σ w_k f_k v_k / Σ w_k f_k − 0.5)·min(1, Σ w_k f_k / 0.1), G = kContrastGain,
/// v_k = smoothstep-interpolated lattice value at rot_k(s, t)/λ_k + offset_k.
/// Loops run over the pixels of the run (AVX2: 8 pixels per step with table gathers).
void texture_run(const Prepared& p, const float* __restrict table, const float* __restrict s,
                 const float* __restrict t, const float* __restrict inv_footprint, int count,
                 float max_inv_footprint, float* __restrict sum, float* __restrict weight,
                 float* __restrict out) {
  for (int i = 0; i < count; ++i) sum[i] = weight[i] = 0.0f;
  for (int k = kOctaves - 1; k >= 0; --k) {
    // px per wavelength is largest where the footprint is smallest; stop when even that is < 3.
    if (p.wavelength[k] * max_inv_footprint <= 3.0f) break;
    const float c = p.rot_c[k] * p.inv_wavelength[k], sn = p.rot_s[k] * p.inv_wavelength[k];
    const float ox = p.off_x[k], oy = p.off_y[k], wl = p.wavelength[k], wk = kOctaveWeight[k];
    int i = 0;
#ifdef __AVX2__
    // Same maths as the scalar loop below, 8 pixels at a time with table gathers.
    const __m256 v_c = _mm256_set1_ps(c), v_sn = _mm256_set1_ps(sn), v_ox = _mm256_set1_ps(ox),
                 v_oy = _mm256_set1_ps(oy), v_wl = _mm256_set1_ps(wl), v_wk = _mm256_set1_ps(wk);
    const __m256 v_zero = _mm256_setzero_ps(), v_one = _mm256_set1_ps(1.0f),
                 v_three = _mm256_set1_ps(3.0f), v_two = _mm256_set1_ps(2.0f),
                 v_third = _mm256_set1_ps(1.0f / 3.0f);
    const __m256i v_mask = _mm256_set1_epi32(kTableMask), v_1 = _mm256_set1_epi32(1);
    for (; i + 8 <= count; i += 8) {
      const __m256 vs = _mm256_loadu_ps(s + i), vt = _mm256_loadu_ps(t + i);
      __m256 fade = _mm256_mul_ps(
          _mm256_sub_ps(_mm256_mul_ps(v_wl, _mm256_loadu_ps(inv_footprint + i)), v_three), v_third);
      fade = _mm256_min_ps(_mm256_max_ps(fade, v_zero), v_one);
      const __m256 x = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(v_c, vs), _mm256_mul_ps(v_sn, vt)), v_ox);
      const __m256 y = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(v_sn, vs), _mm256_mul_ps(v_c, vt)), v_oy);
      const __m256 fx = _mm256_floor_ps(x), fy = _mm256_floor_ps(y);
      __m256 tx = _mm256_sub_ps(x, fx), ty = _mm256_sub_ps(y, fy);
      tx = _mm256_mul_ps(_mm256_mul_ps(tx, tx), _mm256_sub_ps(v_three, _mm256_mul_ps(v_two, tx)));
      ty = _mm256_mul_ps(_mm256_mul_ps(ty, ty), _mm256_sub_ps(v_three, _mm256_mul_ps(v_two, ty)));
      const __m256i ix = _mm256_cvttps_epi32(fx), iy = _mm256_cvttps_epi32(fy);
      const __m256i x0 = _mm256_and_si256(ix, v_mask);
      const __m256i x1 = _mm256_and_si256(_mm256_add_epi32(ix, v_1), v_mask);
      const __m256i y0 = _mm256_slli_epi32(_mm256_and_si256(iy, v_mask), kTableBits);
      const __m256i y1 =
          _mm256_slli_epi32(_mm256_and_si256(_mm256_add_epi32(iy, v_1), v_mask), kTableBits);
      const __m256 t00 = _mm256_i32gather_ps(table, _mm256_add_epi32(y0, x0), 4);
      const __m256 t01 = _mm256_i32gather_ps(table, _mm256_add_epi32(y0, x1), 4);
      const __m256 t10 = _mm256_i32gather_ps(table, _mm256_add_epi32(y1, x0), 4);
      const __m256 t11 = _mm256_i32gather_ps(table, _mm256_add_epi32(y1, x1), 4);
      const __m256 a = _mm256_add_ps(t00, _mm256_mul_ps(tx, _mm256_sub_ps(t01, t00)));
      const __m256 b = _mm256_add_ps(t10, _mm256_mul_ps(tx, _mm256_sub_ps(t11, t10)));
      const __m256 value = _mm256_add_ps(a, _mm256_mul_ps(ty, _mm256_sub_ps(b, a)));
      const __m256 w = _mm256_mul_ps(v_wk, fade);
      _mm256_storeu_ps(sum + i, _mm256_add_ps(_mm256_loadu_ps(sum + i), _mm256_mul_ps(w, value)));
      _mm256_storeu_ps(weight + i, _mm256_add_ps(_mm256_loadu_ps(weight + i), w));
    }
#endif
    for (; i < count; ++i) {
      float fade = (wl * inv_footprint[i] - 3.0f) * (1.0f / 3.0f);
      fade = fade < 0.0f ? 0.0f : (fade > 1.0f ? 1.0f : fade);
      const float x = c * s[i] - sn * t[i] + ox;
      const float y = sn * s[i] + c * t[i] + oy;
      // floor without a libm call (branch-free, vectorisable): truncate, then step down if x < 0.
      int ix = static_cast<int>(x), iy = static_cast<int>(y);
      ix -= x < static_cast<float>(ix) ? 1 : 0;
      iy -= y < static_cast<float>(iy) ? 1 : 0;
      float tx = x - static_cast<float>(ix), ty = y - static_cast<float>(iy);
      tx = tx * tx * (3.0f - 2.0f * tx);
      ty = ty * ty * (3.0f - 2.0f * ty);
      const int x0 = ix & kTableMask, x1 = (ix + 1) & kTableMask;
      const int y0 = (iy & kTableMask) << kTableBits, y1 = ((iy + 1) & kTableMask) << kTableBits;
      const float a = table[y0 + x0] + tx * (table[y0 + x1] - table[y0 + x0]);
      const float b = table[y1 + x0] + tx * (table[y1 + x1] - table[y1 + x0]);
      const float w = wk * fade;
      sum[i] += w * (a + ty * (b - a));
      weight[i] += w;
    }
  }
  for (int i = 0; i < count; ++i) {
    const float w = weight[i];
    const float contrast = kContrastGain * (w * 10.0f < 1.0f ? w * 10.0f : 1.0f);
    out[i] = 0.5f + (sum[i] / (w > 1e-20f ? w : 1e-20f) - 0.5f) * contrast;
  }
}

/// Span [u_first, u_last] of pixel centres of row v inside a convex image polygon.
bool row_span(const std::vector<Eigen::Vector2d>& poly, double v, int width, int& u_first,
              int& u_last) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[(i + 1) % poly.size()];
    if ((a.y() <= v && v <= b.y()) || (b.y() <= v && v <= a.y())) {
      if (a.y() == b.y()) {
        lo = std::min({lo, a.x(), b.x()});
        hi = std::max({hi, a.x(), b.x()});
      } else {
        const double x = a.x() + (v - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
    }
  }
  if (!(lo <= hi)) return false;
  u_first = static_cast<int>(std::max(0.0, std::ceil(lo)));
  u_last = static_cast<int>(std::min(static_cast<double>(width - 1), std::floor(hi)));
  return u_first <= u_last;
}

/// Small triangular noise (variance σ²) from a per-row xorshift stream.
struct RowNoise {
  std::uint64_t state;
  float scale;  // σ·√6: (u1 − ½) + (u2 − ½) has variance 1/6
  float next() {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    const float u1 = static_cast<float>(state & 0xFFFFFF) * (1.0f / 16777216.0f);
    const float u2 = static_cast<float>((state >> 24) & 0xFFFFFF) * (1.0f / 16777216.0f);
    return (u1 + u2 - 1.0f) * scale;
  }
};

struct ViewBuffers {
  cv::Mat image, disparity, surface_id;
};

ViewBuffers render_one(const SyntheticWorld& world, const Pose& T_world_view,
                       std::uint64_t noise_seed) {
  const StereoCamera& cam = world.camera;
  const int width = cam.width, height = cam.height;
  const Eigen::Matrix3d R_cw = T_world_view.linear().transpose();
  const Eigen::Vector3d centre = T_world_view.translation();

  std::vector<Prepared> prepared;
  prepared.reserve(256);
  Prepared scratch;
  for (std::size_t i = 0; i < world.surfaces.size(); ++i) {
    if (prepare(world.surfaces[i], static_cast<int>(i), R_cw, centre, cam, world.max_range_m,
                scratch))
      prepared.push_back(scratch);
  }

  // Pass 1: exact z-buffer on inverse depth (larger = nearer).
  cv::Mat inv_depth(height, width, CV_32F, cv::Scalar(0.0f));
  cv::Mat owner(height, width, CV_32S, cv::Scalar(-1));
  for (int pi = 0; pi < static_cast<int>(prepared.size()); ++pi) {
    const Prepared& p = prepared[pi];
    double v_min = std::numeric_limits<double>::infinity(), v_max = -v_min;
    for (const auto& q : p.image_polygon) {
      v_min = std::min(v_min, q.y());
      v_max = std::max(v_max, q.y());
    }
    const int row_first = static_cast<int>(std::max(0.0, std::ceil(v_min)));
    const int row_last = static_cast<int>(std::min(height - 1.0, std::floor(v_max)));
    for (int v = row_first; v <= row_last; ++v) {
      int u0 = 0, u1 = -1;
      if (!row_span(p.image_polygon, v, width, u0, u1)) continue;
      float* inv_row = inv_depth.ptr<float>(v);
      int* owner_row = owner.ptr<int>(v);
      const double base = p.inv_b * v + p.inv_c;
      for (int u = u0; u <= u1; ++u) {
        const double inv = p.inv_a * u + base;
        if (inv > inv_row[u]) {
          inv_row[u] = static_cast<float>(inv);
          owner_row[u] = pi;
        }
      }
    }
  }

  // Pass 2: shading, exact ground truth, sky.
  ViewBuffers out;
  out.image.create(height, width, CV_8UC3);
  out.disparity.create(height, width, CV_32F);
  out.surface_id.create(height, width, CV_16U);
  const float* table = noise_table().data();
  const double fxb = cam.fx * cam.baseline_m;
  const bool noisy = world.sensor_noise_sigma > 0.0;
  std::vector<float> s_buf(width), t_buf(width), inv_fp(width), sum(width), weight(width),
      tex(width);
  for (int v = 0; v < height; ++v) {
    const int* owner_row = owner.ptr<int>(v);
    auto* pixel = out.image.ptr<std::uint8_t>(v);
    float* disp_row = out.disparity.ptr<float>(v);
    auto* id_row = out.surface_id.ptr<std::uint16_t>(v);
    RowNoise noise{mix64(noise_seed ^ (static_cast<std::uint64_t>(v) << 20)) | 1u,
                   static_cast<float>(world.sensor_noise_sigma * std::sqrt(6.0))};
    const double ry = (v - cam.cy) / cam.fy;
    // Sky: a vertical gradient (BGR), no surface.
    const float sky_t = static_cast<float>(v) / static_cast<float>(std::max(1, height - 1));
    const float sky_b = 235.0f - 20.0f * sky_t, sky_g = 200.0f - 10.0f * sky_t,
                sky_r = 150.0f + 25.0f * sky_t;
    for (int u0 = 0; u0 < width;) {
      const int pi = owner_row[u0];
      int u1 = u0 + 1;
      while (u1 < width && owner_row[u1] == pi) ++u1;
      if (pi < 0) {
        for (int u = u0; u < u1; ++u) {
          pixel[3 * u + 0] = cv::saturate_cast<std::uint8_t>(sky_b);
          pixel[3 * u + 1] = cv::saturate_cast<std::uint8_t>(sky_g);
          pixel[3 * u + 2] = cv::saturate_cast<std::uint8_t>(sky_r);
          disp_row[u] = std::numeric_limits<float>::quiet_NaN();
          id_row[u] = 0;
        }
      } else {
        const Prepared& p = prepared[pi];
        const std::uint16_t id = world.surfaces[p.index].id;
        const double inv_row = p.inv_b * v + p.inv_c;
        const double s_row = p.s_b * v + p.s_c, t_row = p.t_b * v + p.t_c;
        float max_inv_fp = 0.0f;
        for (int u = u0; u < u1; ++u) {
          // Exact plane geometry in double: 1/Z, d = fx·B/Z, (s, t) = Z·(linear) + (s0, t0).
          const double inv = p.inv_a * u + inv_row;
          const double z = 1.0 / inv;
          disp_row[u] = static_cast<float>(fxb * inv);
          id_row[u] = id;
          const int i = u - u0;
          s_buf[i] = static_cast<float>(z * (p.s_a * u + s_row) + p.s0);
          t_buf[i] = static_cast<float>(z * (p.t_a * u + t_row) + p.t0);
          // Footprint (m/px) = Z·|r| / (fx·cos), cos = |n·r|/|r| = (1/Z)·|e|/|r|.
          const double rx = (u - cam.cx) / cam.fx;
          const double r2 = rx * rx + ry * ry + 1.0;
          const double cos_incidence = std::max(inv * p.abs_e / std::sqrt(r2), 0.15);
          inv_fp[i] = static_cast<float>(cam.fx * cos_incidence * inv / std::sqrt(r2));
          max_inv_fp = std::max(max_inv_fp, inv_fp[i]);
        }
        const int count = u1 - u0;
        texture_run(p, table, s_buf.data(), t_buf.data(), inv_fp.data(), count, max_inv_fp,
                    sum.data(), weight.data(), tex.data());
        for (int i = 0; i < count; ++i) {
          const float albedo = std::max(0.05f, 1.0f + p.amplitude * (2.0f * tex[i] - 1.0f));
          const int u = u0 + i;
          pixel[3 * u + 0] = cv::saturate_cast<std::uint8_t>(p.shade_b * albedo);
          pixel[3 * u + 1] = cv::saturate_cast<std::uint8_t>(p.shade_g * albedo);
          pixel[3 * u + 2] = cv::saturate_cast<std::uint8_t>(p.shade_r * albedo);
        }
      }
      u0 = u1;
    }
    if (noisy) {
      for (int i = 0; i < 3 * width; ++i)
        pixel[i] = cv::saturate_cast<std::uint8_t>(pixel[i] + noise.next());
    }
  }
  return out;
}

}  // namespace

SyntheticView render_view(const SyntheticWorld& world, const Pose& T_world_cam,
                          std::uint64_t noise_key) {
  const StereoCamera& cam = world.camera;
  cam.validate("synthetic world camera");
  if (cam.width <= 0 || cam.height <= 0)
    throw InputError("render_view: synthetic world camera has no image size");
  validate_pose(T_world_cam, "render_view: T_world_cam");
  Pose T_world_right = T_world_cam;
  T_world_right.translate(Eigen::Vector3d(cam.baseline_m, 0.0, 0.0));
  const std::uint64_t key = mix64(world.seed * 0x51ull + noise_key);
  ViewBuffers left = render_one(world, T_world_cam, mix64(key + 1));
  ViewBuffers right = render_one(world, T_world_right, mix64(key + 2));
  SyntheticView view;
  view.left = left.image;
  view.disparity = left.disparity;
  view.surface_id = left.surface_id;
  view.right = right.image;
  view.right_disparity = right.disparity;
  view.right_surface_id = right.surface_id;
  return view;
}

cv::Mat non_occluded_disparity(const SyntheticView& view, float tolerance_px) {
  const cv::Mat& left = view.disparity;
  const cv::Mat& right = view.right_disparity;
  if (left.type() != CV_32F || right.type() != CV_32F || left.size() != right.size())
    throw InputError("non_occluded_disparity: left and right disparity must be CV_32F of one size");
  cv::Mat noc(left.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const int width = left.cols;
  for (int v = 0; v < left.rows; ++v) {
    const float* d_left = left.ptr<float>(v);
    const float* d_right = right.ptr<float>(v);
    float* out = noc.ptr<float>(v);
    for (int u = 0; u < width; ++u) {
      const float d = d_left[u];
      if (!std::isfinite(d)) continue;
      const float x = static_cast<float>(u) - d;
      const int x0 = static_cast<int>(std::floor(x));
      bool seen = false;
      for (const int x_r : {x0, x0 + 1})
        if (x_r >= 0 && x_r < width && std::abs(d_right[x_r] - d) <= tolerance_px) seen = true;
      if (seen) out[u] = d;
    }
  }
  return noc;
}

}  // namespace planecell::io
