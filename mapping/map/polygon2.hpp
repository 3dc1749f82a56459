#pragma once
/// Boost.Geometry 2D polygon types for the map's in-polygon tests (geometry.cpp, map_queries.cpp).
/// Kept out of geometry.hpp: Boost.Geometry costs seconds of compile time in every includer.
#include <boost/geometry.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/polygon.hpp>
#include <span>

#include "mapping/map/geometry.hpp"

namespace planecell::map {

using Point2 = boost::geometry::model::d2::point_xy<double>;
using Polygon2 = boost::geometry::model::polygon<Point2>;  ///< clockwise, closed

/// The polygon projected orthogonally into `basis`, corrected (closed, clockwise).
Polygon2 to_polygon2(std::span<const Eigen::Vector3f> vertices, const PlaneBasis& basis);

}  // namespace planecell::map
