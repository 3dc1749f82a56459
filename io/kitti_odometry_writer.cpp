/// Writers of the KITTI odometry text files (calib.txt, poses/NN.txt, times.txt).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "core/error.hpp"
#include "io/kitti_odometry.hpp"

namespace planecell::io {
namespace {

std::ofstream open_for_writing(const std::filesystem::path& path, const char* what) {
  if (path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec)
      throw StorageError(std::string(what) + " '" + path.string() +
                         "': cannot create folder: " + ec.message());
  }
  std::ofstream out(path);
  if (!out) throw StorageError(std::string(what) + " '" + path.string() + "': cannot open for writing");
  return out;
}

void finish(std::ofstream& out, const std::filesystem::path& path, const char* what) {
  out.flush();
  if (!out) throw StorageError(std::string(what) + " '" + path.string() + "': write failed (disk full?)");
}

/// Twelve numbers in %.12e separated by single spaces.
std::string format_row(const double* values, int count, const char* format) {
  std::string line;
  char buffer[64];
  for (int i = 0; i < count; ++i) {
    std::snprintf(buffer, sizeof(buffer), format, values[i]);
    if (i > 0) line += ' ';
    line += buffer;
  }
  return line;
}

}  // namespace

void write_kitti_calibration(const std::filesystem::path& path, const KittiCalibration& calib) {
  for (const auto& p : calib.projection)
    for (double v : p)
      if (!std::isfinite(v))
        throw StorageError("calibration '" + path.string() + "': projection holds NaN or Inf");
  auto out = open_for_writing(path, "calibration");
  for (int i = 0; i < 4; ++i)
    out << 'P' << i << ": " << format_row(calib.projection[i].data(), 12, "%.12e") << '\n';
  const double identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  out << "Tr: " << format_row(identity, 12, "%.12e") << '\n';
  finish(out, path, "calibration");
}

void write_kitti_poses(const std::filesystem::path& path, const std::vector<Pose>& poses) {
  auto out = open_for_writing(path, "poses");
  for (std::size_t i = 0; i < poses.size(); ++i) {
    double row[12];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) row[r * 4 + c] = poses[i].matrix()(r, c);
    for (double v : row)
      if (!std::isfinite(v))
        throw StorageError("poses '" + path.string() + "': pose " + std::to_string(i) +
                           " holds NaN or Inf");
    out << format_row(row, 12, "%.9e") << '\n';
  }
  finish(out, path, "poses");
}

void write_kitti_times(const std::filesystem::path& path, const std::vector<double>& times_s) {
  auto out = open_for_writing(path, "times");
  for (std::size_t i = 0; i < times_s.size(); ++i) {
    if (!std::isfinite(times_s[i]))
      throw StorageError("times '" + path.string() + "': time " + std::to_string(i) +
                         " is NaN or Inf");
    out << format_row(&times_s[i], 1, "%.6e") << '\n';
  }
  finish(out, path, "times");
}

std::string kitti_frame_name(std::size_t index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%06zu.png", index);
  return buffer;
}

}  // namespace planecell::io
