#include "mapping/voxel/voxel_map.hpp"

#include <octomap/ColorOcTree.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "core/error.hpp"

namespace planecell::voxel {
namespace {

/// Sum of colours of the points falling into one voxel.
struct ColourSum {
  std::uint64_t r = 0, g = 0, b = 0, count = 0;
};

/// Size in bytes of the .bt file AbstractOccupancyOcTree::writeBinaryConst writes for `tree`:
///   "# Octomap OcTree binary file\n# (feel free …)\n#\nid <type>\nsize <n>\nres <r>\ndata\n"
/// followed by writeBinaryNode(root): 2 bytes (2 bits per child) per node that has children.
/// Rebuilt here instead of calling writeBinaryConst because its writeBinaryData prints "Writing N
/// nodes to output stream... done." on stderr in Debian's liboctomap (built with OCTOMAP_DEBUG; the
/// template is instantiated inside the shared library, so OCTOMAP_NODEBUGOUT here cannot silence
/// it); writeBinaryNode prints nothing. The header text is octomap 1.9's (binaryFileHeader is
/// protected); tests check the total against writeBinaryConst's real output.
std::size_t bt_size_bytes(const octomap::ColorOcTree& tree) {
  std::ostringstream s;
  s << "# Octomap OcTree binary file\n"
    << "# (feel free to add / change comments, but leave the first line as it is!)\n#\n"
    << "id " << tree.getTreeType() << '\n'
    << "size " << tree.size() << '\n'
    << "res " << tree.getResolution() << '\n'
    << "data\n";
  if (tree.getRoot()) tree.writeBinaryNode(s, tree.getRoot());
  return s.str().size();
}

}  // namespace

ColouredPoints back_project(const cv::Mat& disparity_px, const cv::Mat& image,
                            const StereoCamera& camera, const Pose& T_world_cam,
                            double max_range_m, int stride) {
  if (disparity_px.empty() || disparity_px.type() != CV_32F)
    throw InputError("back_project: disparity must be a non-empty CV_32F map");
  if (image.size() != disparity_px.size() || (image.type() != CV_8UC3 && image.type() != CV_8UC1))
    throw InputError("back_project: colour image must be CV_8UC3/CV_8UC1 of the disparity's size (" +
                     std::to_string(disparity_px.cols) + "x" + std::to_string(disparity_px.rows) + ")");
  if (stride < 1) throw InputError("back_project: stride must be >= 1");
  camera.validate("back_project camera");
  validate_pose(T_world_cam, "back_project pose");
  ColouredPoints out;
  out.origin_m = T_world_cam.translation().cast<float>();
  const Eigen::Isometry3f pose = T_world_cam.cast<float>();
  for (int v = 0; v < disparity_px.rows; v += stride) {
    const float* row = disparity_px.ptr<float>(v);
    for (int u = 0; u < disparity_px.cols; u += stride) {
      const float d = row[u];
      if (!std::isfinite(d) || d <= 0.0f) continue;
      const Eigen::Vector3d x_cam = camera.back_project(u, v, d);
      if (x_cam.norm() > max_range_m) continue;
      out.points_m.push_back(pose * x_cam.cast<float>());
      if (image.type() == CV_8UC3) {
        const auto& bgr = image.at<cv::Vec3b>(v, u);
        out.rgb.push_back({bgr[2], bgr[1], bgr[0]});
      } else {
        const auto grey = image.at<std::uint8_t>(v, u);
        out.rgb.push_back({grey, grey, grey});
      }
    }
  }
  return out;
}

VoxelMap::VoxelMap(const VoxelConfig& config) : config_(config) {
  if (!(config.resolution_m > 0.0) || !std::isfinite(config.resolution_m))
    throw ConfigError("voxel.resolution_m: must be > 0, got " + std::to_string(config.resolution_m));
  if (!(config.max_range_m > 0.0))
    throw ConfigError("voxel.max_range_m: must be > 0, got " + std::to_string(config.max_range_m));
  tree_ = std::make_unique<octomap::ColorOcTree>(config.resolution_m);
}

VoxelMap::~VoxelMap() = default;

VoxelInsertStats VoxelMap::insert(const ColouredPoints& points) {
  if (points.points_m.size() != points.rgb.size())
    throw InputError("voxel insert: " + std::to_string(points.points_m.size()) + " points but " +
                     std::to_string(points.rgb.size()) + " colours");
  const auto start = std::chrono::steady_clock::now();
  std::unordered_map<octomap::OcTreeKey, ColourSum, octomap::OcTreeKey::KeyHash> voxels;
  voxels.reserve(points.points_m.size() / 4 + 16);
  for (std::size_t i = 0; i < points.points_m.size(); ++i) {
    const auto& p = points.points_m[i];
    octomap::OcTreeKey key;
    if (!tree_->coordToKeyChecked(octomap::point3d(p.x(), p.y(), p.z()), key)) continue;
    ColourSum& sum = voxels[key];
    sum.r += points.rgb[i][0], sum.g += points.rgb[i][1], sum.b += points.rgb[i][2];
    ++sum.count;
  }
  if (config_.ray_casting) {
    octomap::Pointcloud cloud;
    cloud.reserve(points.points_m.size());
    for (const auto& p : points.points_m) cloud.push_back(p.x(), p.y(), p.z());
    const auto& o = points.origin_m;
    tree_->insertPointCloud(cloud, octomap::point3d(o.x(), o.y(), o.z()), config_.max_range_m);
  } else {
    for (const auto& [key, sum] : voxels) tree_->updateNode(key, true, /*lazy_eval=*/true);
  }
  for (const auto& [key, sum] : voxels)
    tree_->integrateNodeColor(key, static_cast<std::uint8_t>(std::lround(double(sum.r) / sum.count)),
                              static_cast<std::uint8_t>(std::lround(double(sum.g) / sum.count)),
                              static_cast<std::uint8_t>(std::lround(double(sum.b) / sum.count)));
  tree_->updateInnerOccupancy();
  VoxelInsertStats stats;
  stats.points = points.points_m.size();
  stats.voxels = voxels.size();
  stats.insert_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

std::size_t VoxelMap::occupied_voxels() const {
  std::size_t count = 0;
  const unsigned max_depth = tree_->getTreeDepth();
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it)
    if (tree_->isNodeOccupied(*it)) count += std::size_t{1} << (3 * (max_depth - it.getDepth()));
  return count;
}

std::vector<Eigen::Vector3d> VoxelMap::occupied_centres() const {
  std::vector<Eigen::Vector3d> centres;
  const double r = tree_->getResolution();
  const unsigned max_depth = tree_->getTreeDepth();
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    if (!tree_->isNodeOccupied(*it)) continue;
    const auto c = it.getCoordinate();
    const int n = 1 << (max_depth - it.getDepth());  // voxels along each edge of the leaf
    const Eigen::Vector3d first = Eigen::Vector3d(c.x(), c.y(), c.z()) - Eigen::Vector3d::Constant(0.5 * (n - 1) * r);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) centres.push_back(first + r * Eigen::Vector3d(i, j, k));
  }
  return centres;
}

VoxelMapStats VoxelMap::stats() const {
  VoxelMapStats s;
  s.occupied_voxels = occupied_voxels();
  s.memory_bytes = tree_->memoryUsage();
  std::ostringstream ot;
  tree_->write(ot);  // AbstractOcTree::write / OcTree writeData print nothing
  s.ot_bytes = ot.str().size();
  s.bt_bytes = bt_size_bytes(*tree_);
  return s;
}

std::optional<Rgb> VoxelMap::colour_at(const Eigen::Vector3d& point) const {
  const octomap::ColorOcTreeNode* node = tree_->search(point.x(), point.y(), point.z());
  if (!node || !tree_->isNodeOccupied(node)) return std::nullopt;
  const auto c = node->getColor();
  return Rgb{c.r, c.g, c.b};
}

}  // namespace planecell::voxel
