#include "io/sequence_ground_truth.hpp"

#include <filesystem>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"

namespace planecell::io {
namespace fs = std::filesystem;
namespace {

fs::path beside(const KittiOdometrySequence& sequence, const char* folder, std::size_t index) {
  return sequence.root / folder / sequence.left_images.at(index).filename().replace_extension(".png");
}

void check_size(const cv::Mat& m, const fs::path& path, int width, int height) {
  if (m.cols != width || m.rows != height)
    throw InputError("ground truth '" + path.string() + "': " + std::to_string(m.cols) + "x" +
                     std::to_string(m.rows) + " does not match the frame's " + std::to_string(width) +
                     "x" + std::to_string(height));
}

}  // namespace

bool has_surface_ground_truth(const KittiOdometrySequence& sequence) {
  return fs::is_directory(sequence.root / "surface_0");
}

std::optional<FrameGroundTruth> load_sequence_ground_truth(const KittiOdometrySequence& sequence,
                                                           std::size_t index, int width, int height) {
  if (index >= sequence.size())
    throw InputError("ground truth: frame " + std::to_string(index) + " is beyond the sequence's " +
                     std::to_string(sequence.size()) + " frames");
  FrameGroundTruth gt;
  const fs::path disparity_path = beside(sequence, "disp_occ_0", index);
  if (fs::exists(disparity_path)) {
    gt.disparity = read_kitti_disparity(disparity_path);
    check_size(gt.disparity, disparity_path, width, height);
  }
  const fs::path surface_path = beside(sequence, "surface_0", index);
  if (fs::exists(surface_path)) {
    gt.surface_id = read_image_unchanged(surface_path);
    if (gt.surface_id.type() != CV_16UC1)
      throw InputError("ground truth '" + surface_path.string() +
                       "': surface ids must be a 16-bit single-channel PNG");
    check_size(gt.surface_id, surface_path, width, height);
  }
  if (gt.disparity.empty() && gt.surface_id.empty()) return std::nullopt;
  return gt;
}

}  // namespace planecell::io
