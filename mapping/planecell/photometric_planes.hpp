#pragma once
/// Photometric refinement of each planecell's disparity plane against the stereo pair.
///
/// SGM's path aggregation penalises disparity changes between neighbours (P1, P2), which favours
/// fronto-parallel surfaces: on a slanted surface (the road) the paths lag behind the true slope.
/// Where the paths of opposite directions balance, the lag cancels; near an image border only the
/// paths arriving from inside the image have history, so the road's bottom rows come out too far
/// (−0.4 … −1.6 px on the 1242×375 street) and the first road rows too near. A plane fitted to that
/// disparity inherits the bias, which is range dependent: a map built from such planes is bent,
/// and a pose aligned to it pitches and sinks.
///
/// The raw matching evidence has no smoothness term. Each cell's plane θ = (a, b, c),
/// d(u, v) = a·u + b·v + c, is therefore refined by minimising the cell's photometric error
///   E(θ, α, β) = Σ_p ρ( I_L(p) − α·I_R(u − d(p), v) − β ),
/// over textured pixels p of the cell (|∂I_L/∂u| ≥ min_gradient), with α, β the brightness gain
/// and offset between the two cameras and ρ Huber's loss. I_R is interpolated linearly along the
/// row (the pair is rectified); ∂r/∂θ = α·∂I_R/∂u · (u, v, 1), ∂r/∂β = −1, ∂r/∂α = −I_R.
/// Both images are smoothed by a 3×3 Gaussian first (wider convergence basin, less noise).
/// Ceres solves each cell (Levenberg–Marquardt, dense normal equations, analytic Jacobian). The refined plane
/// replaces the RANSAC one only when E falls below min_cost_ratio of the fitted plane's E, no
/// sample moves by more than max_shift_px and α stays in (0.5, 2): a cell whose texture does not
/// pin the plane, or whose better photometric fit is marginal (non-planar content, occlusion
/// inside the cell), keeps its fit.
#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/config/planecell_config.hpp"
#include "core/plane.hpp"

namespace planecell::extraction {

/// Fewer textured samples than this in a cell: its plane is kept as fitted (five parameters need
/// many more samples than five to be determined against image noise).
inline constexpr int kMinPhotometricSamples = 40;

/// What the refinement did to a frame's planes.
struct PhotometricPlaneStats {
  int refined = 0;   ///< planes replaced by their photometric refinement
  int kept = 0;      ///< planes tried and kept (too little texture, no gain, or too far)
};

/// Refines `planes[k]` for every k with has_plane[k] ≠ 0 against the rectified pair `left_grey`,
/// `right_grey` (CV_8UC1, same size); `labels` holds the cell index of each pixel (row-major,
/// width × height of the images). The settings are ExtractionConfig's photometric_* fields;
/// photometric_iterations = 0 leaves every plane as it is. A cell with fewer than
/// kMinPhotometricSamples textured samples keeps its plane. Throws InputError on mismatched sizes
/// or types.
PhotometricPlaneStats refine_planes_photometric(const cv::Mat& left_grey, const cv::Mat& right_grey,
                                                std::span<const std::int32_t> labels,
                                                std::span<DisparityPlane> planes,
                                                std::span<const std::uint8_t> has_plane,
                                                const ExtractionConfig& config);

}  // namespace planecell::extraction
