#include "io/euroc_to_kitti.hpp"

#include <opencv2/imgproc.hpp>

#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"

namespace planecell::io {
namespace {

cv::Mat grey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat out;
  cv::cvtColor(image, out, cv::COLOR_BGR2GRAY);
  return out;
}

}  // namespace

EurocExport write_euroc_as_kitti(const EurocSequence& sequence, const std::filesystem::path& out_dir) {
  std::vector<std::size_t> posed;
  for (std::size_t i = 0; i < sequence.size(); ++i)
    if (i < sequence.poses.size() && sequence.poses[i]) posed.push_back(i);
  if (posed.empty())
    throw InputError("EuRoC sequence '" + sequence.mav0.string() +
                     "': no stereo pair has a ground-truth pose within 20 ms");
  std::error_code ec;
  for (const char* sub : {"image_0", "image_1", "poses"}) {
    std::filesystem::create_directories(out_dir / sub, ec);
    if (ec) throw StorageError("cannot create '" + (out_dir / sub).string() + "': " + ec.message());
  }

  EurocExport out;
  out.camera = sequence.camera;
  out.skipped_frames = sequence.size() - posed.size();
  const StereoCamera& c = sequence.camera;
  KittiCalibration calib;
  const std::array<double, 12> left = {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  std::array<double, 12> right = left;
  right[3] = -c.fx * c.baseline_m;
  calib.projection = {left, right, left, right};
  write_kitti_calibration(out_dir / "calib.txt", calib);

  const Pose first_inverse = sequence.poses[posed.front()]->inverse();
  const double t0 = static_cast<double>(sequence.timestamps_ns[posed.front()]) * 1e-9;
  std::vector<Pose> poses;
  std::vector<double> times;
  for (std::size_t k = 0; k < posed.size(); ++k) {
    const std::size_t i = posed[k];
    const StereoFrame frame = load_euroc_frame(sequence, i);
    write_image(out_dir / "image_0" / kitti_frame_name(k), grey(frame.left), 1);
    write_image(out_dir / "image_1" / kitti_frame_name(k), grey(frame.right), 1);
    Pose relative = first_inverse * *sequence.poses[i];
    validate_pose(relative, "EuRoC pose of frame " + std::to_string(i));
    poses.push_back(relative);
    times.push_back(static_cast<double>(sequence.timestamps_ns[i]) * 1e-9 - t0);
    ++out.frames;
  }
  write_kitti_poses(out_dir / "poses" / "00.txt", poses);
  out.poses = std::move(poses);
  write_kitti_times(out_dir / "times.txt", times);
  return out;
}

}  // namespace planecell::io
