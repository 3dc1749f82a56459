/// `planecell info PATH` — summarises a sequence folder, a disparity map or an image.
/// Each kind of PATH is one entry of kDescribers (a map store is one more entry).
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <opencv2/core.hpp>
#include <sstream>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/euroc.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "io/map_store.hpp"
#include "io/paths.hpp"
#include "mapping/refine/pose_refinement.hpp"
#include "services/commands/commands.hpp"

namespace planecell::services {
namespace {

namespace fs = std::filesystem;
using io::is_dir;
using io::is_file;
using io::lower_extension;

std::size_t count_files(const fs::path& dir) {
  std::size_t n = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file()) ++n;
  return n;
}

std::string camera_line(const StereoCamera& c) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(3) << "fx " << c.fx << "  fy " << c.fy << "  cx " << c.cx
      << "  cy " << c.cy << "  baseline " << std::setprecision(4) << c.baseline_m << " m";
  return out.str();
}

/// Sum of distances between consecutive camera positions (m).
double path_length_m(const std::vector<Pose>& poses) {
  double length = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i)
    length += (poses[i].translation() - poses[i - 1].translation()).norm();
  return length;
}

// ---- KITTI odometry layout -----------------------------------------------------------------

bool is_kitti_sequence(const fs::path& p) {
  return is_dir(p) && (is_dir(p / "image_0") || is_dir(p / "image_2"));
}

std::string describe_kitti_sequence(const fs::path& dir) {
  std::ostringstream out;
  out << std::fixed;
  const int left_index = is_dir(dir / "image_2") ? 2 : 0;
  const fs::path left_dir = dir / ("image_" + std::to_string(left_index));
  const fs::path right_dir = dir / ("image_" + std::to_string(left_index + 1));
  std::vector<fs::path> left_images;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(left_dir, ec))
    if (entry.is_regular_file()) left_images.push_back(entry.path());
  std::sort(left_images.begin(), left_images.end());
  const std::size_t right_count = is_dir(right_dir) ? count_files(right_dir) : 0;

  out << "KITTI odometry layout: " << dir.string() << "\n";
  out << "  camera pair:  image_" << left_index << "/ + image_" << left_index + 1 << "/ ("
      << (left_index == 2 ? "colour" : "gray") << ")\n";
  out << "  frames:       " << left_images.size() << " left, " << right_count << " right"
      << (is_dir(right_dir) ? "" : " (" + right_dir.filename().string() + "/ missing)") << "\n";
  int width = 0, height = 0;
  if (!left_images.empty()) {
    const cv::Mat first = io::read_image(left_images.front(), false);
    width = first.cols;
    height = first.rows;
    out << "  image size:   " << width << " x " << height << " px\n";
  }
  if (is_file(dir / "calib.txt")) {
    const auto calib = io::read_kitti_calibration(dir / "calib.txt");
    const StereoCamera camera = io::stereo_camera_from_kitti(calib, left_index, width, height);
    out << "  camera:       " << camera_line(camera) << "\n";
  } else {
    out << "  camera:       calib.txt missing\n";
  }
  if (is_file(dir / "times.txt")) {
    const auto times = io::read_kitti_times(dir / "times.txt");
    out << std::setprecision(3) << "  times:        " << times.size() << " rows";
    if (!times.empty())
      out << ", " << times.front() << " .. " << times.back() << " s (span "
          << times.back() - times.front() << " s)";
    out << "\n";
  } else {
    out << "  times:        times.txt missing\n";
  }
  if (const auto poses_file = io::find_kitti_poses_file(dir)) {
    const auto poses = io::read_kitti_poses(*poses_file);
    out << std::setprecision(1) << "  poses:        " << poses.size() << " in "
        << poses_file->string() << ", cam0 path length " << path_length_m(poses) << " m";
    if (poses.size() != left_images.size())
      out << "  (≠ " << left_images.size() << " frames: pass a matching poses file)";
    out << "\n";
  } else {
    out << "  poses:        none found\n";
  }
  out << "  ground truth:";
  for (const char* sub : {"disp_occ_0", "disp_noc_0", "surface_0"}) {
    out << "  " << sub << "/ ";
    if (is_dir(dir / sub))
      out << "(" << count_files(dir / sub) << " files)";
    else
      out << "missing";
  }
  out << "\n";
  return out.str();
}

// ---- EuRoC ---------------------------------------------------------------------------------

bool is_euroc_sequence(const fs::path& p) {
  const fs::path mav0 = is_dir(p / "mav0") ? p / "mav0" : p;
  return is_dir(mav0 / "cam0") && is_file(mav0 / "cam0" / "sensor.yaml");
}

std::string describe_euroc(const fs::path& dir) {
  const auto seq = io::open_euroc(dir);
  std::ostringstream out;
  out << std::fixed << std::setprecision(3);
  std::size_t with_pose = 0;
  for (const auto& p : seq.poses) with_pose += p.has_value();
  out << "EuRoC sequence: " << seq.mav0.string() << "\n";
  out << "  stereo pairs: " << seq.size() << " (cam0 + cam1, raw; rectified on load)\n";
  out << "  image size:   " << seq.camera.width << " x " << seq.camera.height << " px\n";
  out << "  rectified:    " << camera_line(seq.camera) << "\n";
  out << "  time span:    " << (seq.timestamps_ns.back() - seq.timestamps_ns.front()) * 1e-9
      << " s\n";
  out << "  poses:        " << with_pose << " of " << seq.size() << " frames";
  if (!seq.groundtruth_file.empty()) out << " from " << seq.groundtruth_file.string();
  out << "\n";
  return out.str();
}

// ---- single files --------------------------------------------------------------------------

bool is_disparity_file(const fs::path& p) {
  if (!is_file(p)) return false;
  const std::string ext = lower_extension(p);
  if (ext == ".pfm") return true;
  return ext == ".png" && io::read_image_unchanged(p).type() == CV_16UC1;
}

std::string describe_disparity(const fs::path& path) {
  const cv::Mat d = io::read_disparity(path);
  double sum = 0.0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
  std::size_t valid = 0;
  for (int r = 0; r < d.rows; ++r) {
    const float* row = d.ptr<float>(r);
    for (int c = 0; c < d.cols; ++c) {
      if (!is_valid_disparity(row[c])) continue;
      ++valid;
      sum += row[c];
      lo = std::min(lo, static_cast<double>(row[c]));
      hi = std::max(hi, static_cast<double>(row[c]));
    }
  }
  std::ostringstream out;
  out << std::fixed << std::setprecision(2);
  out << "disparity map (" << (lower_extension(path) == ".pfm" ? "PFM" : "KITTI 16-bit PNG")
      << "): " << path.string() << "\n";
  out << "  size:         " << d.cols << " x " << d.rows << " px\n";
  out << "  density:      " << 100.0 * valid / std::max<std::size_t>(1, d.total()) << " % ("
      << valid << " valid px)\n";
  if (valid > 0)
    out << "  disparity:    min " << lo << "  max " << hi << "  mean " << sum / valid << " px\n";
  return out.str();
}

bool is_image_file(const fs::path& p) {
  static const std::vector<std::string> kImageExtensions{".png", ".jpg", ".jpeg", ".ppm",
                                                         ".pgm", ".bmp", ".tif", ".tiff"};
  const std::string ext = lower_extension(p);
  return is_file(p) &&
         std::find(kImageExtensions.begin(), kImageExtensions.end(), ext) != kImageExtensions.end();
}

std::string describe_image(const fs::path& path) {
  const cv::Mat image = io::read_image_unchanged(path);
  std::vector<cv::Mat> channels;
  cv::split(image, channels);
  std::ostringstream out;
  out << std::fixed << std::setprecision(1);
  out << "image: " << path.string() << "\n";
  out << "  size:         " << image.cols << " x " << image.rows << " px, " << image.channels()
      << " channel(s), " << (image.depth() == CV_8U ? 8 : image.depth() == CV_16U ? 16 : 32)
      << "-bit\n";
  for (std::size_t k = 0; k < channels.size(); ++k) {
    double lo = 0.0, hi = 0.0;
    cv::minMaxLoc(channels[k], &lo, &hi);
    out << "  channel " << k << ":    min " << lo << "  max " << hi << "  mean "
        << cv::mean(channels[k])[0] << "\n";
  }
  return out.str();
}

bool is_map_store(const fs::path& path) {
  const std::string ext = lower_extension(path);
  return fs::is_regular_file(path) && (ext == ".db" || ext == ".sqlite");
}

std::string describe_map_store(const fs::path& path) {
  const io::MapStore store(path);
  io::StoredMap contents = store.load();
  const bool settled = contents.settled;
  const map::GlobalMap global_map = io::load_map(std::move(contents));
  std::size_t planecells_with_surface = 0;
  for (const auto& [id, cell] : global_map.cells())
    if (cell.surface != kNoSurface) ++planecells_with_surface;
  double area_m2 = 0.0;
  for (const auto& [id, surface] : global_map.surfaces()) area_m2 += surface.area_m2;
  std::ostringstream out;
  out << std::fixed << std::setprecision(1);
  out << "planecell map store: " << path.string() << "\n";
  out << "  frames:       " << store.frame_count() << " committed"
      << (settled ? ", the map settled after the last (its session closed)" : "") << "\n";
  out << "  cells:        " << global_map.cells().size() << " (" << planecells_with_surface
      << " with a surface label)\n";
  out << "  surfaces:     " << global_map.surfaces().size() << " ("
      << map::dormant_surface_count(global_map) << " dormant), " << area_m2 << " m² in all\n";
  out << "  merges:       " << store.merge_history().size() << " surface merges recorded\n";
  // Where the map is: the bounds of every integrated cell (the surfaces' bounds, fused
  // re-observations included), and how far the camera went (path_length_m, frame order).
  map::Aabb extent;
  for (const auto& [id, surface] : global_map.surfaces()) extent.extend(surface.bounds);
  if (!extent.empty())
    out << "  extent:       x " << extent.min.x() << " … " << extent.max.x() << ", y "
        << extent.min.y() << " … " << extent.max.y() << ", z " << extent.min.z() << " … "
        << extent.max.z() << " m (world frame)\n";
  // One pass over the committed frames: their poses, and the refined ones' corrections.
  const std::vector<std::uint64_t> frame_ids = store.frame_ids();
  std::vector<Pose> poses;
  std::size_t refined = 0;
  double sum_m = 0.0, max_m = 0.0, max_deg = 0.0;
  for (const std::uint64_t id : frame_ids) {
    const auto pose = store.pose(id);
    if (!pose) continue;
    poses.push_back(*pose);
    const auto input = store.input_pose(id);  // the odometry pose the refinement replaced
    if (!input) continue;
    ++refined;
    const auto correction = refine::correction_between(*input, *pose);  // (ω rad, τ m)
    const double moved_m = correction.tail<3>().norm();
    sum_m += moved_m;
    max_m = std::max(max_m, moved_m);
    max_deg = std::max(max_deg, correction.head<3>().norm() * 180.0 / std::numbers::pi);
  }
  if (!frame_ids.empty())
    out << "  trajectory:   frames " << frame_ids.front() << " … " << frame_ids.back() << ", "
        << std::setprecision(2) << path_length_m(poses) << " m driven\n"
        << std::setprecision(1);
  if (refined > 0)
    out << "  refinement:   " << refined << " of " << frame_ids.size()
        << " frames refined (odometry poses kept); correction mean " << std::setprecision(3)
        << sum_m / static_cast<double>(refined) << " m, max " << max_m << " m / " << max_deg
        << " deg\n"
        << std::setprecision(1);
  const map::MapBytes ram = global_map.map_bytes_by_part();
  out << "  map in RAM:   " << ram.total() / 1024.0 << " KiB (cells " << ram.cells / 1024.0
      << ", vertices " << ram.vertices / 1024.0 << ", surfaces " << ram.surfaces / 1024.0
      << ", footprints " << ram.footprints / 1024.0 << ", index " << ram.index / 1024.0 << ")\n";
  out << "  file size:    " << fs::file_size(path) / 1024.0 << " KiB\n";
  const io::StoreBytes stored = store.bytes_by_part();
  out << "  store pages:  " << stored.total() / 1024.0 << " KiB (cells " << stored.cells / 1024.0
      << ", cell-bounds R*Tree " << stored.bounds / 1024.0 << ", surfaces "
      << stored.surfaces / 1024.0 << ", frames " << stored.frames / 1024.0 << ", merges "
      << stored.merges / 1024.0 << ", schema " << stored.other / 1024.0 << ", free "
      << stored.free / 1024.0 << ")\n";
  return out.str();
}

/// One kind of PATH `planecell info` understands (first match wins).
struct Describer {
  const char* kind;
  bool (*matches)(const fs::path&);
  std::string (*describe)(const fs::path&);
};

const Describer kDescribers[] = {
    {"planecell map store (.db)", is_map_store, describe_map_store},
    {"KITTI odometry layout folder", is_kitti_sequence, describe_kitti_sequence},
    {"EuRoC folder", is_euroc_sequence, describe_euroc},
    {"disparity map", is_disparity_file, describe_disparity},
    {"image", is_image_file, describe_image},
};

std::string describe_path(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError("info: '" + path.string() + "' does not exist");
  for (const auto& describer : kDescribers)
    if (describer.matches(path)) return describer.describe(path);
  std::string kinds;
  for (const auto& describer : kDescribers)
    kinds += std::string(kinds.empty() ? "" : ", ") + describer.kind;
  throw InputError("info: '" + path.string() + "' is not something planecell knows (expected: " +
                   kinds + ")");
}

}  // namespace

void add_info_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand(
      "info",
      "Summarise a dataset folder or file: a KITTI-odometry-layout sequence (frames, image "
      "size, camera, time span, poses, path length, GT folders), a EuRoC folder, a disparity map "
      "(.pfm or KITTI 16-bit .png: size, density, min/max/mean), an image, or a map store "
      "written by `planecell replay --map` (frames, cells, surfaces, world extent, distance "
      "driven, refined poses, RAM and store bytes by part).");
  auto path = std::make_shared<std::string>();
  command->add_option("path", *path, "Folder or file to summarise")->required();
  command->footer(
      "Examples:\n"
      "  planecell info /tmp/street                          # a `planecell synth` output\n"
      "  planecell info dataset/sequences/00                 # KITTI odometry (poses in ../../poses)\n"
      "  planecell info V1_01_easy                           # EuRoC (folder holding mav0/)\n"
      "  planecell info training/disp_occ_0/000000_10.png    # KITTI GT disparity\n"
      "  planecell info disparity/left/A-0032-0006.pfm       # PFM disparity\n"
      "  planecell info teddy/im2.png                        # an image\n"
      "  planecell info /tmp/street.db                       # a stored map\n");
  context.add(command, [path](const CommandContext&) {
    std::cout << describe_path(*path);
    return kExitOk;
  });
}

}  // namespace planecell::services
