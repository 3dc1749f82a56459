/// The KITTI-like street: a centreline polyline with filleted turns, a street cross-section built
/// from mitered strips along each leg, and the stereo rig driving the centreline.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/synthetic/synthetic_world.hpp"

namespace planecell::io {
namespace {

using Vec2 = Eigen::Vector2d;  // (x, z) in the horizontal layout plane
using Vec3 = Eigen::Vector3d;

constexpr double kCurbHeightM = 0.15;
constexpr double kFilletRadiusM = 12.0;
constexpr double kBuildingDepthM = 12.0;
constexpr double kMaxSetbackM = 3.0;
constexpr double kBackgroundMarginM = 250.0;
constexpr double kLookaheadM = 90.0;

/// Deterministic generator (SplitMix64): identical streams on every platform.
struct Rng {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform(double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(next() >> 11) * 0x1.0p-53;
  }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
  std::uint32_t seed32() { return static_cast<std::uint32_t>(next() >> 32); }
};

/// Heading h (rad, 0 = +z, positive = turning right towards +x): direction (sin h, cos h).
Vec2 direction(double h) { return {std::sin(h), std::cos(h)}; }
/// Right-hand side of heading h: camera x axis projected on the layout plane.
Vec2 right_of(double h) { return {std::cos(h), -std::sin(h)}; }

Vec3 lift(const Vec2& p, double y) { return {p.x(), y, p.y()}; }

/// A centreline made of straight legs between vertices; closed or open.
struct Centreline {
  std::vector<Vec2> vertices;
  bool closed = false;
  std::size_t legs() const { return closed ? vertices.size() : vertices.size() - 1; }
  Vec2 leg_start(std::size_t i) const { return vertices[i]; }
  Vec2 leg_end(std::size_t i) const { return vertices[(i + 1) % vertices.size()]; }
  double heading(std::size_t i) const {
    const Vec2 d = leg_end(i) - leg_start(i);
    return std::atan2(d.x(), d.y());
  }
  double length(std::size_t i) const { return (leg_end(i) - leg_start(i)).norm(); }
  /// Signed turn at vertex i (rad, positive = right); 0 at open ends.
  double turn(std::size_t i) const {
    if (!closed && (i == 0 || i + 1 >= vertices.size())) return 0.0;
    const std::size_t in = (i + legs() - 1) % legs();
    double d = heading(i % legs()) - heading(in);
    while (d > M_PI) d -= 2.0 * M_PI;
    while (d < -M_PI) d += 2.0 * M_PI;
    return d;
  }
  /// Miter vector at vertex i: V + w·m lies on both adjacent legs' offset-w lines,
  /// m = (r_in + r_out) / (1 + r_in·r_out).
  Vec2 miter(std::size_t i) const {
    if (!closed && i == 0) return right_of(heading(0));
    if (!closed && i + 1 >= vertices.size()) return right_of(heading(legs() - 1));
    const Vec2 r_in = right_of(heading((i + legs() - 1) % legs()));
    const Vec2 r_out = right_of(heading(i % legs()));
    return (r_in + r_out) / (1.0 + r_in.dot(r_out));
  }
  /// Fillet tangent length at vertex i: R·tan(|θ|/2).
  double tangent(std::size_t i) const { return kFilletRadiusM * std::tan(std::abs(turn(i)) / 2.0); }
};

/// The driven path: legs shortened by the fillet tangents, joined by circular arcs.
struct PathPiece {
  bool arc = false;
  Vec2 start;
  double heading = 0.0;  // at the start
  double turn = 0.0;     // arcs: signed total turn
  double length = 0.0;
};

std::vector<PathPiece> build_path(const Centreline& line) {
  std::vector<PathPiece> pieces;
  const std::size_t n = line.legs();
  for (std::size_t i = 0; i < n; ++i) {
    const double h = line.heading(i);
    const Vec2 d = direction(h);
    const std::size_t end_vertex = (i + 1) % line.vertices.size();
    const double t0 = line.tangent(i), t1 = line.tangent(end_vertex);
    PathPiece straight;
    straight.start = line.leg_start(i) + t0 * d;
    straight.heading = h;
    straight.length = line.length(i) - t0 - t1;
    pieces.push_back(straight);
    const double turn = line.turn(end_vertex);
    if (turn != 0.0) {
      PathPiece arc;
      arc.arc = true;
      arc.start = line.leg_end(i) - t1 * d;
      arc.heading = h;
      arc.turn = turn;
      arc.length = kFilletRadiusM * std::abs(turn);
      pieces.push_back(arc);
    }
  }
  return pieces;
}

/// Position and heading at distance `along` into a piece.
void piece_pose(const PathPiece& p, double along, Vec2& position, double& heading) {
  if (!p.arc) {
    position = p.start + along * direction(p.heading);
    heading = p.heading;
    return;
  }
  const double sign = p.turn > 0.0 ? 1.0 : -1.0;
  const Vec2 centre = p.start + sign * kFilletRadiusM * right_of(p.heading);
  heading = p.heading + sign * along / kFilletRadiusM;
  position = centre - sign * kFilletRadiusM * right_of(heading);
}

/// T_world_cam of a camera at layout position p, heading h, on the camera's horizontal plane
/// y = 0: rotation about the y axis, columns x = (cos h, 0, −sin h), z = (sin h, 0, cos h).
Pose camera_pose(const Vec2& p, double h) {
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::AngleAxisd(h, Vec3::UnitY()).toRotationMatrix();
  pose.translation() = lift(p, 0.0);
  return pose;
}

/// Surfaces accumulate here; ids follow the insertion order.
class Builder {
 public:
  explicit Builder(Rng& rng) : rng_(rng) {}
  std::vector<SyntheticSurface> surfaces;

  SurfaceTexture texture(const Vec3& rgb, double amplitude, double wavelength_m) {
    SurfaceTexture t;
    t.colour_rgb = rgb.cwiseMax(0.02).cwiseMin(1.0);
    t.amplitude = amplitude;
    t.base_wavelength_m = wavelength_m;
    t.seed = rng_.seed32();
    return t;
  }
  Vec3 jitter(const Vec3& rgb, double amount) {
    return rgb + Vec3(rng_.uniform(-amount, amount), rng_.uniform(-amount, amount),
                      rng_.uniform(-amount, amount));
  }

  /// A vertical rectangle from layout point a to b, between heights (y values) y_bottom and
  /// y_top (y_top < y_bottom: up is −y). Its normal faces `facing` (layout plane).
  void vertical(SurfaceKind kind, Vec2 a, Vec2 b, double y_bottom, double y_top,
                const Vec2& facing, const SurfaceTexture& tex) {
    const double len = (b - a).norm();
    if (len < 1e-3 || y_bottom - y_top < 1e-3) return;
    Vec2 u2 = (b - a) / len;
    // n = u × (0, −1, 0) = (u_z, 0, −u_x): flip the run when it faces away.
    if (Vec2(u2.y(), -u2.x()).dot(facing) < 0.0) {
      std::swap(a, b);
      u2 = -u2;
    }
    add(make_rectangle(next_id(), kind, lift(a, y_bottom), lift(u2, 0.0), Vec3(0, -1, 0), len,
                       y_bottom - y_top, tex));
  }

  /// A horizontal convex polygon at height y, normal up (−y): u = +x, v = +z; the origin is its
  /// first corner, so (s, t) = (x − x0, z − z0) stay small (texture precision in float).
  void horizontal(SurfaceKind kind, const std::vector<Vec2>& corners, double y,
                  const SurfaceTexture& tex) {
    std::vector<Vec2> local;
    local.reserve(corners.size());
    for (const auto& c : corners) local.push_back(c - corners.front());
    add(make_surface(next_id(), kind, lift(corners.front(), y), Vec3::UnitX(), Vec3::UnitZ(),
                     std::move(local), tex));
  }

  void add(SyntheticSurface s) { surfaces.push_back(std::move(s)); }

  std::uint16_t next_id() {
    if (surfaces.size() >= 65535)
      throw ConfigError(
          "synth: the street needs more than 65535 surfaces (16-bit ids); use fewer frames or "
          "--loop");
    return static_cast<std::uint16_t>(surfaces.size() + 1);
  }

  Rng& rng() { return rng_; }

 private:
  Rng& rng_;
};

struct StreetParams {
  double road_half_m = 4.5;
  double sidewalk_m = 3.0;
  double ground_y = 1.65;  // road plane y (camera at y = 0)
};

/// Buildings, doors, windows and awnings along one side of one leg.
void add_buildings(Builder& b, const Centreline& line, std::size_t leg, double side,
                   const StreetParams& sp) {
  Rng& rng = b.rng();
  const double h = line.heading(leg);
  const Vec2 d = direction(h), r = right_of(h);
  const Vec2 va = line.leg_start(leg);
  const std::size_t ia = leg, ib = (leg + 1) % line.vertices.size();
  const double w_f = side * (sp.road_half_m + sp.sidewalk_m);
  // Leg coordinate t of the facade line's miter points.
  const double t_start = w_f * line.miter(ia).dot(d);
  const double t_end = line.length(leg) + w_f * line.miter(ib).dot(d);
  const Vec2 facing = -side * r;  // towards the street
  const double y_walk = sp.ground_y - kCurbHeightM;
  auto at = [&](double t, double offset) { return Vec2(va + t * d + offset * r); };

  std::vector<double> cuts{t_start};
  while (t_end - cuts.back() > 22.0) cuts.push_back(cuts.back() + rng.uniform(6.0, 18.0));
  cuts.push_back(t_end);
  const std::size_t n = cuts.size() - 1;
  std::vector<double> setback(n), height(n);
  static const Vec3 kPalette[] = {{0.72, 0.62, 0.50}, {0.60, 0.58, 0.55}, {0.78, 0.72, 0.62},
                                  {0.55, 0.40, 0.32}, {0.70, 0.70, 0.72}, {0.62, 0.55, 0.45}};
  for (std::size_t k = 0; k < n; ++k) {
    setback[k] = (k == 0 || k + 1 == n || rng.chance(0.5)) ? 0.0 : rng.uniform(0.5, kMaxSetbackM);
    height[k] = rng.uniform(6.0, 20.0);
  }
  for (std::size_t k = 0; k < n; ++k) {
    const double off = w_f + side * setback[k];
    const Vec3 colour = b.jitter(kPalette[rng.next() % 6], 0.06);
    const bool weak = rng.chance(0.15);
    const auto facade_tex =
        b.texture(colour, weak ? 0.03 : rng.uniform(0.25, 0.5), rng.uniform(0.015, 0.04));
    b.vertical(SurfaceKind::kFacade, at(cuts[k], off), at(cuts[k + 1], off), y_walk,
               y_walk - height[k], facing, facade_tex);
    const double width = cuts[k + 1] - cuts[k];
    const double front = off - side * 0.03;  // doors/windows stand 3 cm proud of the facade
    // Doors (and sometimes a slanted awning above them).
    const int doors = width > 10.0 ? 2 : 1;
    for (int i = 0; i < doors; ++i) {
      const double lo = cuts[k] + 1.0 + i * width / doors;
      const double hi = cuts[k] + (i + 1) * width / doors - 2.2;
      if (hi <= lo) continue;
      const double t0 = rng.uniform(lo, hi);
      const auto door_tex =
          b.texture(b.jitter({0.35, 0.25, 0.18}, 0.08), rng.uniform(0.1, 0.3), 0.01);
      b.vertical(SurfaceKind::kDoor, at(t0, front), at(t0 + 1.1, front), y_walk, y_walk - 2.2,
                 facing, door_tex);
      if (rng.chance(0.4)) {
        // Awning: top edge on the facade 2.7 m up, sloping 1.0 m out and 0.5 m down.
        const Vec2 a2 = at(t0 - 0.3, off - side * 0.05);
        const Vec2 u2 = d;
        const Vec3 u3 = lift(u2, 0.0);
        Vec3 v3 = lift(facing, 0.0) * 1.0 + Vec3(0, 0.5, 0);
        v3.normalize();
        const auto awning_tex =
            b.texture(b.jitter({0.65, 0.15, 0.15}, 0.1), rng.uniform(0.15, 0.3), 0.02);
        b.add(make_rectangle(b.next_id(), SurfaceKind::kAwning, lift(a2, y_walk - 2.7), u3, v3,
                             1.7, std::sqrt(1.25), awning_tex));
      }
    }
    // Windows: weakly textured glass, rows every 3 m from 3 m up.
    if (rng.chance(0.6)) {
      const double spacing = rng.uniform(2.5, 4.0);
      const int columns = std::min(6, static_cast<int>((width - 1.0) / spacing));
      for (double z = 3.2; z + 1.5 < height[k] - 1.0; z += 3.0) {
        for (int c = 0; c < columns; ++c) {
          const double t0 = cuts[k] + (width - columns * spacing) / 2.0 + c * spacing +
                            (spacing - 1.2) / 2.0;
          const auto glass = b.texture(b.jitter({0.25, 0.30, 0.36}, 0.03), 0.03, 0.05);
          b.vertical(SurfaceKind::kWindow, at(t0, front), at(t0 + 1.2, front), y_walk - z,
                     y_walk - z - 1.5, facing, glass);
        }
      }
    }
  }
  // Side walls where neighbouring buildings differ in setback or height (never coplanar).
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double t = cuts[k + 1];
    const bool k_front = setback[k] < setback[k + 1] ||
                         (setback[k] == setback[k + 1] && height[k] <= height[k + 1]);
    const std::size_t f = k_front ? k : k + 1, bk = k_front ? k + 1 : k;
    const Vec2 towards_back = k_front ? d : Vec2(-d);
    const double deep = w_f + side * kBuildingDepthM;
    const auto wall_tex = b.texture(b.jitter({0.6, 0.58, 0.55}, 0.08), rng.uniform(0.2, 0.4),
                                    rng.uniform(0.015, 0.04));
    if (setback[f] != setback[bk])
      b.vertical(SurfaceKind::kWall, at(t, w_f + side * setback[f]), at(t, deep), y_walk,
                 y_walk - height[f], towards_back, wall_tex);
    if (height[bk] > height[f])
      b.vertical(SurfaceKind::kWall, at(t, w_f + side * setback[bk]), at(t, deep),
                 y_walk - height[f], y_walk - height[bk], -towards_back, wall_tex);
  }
}

/// Road, curbs, sidewalks, buildings, poles and parked cars of one leg.
void add_leg(Builder& b, const Centreline& line, std::size_t leg, const StreetParams& sp) {
  Rng& rng = b.rng();
  const double h = line.heading(leg);
  const Vec2 d = direction(h), r = right_of(h);
  const std::size_t ia = leg, ib = (leg + 1) % line.vertices.size();
  const Vec2 va = line.leg_start(leg), vb = line.leg_end(leg);
  const Vec2 ma = line.miter(ia), mb = line.miter(ib);
  const double y_walk = sp.ground_y - kCurbHeightM;
  const double rh = sp.road_half_m;
  auto at = [&](double t, double offset) { return Vec2(va + t * d + offset * r); };

  b.horizontal(SurfaceKind::kRoad, {va - rh * ma, vb - rh * mb, vb + rh * mb, va + rh * ma},
               sp.ground_y,
               b.texture(b.jitter({0.36, 0.36, 0.37}, 0.03), rng.uniform(0.3, 0.45), 0.012));
  for (double side : {-1.0, 1.0}) {
    const Vec2 facing = -side * r;
    const double w_curb = side * rh, w_out = side * (rh + sp.sidewalk_m + kMaxSetbackM);
    b.vertical(SurfaceKind::kCurb, va + w_curb * ma, vb + w_curb * mb, sp.ground_y, y_walk, facing,
               b.texture({0.62, 0.62, 0.60}, 0.3, 0.01));
    b.horizontal(SurfaceKind::kSidewalk,
                 {va + w_curb * ma, vb + w_curb * mb, vb + w_out * mb, va + w_out * ma}, y_walk,
                 b.texture(b.jitter({0.55, 0.53, 0.50}, 0.04), rng.uniform(0.2, 0.4), 0.015));
    add_buildings(b, line, leg, side, sp);

    // Poles on the sidewalk, 0.5 m behind the curb (kept out of the corner miters).
    const double t_lo = std::max(0.0, w_curb * ma.dot(d)) + 5.0;
    const double t_hi = line.length(leg) + std::min(0.0, w_curb * mb.dot(d)) - 5.0;
    for (double t = t_lo + rng.uniform(0.0, 15.0); t < t_hi; t += rng.uniform(15.0, 35.0)) {
      const Vec2 c = at(t, side * (rh + 0.5));
      const double top = y_walk - rng.uniform(4.0, 7.0);
      const auto tex = b.texture(b.jitter({0.45, 0.47, 0.50}, 0.05), 0.15, 0.01);
      const Vec2 corners[4] = {c + 0.1 * (-d - r), c + 0.1 * (d - r), c + 0.1 * (d + r),
                               c + 0.1 * (-d + r)};
      for (int i = 0; i < 4; ++i) {
        const Vec2 mid = (corners[i] + corners[(i + 1) % 4]) / 2.0;
        b.vertical(SurfaceKind::kPole, corners[i], corners[(i + 1) % 4], y_walk, top, mid - c,
                   tex);
      }
    }
    // Parked cars (boxes) along the curb, only beside straight parts of the driven path.
    const double car_lo = line.tangent(ia) + 3.0;
    const double car_hi = line.length(leg) - line.tangent(ib) - 3.0;
    for (double t = car_lo + rng.uniform(0.0, 4.0); t + 4.3 < car_hi; t += 4.3 + rng.uniform(1.0, 6.0)) {
      if (!rng.chance(0.55)) continue;
      const double lateral = side * (rh - 1.2);
      const Vec2 c = at(t + 2.15, lateral);
      const Vec2 hl = 2.15 * d, hw = 0.9 * r;
      const Vec2 corners[4] = {c - hl - hw, c + hl - hw, c + hl + hw, c - hl + hw};
      const double top = sp.ground_y - rng.uniform(1.4, 1.6);
      const auto tex = b.texture(
          Vec3(rng.uniform(0.1, 0.9), rng.uniform(0.1, 0.9), rng.uniform(0.1, 0.9)),
          rng.uniform(0.08, 0.2), 0.02);
      for (int i = 0; i < 4; ++i) {
        const Vec2 mid = (corners[i] + corners[(i + 1) % 4]) / 2.0;
        b.vertical(SurfaceKind::kCar, corners[i], corners[(i + 1) % 4], sp.ground_y, top,
                   mid - c, tex);
      }
      b.horizontal(SurfaceKind::kCar, {corners[0], corners[1], corners[2], corners[3]}, top, tex);
    }
  }
}

/// Far background: four tall walls enclosing the whole layout 250 m beyond its bounds.
void add_background(Builder& b, const std::vector<SyntheticSurface>& built, double ground_y) {
  Eigen::AlignedBox2d box;
  for (const auto& s : built)
    for (const auto& c : s.corners_world()) box.extend(Vec2(c.x(), c.z()));
  box.min() -= Vec2::Constant(kBackgroundMarginM);
  box.max() += Vec2::Constant(kBackgroundMarginM);
  const double extent = box.sizes().maxCoeff();
  const double top = ground_y - (20.0 + 0.02 * extent);  // low hills: sky stays visible
  const Vec2 c = box.center();
  const Vec2 p[4] = {box.min(), Vec2(box.max().x(), box.min().y()), box.max(),
                     Vec2(box.min().x(), box.max().y())};
  for (int i = 0; i < 4; ++i) {
    const Vec2 mid = (p[i] + p[(i + 1) % 4]) / 2.0;
    b.vertical(SurfaceKind::kBackground, p[i], p[(i + 1) % 4], ground_y, top, c - mid,
               b.texture(b.jitter({0.45, 0.52, 0.42}, 0.05), 0.35, 0.5));
  }
}

void validate(const SynthConfig& c) {
  auto fail = [](const std::string& what) { throw ConfigError("synth." + what); };
  if (c.frames <= 0 || c.frames > 1000000) fail("frames must be in 1..1000000, got " + std::to_string(c.frames));
  if (c.width < 64 || c.width > 8192) fail("width must be in 64..8192 px, got " + std::to_string(c.width));
  if (c.height < 32 || c.height > 8192) fail("height must be in 32..8192 px, got " + std::to_string(c.height));
  auto positive = [&](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) fail(std::string(name) + " must be finite and > 0");
  };
  positive(c.fx, "fx");
  positive(c.fy, "fy");
  positive(c.baseline_m, "baseline_m");
  positive(c.camera_height_m, "camera_height_m");
  positive(c.speed_mps, "speed_mps");
  positive(c.frame_rate_hz, "frame_rate_hz");
  positive(c.max_range_m, "max_range_m");
  if (!std::isfinite(c.cx) || !std::isfinite(c.cy)) fail("cx/cy must be finite");
  if (c.camera_height_m < 0.5 || c.camera_height_m > 4.0)
    fail("camera_height_m must be in 0.5..4 m (the rig drives on the road)");
  if (!std::isfinite(c.sensor_noise_sigma) || c.sensor_noise_sigma < 0.0 || c.sensor_noise_sigma > 20.0)
    fail("sensor_noise_sigma must be in 0..20 grey levels");
  if (c.png_compression < 0 || c.png_compression > 9) fail("png_compression must be in 0..9");
}

}  // namespace

SyntheticWorld make_street_world(const SynthConfig& config) {
  validate(config);
  Rng rng{config.seed * 0x2545F4914F6CDD1Dull + 0x1234567ull};
  SyntheticWorld world;
  world.seed = config.seed;
  world.loop = config.loop;
  world.frame_rate_hz = config.frame_rate_hz;
  world.sensor_noise_sigma = config.sensor_noise_sigma;
  world.max_range_m = config.max_range_m;
  const double sx = static_cast<double>(config.width) / kSynthReferenceWidth;
  const double sy = static_cast<double>(config.height) / kSynthReferenceHeight;
  world.camera.fx = config.fx * sx;
  world.camera.fy = config.fy * sx;
  world.camera.cx = (config.cx + 0.5) * sx - 0.5;
  world.camera.cy = (config.cy + 0.5) * sy - 0.5;
  world.camera.baseline_m = config.baseline_m;
  world.camera.width = config.width;
  world.camera.height = config.height;

  StreetParams sp;
  sp.road_half_m = rng.uniform(4.0, 5.5);
  sp.sidewalk_m = rng.uniform(2.5, 3.5);
  sp.ground_y = config.camera_height_m;

  const double nominal_step = config.speed_mps / config.frame_rate_hz;
  Centreline line;
  double s_start = 0.0;
  if (config.loop) {
    // A rectangular block driven clockwise (right turns) twice; sides a (along z) and b.
    const double target = std::max(0.5 * config.frames * nominal_step, 230.0);
    const double b_len = (target + (8.0 - 2.0 * M_PI) * kFilletRadiusM) / 5.0;
    const double a_len = 1.5 * b_len;
    line.closed = true;
    line.vertices = {{0.0, -a_len / 2}, {0.0, a_len / 2}, {b_len, a_len / 2}, {b_len, -a_len / 2}};
    s_start = a_len / 2 - line.tangent(0);
  } else {
    // Legs of 60–140 m, turns of 25–60° whose sign keeps the heading within ±60°.
    const double needed = 40.0 + (config.frames - 1) * nominal_step + kLookaheadM;
    line.vertices = {{0.0, -40.0}};
    double heading = 0.0, total = 0.0;
    bool first = true;
    while (total < needed) {
      if (!first) {
        const double magnitude = rng.uniform(25.0, 60.0) * M_PI / 180.0;
        double sign = rng.chance(0.5) ? 1.0 : -1.0;
        if (std::abs(heading + sign * magnitude) > 60.0 * M_PI / 180.0) sign = -sign;
        heading += sign * magnitude;
      }
      const double len = first ? 40.0 + rng.uniform(60.0, 140.0) : rng.uniform(60.0, 140.0);
      line.vertices.push_back(line.vertices.back() + len * direction(heading));
      total += len;
      first = false;
    }
    s_start = 40.0;
  }

  Builder builder(rng);
  for (std::size_t leg = 0; leg < line.legs(); ++leg) add_leg(builder, line, leg, sp);
  if (!line.closed) {
    // End caps: a building across the street at both ends.
    const double w = sp.road_half_m + sp.sidewalk_m + kMaxSetbackM;
    for (int end = 0; end < 2; ++end) {
      const std::size_t vi = end == 0 ? 0 : line.vertices.size() - 1;
      const double h = line.heading(end == 0 ? 0 : line.legs() - 1);
      const Vec2 v = line.vertices[vi], r = right_of(h), d = direction(h);
      const Vec2 facing = end == 0 ? d : Vec2(-d);
      builder.vertical(SurfaceKind::kWall, v - w * r, v + w * r, sp.ground_y, sp.ground_y - 15.0,
                       facing, builder.texture({0.6, 0.55, 0.5}, 0.35, 0.03));
    }
  }
  add_background(builder, builder.surfaces, sp.ground_y);
  world.surfaces = std::move(builder.surfaces);

  // Trajectory along the filleted centreline.
  const auto pieces = build_path(line);
  double path_total = 0.0;
  for (const auto& p : pieces) path_total += p.length;
  const double step = config.loop ? 2.0 * path_total / config.frames : nominal_step;
  world.trajectory.reserve(static_cast<std::size_t>(config.frames));
  for (int i = 0; i < config.frames; ++i) {
    double s = s_start + i * step;
    if (config.loop) s = std::fmod(s, path_total);
    std::size_t k = 0;
    while (k + 1 < pieces.size() && s > pieces[k].length) s -= pieces[k++].length;
    Vec2 position;
    double heading = 0.0;
    piece_pose(pieces[k], std::min(s, pieces[k].length), position, heading);
    world.trajectory.push_back(camera_pose(position, heading));
  }
  world.path_length_m = (config.frames - 1) * step;
  return world;
}

}  // namespace planecell::io
