#pragma once
/// Vertex extraction (paper §5): an ordered polygon per segment of a label image.
#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <vector>

namespace planecell::extraction {

/// Polygon of every label 0..num_labels−1 of a CV_32S label image (empty for absent labels).
///
/// The paper's rule, stated on the lattice of pixel corners: at a corner point, look at the four
/// pixels around it. For segment S the point is a *boundary* point when S owns two of them that
/// are horizontal or vertical neighbours (a straight edge), and a *vertex* when S owns one or
/// three of them (convex/concave corner) or two diagonal ones, or when three or more segments
/// (the outside of the image counting as one) meet there, or at the image corners (junctions,
/// shared by all the segments that meet there).
/// The outer boundary of each (4-connected) segment is traced clockwise in image coordinates
/// (x right, y down) from the top-left corner of its first pixel in raster order; its vertices
/// are returned in that order, in pixel-centre coordinates (pixel (u, v) covers
/// [u − ½, u + ½] × [v − ½, v + ½]), so the polygon's area equals the segment's pixel count.
/// Holes are not represented. With tolerance_px > 0 each chain between two junctions is
/// simplified by Douglas–Peucker (junctions are kept, so neighbours simplify shared edges alike).
/// With junctions_only, a polygon with ≥ 3 junctions keeps only them (the compact form: shared
/// edges become straight and identical in both neighbours); others fall back to Douglas–Peucker
/// with at least 1 px tolerance.
std::vector<std::vector<Eigen::Vector2f>> extract_polygons(const cv::Mat& labels, int num_labels,
                                                           double tolerance_px = 0.0,
                                                           bool junctions_only = false);

}  // namespace planecell::extraction
