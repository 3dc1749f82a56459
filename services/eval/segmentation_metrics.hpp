#pragma once
/// How well planecells follow ground-truth surfaces (synthetic sequences): boundary recall and
/// the share of cells lying on one surface (an undersegmentation-style score).
#include <filesystem>
#include <opencv2/core/mat.hpp>

#include "core/config/planecell_config.hpp"
#include "core/config/sgm_config.hpp"
#include "io/stereo_datasets.hpp"

namespace planecell::services::eval {

/// Scoring choices of evaluate_segmentation.
struct SegmentationOptions {
  int boundary_tolerance_px =
      2;                ///< r: a GT boundary pixel counts when a cell boundary is this near
  double purity = 0.9;  ///< a cell "lies on one surface" with ≥ this share of its pixels
};

/// Counts of one label image against GT surface ids; they add over frames (pooled figures).
///  * boundary recall: a pixel is a boundary pixel of an id image when one of its 4-neighbours
///    has another id. A GT boundary pixel is recalled when a cell boundary pixel lies within
///    Chebyshev distance r of it (a (2r+1)×(2r+1) window).
///  * single-surface cells: a cell lies on one surface when at least `purity` of its pixels carry
///    its most frequent GT id (GT id 0, "no surface", counts as a surface of its own).
struct SegmentationScores {
  long gt_boundary_pixels = 0;
  long recalled_boundary_pixels = 0;
  long cells = 0;
  long single_surface_cells = 0;

  SegmentationScores& operator+=(const SegmentationScores& o);
  /// 100·recalled/GT boundary pixels; NaN without GT boundaries.
  double boundary_recall_pct() const;
  /// 100·single-surface cells/cells; NaN without cells.
  double single_surface_pct() const;
};

/// Scores cell `labels` (CV_32S, ids ≥ 0) against GT `surfaces` (CV_16U or CV_32S ids) of the
/// same size. Throws InputError on empty images, other types, negative labels or a size
/// mismatch; ConfigError on a negative tolerance or a purity outside (0, 1].
SegmentationScores evaluate_segmentation(const cv::Mat& labels, const cv::Mat& surfaces,
                                         const SegmentationOptions& options = {});

/// GT surface ids of a synthetic pair (SEQ/surface_0/<frame>.png beside SEQ/image_2/<frame>.png,
/// written by `planecell synth`), CV_16U; empty when the file does not exist. Throws InputError
/// naming the file when it is unreadable or not single-channel 16-bit.
cv::Mat synthetic_surface_ids(const io::StereoSampleRef& ref);

/// The planecells of `sample` as the "planecell" stereo method makes them (planecell SGM with
/// `sgm`, max_disparity from the sample, then extract_planecells with `extraction`), scored
/// against `surfaces`.
SegmentationScores planecell_segmentation(const io::StereoSample& sample, const cv::Mat& surfaces,
                                          const SgmConfig& sgm, const ExtractionConfig& extraction,
                                          const SegmentationOptions& options = {});

}  // namespace planecell::services::eval
