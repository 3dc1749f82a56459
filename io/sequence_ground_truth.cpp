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

void check_index(const KittiOdometrySequence& sequence, std::size_t index) {
  if (index >= sequence.size())
    throw InputError("ground truth: frame " + std::to_string(index) + " is beyond the sequence's " +
                     std::to_string(sequence.size()) + " frames");
}

}  // namespace

bool has_surface_ground_truth(const KittiOdometrySequence& sequence) {
  return fs::is_directory(sequence.root / "surface_0");
}

cv::Mat load_surface_ids(const KittiOdometrySequence& sequence, std::size_t index, int width, int height) {
  check_index(sequence, index);
  const fs::path path = beside(sequence, "surface_0", index);
  if (!fs::exists(path)) return {};
  cv::Mat ids = read_image_unchanged(path);
  if (ids.type() != CV_16UC1)
    throw InputError("ground truth '" + path.string() + "': surface ids must be a 16-bit single-channel PNG");
  check_size(ids, path, width, height);
  return ids;
}

bool has_disparity_ground_truth(const KittiOdometrySequence& sequence) {
  return fs::is_directory(sequence.root / "disp_occ_0");
}

cv::Mat load_disparity_ground_truth(const KittiOdometrySequence& sequence, std::size_t index,
                                    int width, int height) {
  check_index(sequence, index);
  const fs::path path = beside(sequence, "disp_occ_0", index);
  if (!fs::exists(path)) return {};
  cv::Mat disparity = read_kitti_disparity(path);
  check_size(disparity, path, width, height);
  return disparity;
}

}  // namespace planecell::io
