#pragma once
/// The planecell: a planar polygon with colour, the paper's basic map unit.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "core/plane.hpp"

namespace planecell {

/// Joint colour-histogram bins of a planecell (quantised colour; see mapping/planecell).
inline constexpr int kColourHistogramBins = 64;
using ColourHistogram = std::array<float, kColourHistogramBins>;  ///< normalised to sum 1

/// Sentinel surface label of a cell not (yet) assigned to a surface.
inline constexpr std::uint32_t kNoSurface = 0xFFFFFFFFu;

/// One planecell. Geometry is in the frame named by the owner (camera frame after extraction,
/// world frame after the pose transform).
struct Planecell {
  std::uint32_t id = 0;           ///< unique within its frame (extraction) or map (global)
  std::uint64_t frame_id = 0;     ///< frame it was extracted from
  bool has_plane = false;         ///< false: planeless (sky, reflections); no 3D output
  DisparityPlane disparity_plane; ///< d = a u + b v + c in the source image
  Plane3 plane;                   ///< n·X + e = 0 (camera frame, or world after transform)
  std::vector<Eigen::Vector2f> vertices_px;  ///< ordered polygon in the image
  std::vector<Eigen::Vector3f> vertices_m;   ///< same polygon in 3D (camera or world frame)
  Eigen::Vector3f mean_rgb = Eigen::Vector3f::Zero();  ///< 0..255, R G B order
  ColourHistogram histogram{};
  std::uint32_t area_px = 0;      ///< pixels in the segment
  std::uint32_t inlier_count = 0; ///< RANSAC inliers
  float inlier_ratio = 0.0f;      ///< inliers / valid disparities
  /// 1-σ depth uncertainty of the plane at the polygon's centroid, σ_Z = Z²·σ_d / (f_x·B) (m), with
  /// σ_d = t/√3 the spread of inliers uniform within the RANSAC threshold ±t; 0 = unknown.
  float depth_sigma_m = 0.0f;
  /// 1-σ angle of the plane's normal (rad) from its least-squares fit (normal_sigma_rad, with the
  /// inliers' residual variance s² = Σr²/(n − 3) and their image scatter); 0 = unknown. It assumes
  /// independent pixel errors: SGM's aggregation correlates them, so the actual angle error is
  /// several times larger (MapConfig::normal_sigma_scale), but it ranks cells by how well their
  /// orientation is known.
  float normal_sigma_rad = 0.0f;
  std::uint32_t surface = kNoSurface;  ///< CRF surface label
};

}  // namespace planecell
