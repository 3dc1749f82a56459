#pragma once
/// 2D→3D conversion (paper §5.1) and the dense disparity rendered from the planes.
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/planecell.hpp"
#include "core/stereo_camera.hpp"

namespace planecell::extraction {

/// Smallest disparity a vertex is back-projected with (px): a plane that reaches d ≤ 0 inside
/// the image (beyond infinity) is clamped there so that its vertices stay finite.
inline constexpr double kMinVertexDisparityPx = 0.25;

/// Converts a cell with a disparity plane into the left camera frame, exactly: the 3D plane is
/// plane_from_disparity(θ) (a·fx·X + b·fy·Y + (a·cx + b·cy + c)·Z − fx·B = 0, normalised) and
/// each image vertex (u, v) is back-projected with the plane's own disparity d = θ(u, v), so
/// every 3D vertex lies on the 3D plane and projects back to (u, v, d). Planeless cells get no
/// 3D geometry (vertices_m cleared).
void convert_to_3d(Planecell& cell, const StereoCamera& camera);

/// The "optimised depth map": d(u, v) = θ_{S(u,v)}(u, v) for every pixel of a cell with a
/// plane (clamped at 0). With fill_planeless, a planeless cell takes the plane of its farther
/// (smaller-disparity at the cell's centre) neighbour that has one, so the map is dense wherever
/// a plane is reachable; otherwise its pixels are NaN. `labels` is CV_32S indexing `cells`.
cv::Mat render_dense_disparity(const cv::Mat& labels, const std::vector<Planecell>& cells,
                               bool fill_planeless);

}  // namespace planecell::extraction

namespace planecell::extraction {

/// Occlusion-aware hole filling of a rendered dense disparity: along each row, a run of pixels
/// without input disparity (NaN in `input_disparity`) that separates two different cells is
/// most likely background uncovered by a depth edge (stereo occlusion), so each of its pixels
/// takes the farthest (smallest) of its own plane and the planes of the cells at the run's two
/// ends: d = min(θ_own, θ_left, θ_right). Pixels with input disparity are left untouched.
void prefer_background_in_holes(cv::Mat& dense, const cv::Mat& input_disparity,
                                const cv::Mat& labels, const std::vector<Planecell>& cells);

}  // namespace planecell::extraction
