#pragma once
/// The synthetic stereo world: textured planar polygons (a KITTI-like street, or a small box
/// scene for unit tests) seen from a rectified stereo rig, rendered with exact ground truth.
///
/// Frames: the world is the first left-camera frame of the trajectory (KITTI convention: x right,
/// y down, z forward); the road is the plane y = camera_height_m.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/config/synth_config.hpp"
#include "core/plane.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"

namespace planecell::io {

/// What a surface is (written to scene.yaml; tests and evaluation may group by it).
enum class SurfaceKind : std::uint8_t {
  kRoad,
  kCurb,
  kSidewalk,
  kFacade,
  kWall,  ///< side wall between buildings of different setback/height, end caps
  kDoor,
  kWindow,
  kAwning,  ///< slanted panel above a door
  kCar,
  kPole,
  kBackground,
  kBox,  ///< generic (test worlds)
};
std::string to_string(SurfaceKind kind);
/// Inverse of to_string. Throws InputError naming the text when unknown.
SurfaceKind surface_kind_from_string(const std::string& text);

/// Texture of a surface: albedo(s, t) = max(0.05, 1 + amplitude·(2·n(s, t) − 1)), where n ≈ 0.5 ± 0.2
/// is a contrast-stretched multi-octave value noise of the in-plane coordinates (s, t) (m). Octave k has wavelength
/// base_wavelength_m·3^k, its own rotation and offset (from `seed`); the sum of incommensurate
/// octaves is not periodic. Octaves finer than ~3 px on screen fade out (no aliasing).
struct SurfaceTexture {
  Eigen::Vector3d colour_rgb{0.5, 0.5, 0.5};  ///< base albedo, 0..1
  double amplitude = 0.4;                     ///< 0 = flat colour; < 0.05 = weakly textured
  double base_wavelength_m = 0.02;            ///< finest octave
  std::uint32_t seed = 0;
};

/// Weakly textured: amplitude < 0.05 (the street's plain facades and glass, 0.03), too little
/// contrast for stereo matching to measure the surface as well as a textured one.
inline bool is_weakly_textured(const SurfaceTexture& texture) { return texture.amplitude < 0.05; }

/// One planar, convex, textured polygon.
/// A point of the surface is X = origin + s·u_axis + t·v_axis with (s, t) inside `polygon`;
/// the plane is n·X + e = 0 with n = u_axis × v_axis (unit), e = −n·origin.
struct SyntheticSurface {
  std::uint16_t id = 0;  ///< 1..65535; 0 is reserved for "no surface" (sky)
  SurfaceKind kind = SurfaceKind::kBox;
  Plane3 plane;             ///< world frame
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d u_axis = Eigen::Vector3d::UnitX();  ///< unit, in the plane
  Eigen::Vector3d v_axis = Eigen::Vector3d::UnitY();  ///< unit, in the plane, ⟂ u_axis
  std::vector<Eigen::Vector2d> polygon;  ///< convex, in (s, t) metres, either orientation
  SurfaceTexture texture;

  /// World-frame corners of the polygon.
  std::vector<Eigen::Vector3d> corners_world() const;
};

/// Builds a surface from an origin, two in-plane unit axes and a convex polygon; sets the plane
/// (n = u × v). Throws InputError when the axes are not orthonormal or the polygon has < 3 corners.
SyntheticSurface make_surface(std::uint16_t id, SurfaceKind kind, const Eigen::Vector3d& origin,
                              const Eigen::Vector3d& u_axis, const Eigen::Vector3d& v_axis,
                              std::vector<Eigen::Vector2d> polygon, const SurfaceTexture& texture);

/// Axis-aligned rectangle [0, width_m] × [0, height_m] in the (u, v) basis at `origin`.
SyntheticSurface make_rectangle(std::uint16_t id, SurfaceKind kind, const Eigen::Vector3d& origin,
                                const Eigen::Vector3d& u_axis, const Eigen::Vector3d& v_axis,
                                double width_m, double height_m, const SurfaceTexture& texture);

struct SyntheticWorld {
  std::vector<SyntheticSurface> surfaces;  ///< surfaces[i].id == i + 1
  std::vector<Pose> trajectory;            ///< T_world_cam (left camera) per frame
  StereoCamera camera;
  double frame_rate_hz = 10.0;
  double sensor_noise_sigma = 0.0;  ///< grey levels; noise is a function of (seed, key, view)
  double max_range_m = 400.0;       ///< non-background surfaces beyond it are not drawn
  std::uint64_t seed = 1;
  bool loop = false;
  double path_length_m = 0.0;  ///< distance driven from the first to the last frame
};

/// The KITTI-like street of `config` (validated first: ConfigError names the bad field).
/// Open path (loop = false): straight legs of 60–140 m joined by 25–60° turns (filleted,
/// heading kept within ±60°), driven once at speed_mps. Loop: a rectangular block driven twice.
/// Cross-section: road, curbs, sidewalks, buildings with setbacks, side walls, doors, windows
/// (weakly textured), slanted awnings, parked cars (boxes), poles, far background walls.
SyntheticWorld make_street_world(const SynthConfig& config);

/// A small scene for other modules' unit tests: ground plane (1.5 m below the camera), a back wall
/// at 14 m, a fronto-parallel box face at 6 m, a slanted panel (normal 40° from the optical axis)
/// and a weakly textured panel, seen at width×height with KITTI-like field of view (fx scaled by
/// width/1242) and baseline 0.54 m. Trajectory: `frames` poses 0.3 m apart along +z.
SyntheticWorld make_box_world(int width = 320, int height = 120, std::uint64_t seed = 1,
                              int frames = 3);

/// One rendered stereo pair with exact ground truth.
struct SyntheticView {
  cv::Mat left, right;          ///< CV_8UC3 BGR
  cv::Mat disparity;            ///< CV_32F left disparity d = fx·B/Z, NaN where no surface (sky)
  cv::Mat surface_id;           ///< CV_16U left surface id, 0 = none
  cv::Mat right_disparity;      ///< CV_32F, same convention, for the right view
  cv::Mat right_surface_id;     ///< CV_16U
};

/// Renders both views from T_world_cam (left camera; the right one sits at +baseline along the
/// camera x axis). Per pixel, the nearest surface along the pixel-centre ray wins (exact z-buffer
/// on inverse depth, which is linear in (u, v) for a plane: 1/Z = −(n_c·r(u, v))/e_c,
/// r = ((u − cx)/fx, (v − cy)/fy, 1)). Shading is Lambert with a fixed sun, identical for both
/// views, so left(u, v) ≈ right(u − d, v) wherever the point is visible in both.
/// `noise_key` selects the sensor noise pattern (the frame index in sequences).
SyntheticView render_view(const SyntheticWorld& world, const Pose& T_world_cam,
                          std::uint64_t noise_key = 0);

/// Timing and size summary of write_sequence.
struct SequenceStats {
  std::size_t frames = 0;
  double render_ms = 0.0;  ///< total, both views + GT
  double write_ms = 0.0;   ///< total over the two writer tasks (PNG encoding + file writes),
                           ///< which run on their own threads while the next frame renders
  double path_length_m = 0.0;
  std::size_t surfaces = 0;
};

using ProgressCallback = std::function<void(std::size_t done, std::size_t total)>;

/// The left disparity of the pixels the right camera sees too (KITTI's "noc" ground truth): d(u, v)
/// where the match u − d lies in the right image and the right view's disparity at one of the two
/// pixels around it, ⌊u − d⌋ or ⌈u − d⌉, is within `tolerance_px` of d (the same surface point);
/// NaN elsewhere. A nearer surface hiding the point in the right view has a larger disparity there.
cv::Mat non_occluded_disparity(const SyntheticView& view, float tolerance_px = 1.0f);

/// Writes the KITTI odometry layout into out_dir: image_2/ and image_3/ (colour PNG NNNNNN.png),
/// calib.txt (P0 = P2, P1 = P3), poses/00.txt (T_world_cam0), times.txt, plus ground truth
/// disp_occ_0/ and disp_noc_0/ (KITTI 16-bit: all pixels, and those visible in both views,
/// non_occluded_disparity), surface_0/ (16-bit ids) and scene.yaml. Throws StorageError naming
/// the path when out_dir cannot be created or written.
SequenceStats write_sequence(const SyntheticWorld& world, const std::filesystem::path& out_dir,
                             const ProgressCallback& progress = {}, int png_compression = 1);

/// Writes / reads scene.yaml (camera, frame rate and every surface: id, kind, normal, offset,
/// origin, axes, polygon, corners, texture). read_scene_surfaces throws InputError naming the
/// file and surface on a malformed entry.
void write_scene_yaml(const std::filesystem::path& path, const SyntheticWorld& world);
std::vector<SyntheticSurface> read_scene_surfaces(const std::filesystem::path& path);

}  // namespace planecell::io
