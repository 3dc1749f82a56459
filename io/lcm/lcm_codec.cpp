#include "io/lcm/lcm_codec.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <future>
#include <string>

#include "core/error.hpp"
#include "io/image_io.hpp"

namespace planecell::io {
namespace {

bool finite(double v) { return std::isfinite(v); }

template <class T, std::size_t N>
bool all_finite(const T (&values)[N]) {
  for (const T v : values)
    if (!std::isfinite(v)) return false;
  return true;
}

std::string frame_name(std::int64_t frame_id) { return "frame " + std::to_string(frame_id); }

/// Big-endian int32 at `offset`, or nullopt past the end.
std::optional<std::int32_t> wire_int32(std::span<const std::uint8_t> bytes, std::size_t offset) {
  if (offset + 4 > bytes.size()) return std::nullopt;
  const std::uint32_t v = (std::uint32_t{bytes[offset]} << 24) | (std::uint32_t{bytes[offset + 1]} << 16) |
                          (std::uint32_t{bytes[offset + 2]} << 8) | std::uint32_t{bytes[offset + 3]};
  return static_cast<std::int32_t>(v);
}

}  // namespace

namespace {

[[noreturn]] void decode_failed(const char* what, std::size_t size) {
  throw InputError(std::string(what) + ": " + std::to_string(size) +
                   " bytes are not one whole message of this type (wrong type, truncated or corrupt)");
}

template <class Message>
Message decode_checked(std::span<const std::uint8_t> bytes, const char* what) {
  Message message;
  int used = -1;
  try {
    used = message.decode(bytes.data(), 0, static_cast<int>(bytes.size()));
  } catch (const std::exception&) {  // bad_alloc / length_error from a corrupt count
    used = -1;
  }
  if (used < 0 || static_cast<std::size_t>(used) != bytes.size()) decode_failed(what, bytes.size());
  return message;
}

/// Checks an int32 count at `offset` against the bytes left, each element taking `element_bytes`;
/// returns the offset after the count.
std::size_t check_count(std::span<const std::uint8_t> bytes, std::size_t offset, std::size_t element_bytes,
                        const char* what, std::int32_t* count_out = nullptr) {
  const auto count = wire_int32(bytes, offset);
  if (!count || *count < 0 || static_cast<std::size_t>(*count) * element_bytes > bytes.size() - offset - 4)
    decode_failed(what, bytes.size());
  if (count_out) *count_out = *count;
  return offset + 4;
}

}  // namespace

planecell_lcm::stereo_frame_t decode_stereo_frame(std::span<const std::uint8_t> bytes) {
  constexpr const char* what = "stereo_frame_t";
  std::int32_t left = 0;
  std::size_t at = check_count(bytes, 74, 1, what, &left);  // after hash, times, size, camera
  check_count(bytes, at + static_cast<std::size_t>(left), 1, what);
  return decode_checked<planecell_lcm::stereo_frame_t>(bytes, what);
}

planecell_lcm::pose_t decode_pose(std::span<const std::uint8_t> bytes) {
  return decode_checked<planecell_lcm::pose_t>(bytes, "pose_t");
}

planecell_lcm::map_update_t decode_map_update(std::span<const std::uint8_t> bytes) {
  constexpr const char* what = "map_update_t";
  constexpr std::size_t kCellFixedBytes = 68;     // planecell_t without its 12 bytes per vertex
  constexpr std::size_t kVertexCountAt = 64;      // offset of num_vertices in a planecell_t
  std::int32_t cells = 0;
  std::size_t at = check_count(bytes, 48, kCellFixedBytes, what, &cells);
  for (std::int32_t i = 0; i < cells; ++i) {
    std::int32_t vertices = 0;
    check_count(bytes, at + kVertexCountAt, 12, what, &vertices);
    at += kCellFixedBytes + 12 * static_cast<std::size_t>(vertices);
  }
  for (const std::size_t element : {8, 4, 8, 4}) {  // relabels, removals, merges, removed surfaces
    std::int32_t count = 0;
    at = check_count(bytes, at, element, what, &count);
    at += element * static_cast<std::size_t>(count);
  }
  at += 1;  // settled (boolean)
  if (at != bytes.size()) decode_failed(what, bytes.size());
  return decode_checked<planecell_lcm::map_update_t>(bytes, what);
}

planecell_lcm::map_stats_t decode_map_stats(std::span<const std::uint8_t> bytes) {
  constexpr const char* what = "map_stats_t";
  // Walks the layout so that no count reaches the generated decoder's resize unchecked: hash,
  // utime and five counters (56 bytes); num_stages, each stage name (int32 length incl. NUL, then
  // the bytes) and three floats per stage; num_queues, each queue name and an int32 depth; two
  // int64 map sizes.
  auto skip_strings = [&](std::size_t at, std::int32_t count) {
    for (std::int32_t i = 0; i < count; ++i) {
      std::int32_t length = 0;
      at = check_count(bytes, at, 1, what, &length);
      at += static_cast<std::size_t>(length);
    }
    return at;
  };
  std::int32_t stages = 0, queues = 0;
  std::size_t at = check_count(bytes, 56, 17, what, &stages);  // a stage: name ≥ 5 bytes, 3 floats
  at = skip_strings(at, stages) + 12 * static_cast<std::size_t>(stages);
  at = check_count(bytes, at, 9, what, &queues);  // a queue: name ≥ 5 bytes, an int32
  at = skip_strings(at, queues) + 4 * static_cast<std::size_t>(queues);
  if (at + 16 != bytes.size()) decode_failed(what, bytes.size());
  return decode_checked<planecell_lcm::map_stats_t>(bytes, what);
}

// --- stereo frames --------------------------------------------------------------------------------

namespace {

/// The message's header fields: ids, time, size, channels, encoding and camera.
planecell_lcm::stereo_frame_t stereo_header(std::uint64_t frame_id, const StereoCamera& camera, int width,
                                            int height, int channels, ImageEncoding encoding,
                                            std::int64_t utime) {
  planecell_lcm::stereo_frame_t m;
  m.utime = utime;
  m.frame_id = static_cast<std::int64_t>(frame_id);
  m.width = width;
  m.height = height;
  m.channels = static_cast<std::int8_t>(channels);
  m.encoding = static_cast<std::int8_t>(encoding);
  m.fx = camera.fx;
  m.fy = camera.fy;
  m.cx = camera.cx;
  m.cy = camera.cy;
  m.baseline_m = camera.baseline_m;
  return m;
}

}  // namespace

planecell_lcm::stereo_frame_t to_lcm(const StereoFrame& frame, ImageEncoding encoding, std::int64_t utime) {
  const std::string name = frame_name(static_cast<std::int64_t>(frame.frame_id));
  if (frame.left.empty() || frame.right.empty()) throw InputError("stereo frame " + name + ": empty image");
  if (frame.left.size() != frame.right.size() || frame.left.type() != frame.right.type())
    throw InputError("stereo frame " + name + ": left and right differ in size or type");
  if (frame.left.depth() != CV_8U || (frame.left.channels() != 1 && frame.left.channels() != 3))
    throw InputError("stereo frame " + name + ": images must be 8-bit gray or BGR");
  planecell_lcm::stereo_frame_t m = stereo_header(frame.frame_id, frame.camera, frame.left.cols, frame.left.rows,
                                                  frame.left.channels(), encoding, utime);
  auto pack = [&](const cv::Mat& image, std::vector<std::uint8_t>& out) {
    if (encoding == ImageEncoding::kPng) {
      if (!cv::imencode(".png", image, out, {cv::IMWRITE_PNG_COMPRESSION, 1}))
        throw InputError("stereo frame " + name + ": PNG encoding failed");
    } else {
      const cv::Mat contiguous = image.isContinuous() ? image : image.clone();
      out.assign(contiguous.data, contiguous.data + contiguous.total() * contiguous.elemSize());
    }
  };
  pack(frame.left, m.left);
  pack(frame.right, m.right);
  m.left_size = static_cast<std::int32_t>(m.left.size());
  m.right_size = static_cast<std::int32_t>(m.right.size());
  return m;
}

planecell_lcm::stereo_frame_t to_lcm_png(std::uint64_t frame_id, const StereoCamera& camera,
                                         std::vector<std::uint8_t> left_png,
                                         std::vector<std::uint8_t> right_png, std::int64_t utime) {
  const std::string name = frame_name(static_cast<std::int64_t>(frame_id));
  const auto left = io::png_header_size(left_png), right = io::png_header_size(right_png);
  if (!left || !right)
    throw InputError("stereo frame " + name + ": " + (left ? "right" : "left") +
                     " image is not a PNG (no PNG signature and IHDR)");
  if (*left != *right || left->first > static_cast<std::uint32_t>(kMaxLcmImageSide) ||
      left->second > static_cast<std::uint32_t>(kMaxLcmImageSide))
    throw InputError("stereo frame " + name + ": PNG sizes " + std::to_string(left->first) + "x" +
                     std::to_string(left->second) + " and " + std::to_string(right->first) + "x" +
                     std::to_string(right->second) + " differ or exceed " + std::to_string(kMaxLcmImageSide));
  planecell_lcm::stereo_frame_t m =
      stereo_header(frame_id, camera, static_cast<int>(left->first), static_cast<int>(left->second), 3,
                    ImageEncoding::kPng, utime);
  m.left = std::move(left_png);
  m.right = std::move(right_png);
  m.left_size = static_cast<std::int32_t>(m.left.size());
  m.right_size = static_cast<std::int32_t>(m.right.size());
  return m;
}

StereoFrame from_lcm(const planecell_lcm::stereo_frame_t& m) {
  const std::string name = "stereo_frame_t " + frame_name(m.frame_id);
  if (m.frame_id < 0) throw InputError(name + ": negative frame id");
  if (m.width <= 0 || m.height <= 0 || m.width > kMaxLcmImageSide || m.height > kMaxLcmImageSide)
    throw InputError(name + ": image size " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                     " outside 1.." + std::to_string(kMaxLcmImageSide));
  if (m.channels != 1 && m.channels != 3)
    throw InputError(name + ": " + std::to_string(m.channels) + " channels (expected 1 or 3)");
  if (!(finite(m.fx) && finite(m.fy) && finite(m.cx) && finite(m.cy) && finite(m.baseline_m)) ||
      m.fx <= 0.0 || m.fy <= 0.0 || m.baseline_m <= 0.0)
    throw InputError(name + ": camera fx, fy, baseline must be finite and positive, cx, cy finite");
  if (m.left_size != static_cast<std::int32_t>(m.left.size()) ||
      m.right_size != static_cast<std::int32_t>(m.right.size()))
    throw InputError(name + ": byte counts disagree with the arrays");
  const int type = m.channels == 3 ? CV_8UC3 : CV_8UC1;
  auto unpack = [&](const std::vector<std::uint8_t>& bytes, const char* side) {
    cv::Mat image;
    if (m.encoding == planecell_lcm::stereo_frame_t::ENCODING_RAW) {
      const std::size_t expected =
          static_cast<std::size_t>(m.width) * static_cast<std::size_t>(m.height) * static_cast<std::size_t>(m.channels);
      if (bytes.size() != expected)
        throw InputError(name + ": " + side + " image has " + std::to_string(bytes.size()) + " bytes, " +
                         std::to_string(m.width) + "x" + std::to_string(m.height) + "x" +
                         std::to_string(m.channels) + " needs " + std::to_string(expected));
      image = cv::Mat(m.height, m.width, type, const_cast<std::uint8_t*>(bytes.data())).clone();
    } else if (m.encoding == planecell_lcm::stereo_frame_t::ENCODING_PNG) {
      if (bytes.empty()) throw InputError(name + ": " + side + " PNG is empty");
      // Only a PNG whose IHDR agrees with the header reaches the decoder: imdecode would try its
      // other decoders on anything else, and a forged size would allocate before any check.
      const auto size = io::png_header_size(bytes);
      if (!size) throw InputError(name + ": " + side + " image is not a PNG (no PNG signature and IHDR)");
      if (size->first != static_cast<std::uint32_t>(m.width) || size->second != static_cast<std::uint32_t>(m.height))
        throw InputError(name + ": " + side + " PNG is " + std::to_string(size->first) + "x" +
                         std::to_string(size->second) + ", header says " + std::to_string(m.width) +
                         "x" + std::to_string(m.height));
      try {
        image = cv::imdecode(bytes, m.channels == 3 ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
      } catch (const cv::Exception&) {
        image.release();
      }
      if (image.empty()) throw InputError(name + ": " + side + " PNG does not decode");
      if (image.cols != m.width || image.rows != m.height)
        throw InputError(name + ": " + side + " PNG is " + std::to_string(image.cols) + "x" +
                         std::to_string(image.rows) + ", header says " + std::to_string(m.width) + "x" +
                         std::to_string(m.height));
    } else {
      throw InputError(name + ": unknown image encoding " + std::to_string(m.encoding));
    }
    return image;
  };
  StereoFrame frame;
  frame.frame_id = static_cast<std::uint64_t>(m.frame_id);
  frame.timestamp_s = static_cast<double>(m.utime) * 1e-6;
  if (m.encoding == planecell_lcm::stereo_frame_t::ENCODING_PNG) {
    // Two independent decodes (~11 ms each at 1242×375): the right one runs on a second thread.
    auto right = std::async(std::launch::async, [&] { return unpack(m.right, "right"); });
    frame.left = unpack(m.left, "left");
    frame.right = right.get();
  } else {
    frame.left = unpack(m.left, "left");
    frame.right = unpack(m.right, "right");
  }
  frame.camera.fx = m.fx;
  frame.camera.fy = m.fy;
  frame.camera.cx = m.cx;
  frame.camera.cy = m.cy;
  frame.camera.baseline_m = m.baseline_m;
  frame.camera.width = m.width;
  frame.camera.height = m.height;
  return frame;
}

// --- poses ------------------------------------------------------------------------------------------

planecell_lcm::pose_t to_lcm(std::uint64_t frame_id, const Pose& T_world_cam, std::int64_t utime) {
  planecell_lcm::pose_t m;
  m.utime = utime;
  m.frame_id = static_cast<std::int64_t>(frame_id);
  const Eigen::Matrix4d matrix = T_world_cam.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m.T_world_cam[4 * r + c] = matrix(r, c);
  return m;
}

Pose from_lcm(const planecell_lcm::pose_t& m) {
  const std::string name = "pose_t " + frame_name(m.frame_id);
  if (m.frame_id < 0) throw InputError(name + ": negative frame id");
  if (!all_finite(m.T_world_cam)) throw InputError(name + ": matrix holds NaN or Inf");
  if (m.T_world_cam[12] != 0.0 || m.T_world_cam[13] != 0.0 || m.T_world_cam[14] != 0.0 ||
      m.T_world_cam[15] != 1.0)
    throw InputError(name + ": last row must be 0 0 0 1");
  const Pose pose = pose_from_3x4(m.T_world_cam, name);  // first three rows, validated
  return pose;
}

// --- planecells -------------------------------------------------------------------------------------

planecell_lcm::planecell_t to_lcm(const map::MapCell& cell) {
  planecell_lcm::planecell_t m;
  m.id = static_cast<std::int32_t>(cell.id);
  m.frame_id = static_cast<std::int64_t>(cell.frame_id);
  m.surface = static_cast<std::int32_t>(cell.surface);
  const Plane3 plane = cell.plane;
  for (int i = 0; i < 3; ++i) m.normal[i] = plane.normal[i];
  m.offset = plane.offset;
  for (int i = 0; i < 3; ++i) m.mean_rgb[i] = cell.mean_rgb[i];
  m.depth_sigma_m = cell.depth_sigma_m;
  m.num_vertices = static_cast<std::int32_t>(cell.vertices_m.size());
  for (const auto& v : cell.vertices_m) m.vertices_m.push_back({v.x(), v.y(), v.z()});
  return m;
}

map::MapCell from_lcm(const planecell_lcm::planecell_t& m) {
  const std::string name = "planecell_t " + std::to_string(m.id);
  if (m.num_vertices < 0 || m.num_vertices > kMaxLcmCellVertices)
    throw InputError(name + ": " + std::to_string(m.num_vertices) + " vertices (0.." +
                     std::to_string(kMaxLcmCellVertices) + " accepted)");
  const auto n = static_cast<std::size_t>(m.num_vertices);
  if (m.vertices_m.size() != n) throw InputError(name + ": vertex array disagrees with num_vertices");
  if (m.frame_id < 0) throw InputError(name + ": negative frame id");
  if (!all_finite(m.normal) || !finite(m.offset) || !all_finite(m.mean_rgb) ||
      !std::isfinite(m.depth_sigma_m) || m.depth_sigma_m < 0.0f)
    throw InputError(name + ": NaN or Inf in the plane, colour or depth noise");
  map::MapCell cell;
  cell.id = static_cast<std::uint32_t>(m.id);
  cell.frame_id = static_cast<std::uint64_t>(m.frame_id);
  cell.surface = static_cast<std::uint32_t>(m.surface);
  cell.plane = Plane3{Eigen::Vector3d(m.normal[0], m.normal[1], m.normal[2]), m.offset};
  if (!cell.plane.normal().allFinite() || !std::isfinite(cell.plane.offset()))
    throw InputError(name + ": plane beyond float range (the map keeps planes as floats)");
  std::vector<Eigen::Vector3f> vertices;
  vertices.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& xyz = m.vertices_m[i];
    if (xyz.size() != 3) throw InputError(name + ": malformed vertex " + std::to_string(i));
    if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]))
      throw InputError(name + ": vertex " + std::to_string(i) + " is NaN or Inf");
    vertices.emplace_back(xyz[0], xyz[1], xyz[2]);
  }
  cell.vertices_m = map::StoredPolygon(vertices);
  cell.mean_rgb = Eigen::Vector3f(m.mean_rgb[0], m.mean_rgb[1], m.mean_rgb[2]);
  cell.depth_sigma_m = m.depth_sigma_m;
  return cell;
}

// --- map updates ------------------------------------------------------------------------------------

std::vector<planecell_lcm::map_update_t> encode_map_update(const MapUpdate& update, std::int64_t utime,
                                                           std::size_t max_bytes) {
  auto fresh = [&] {
    planecell_lcm::map_update_t m{};
    m.utime = utime;
    m.frame_id = static_cast<std::int64_t>(update.frame_id);
    m.settled = update.settled;
    m.next_cell_id = static_cast<std::int32_t>(update.next_cell_id);
    m.next_surface_id = static_cast<std::int32_t>(update.next_surface_id);
    m.map_cells = static_cast<std::int32_t>(update.map_cells);
    m.map_surfaces = static_cast<std::int32_t>(update.map_surfaces);
    m.num_added = m.num_relabelled = m.num_removed = m.num_merges = m.num_removed_surfaces = 0;
    return m;
  };
  std::vector<planecell_lcm::map_update_t> chunks{fresh()};
  std::size_t size = static_cast<std::size_t>(chunks.back().getEncodedSize());
  const std::size_t empty_size = size;
  // Adds one item of `bytes` encoded bytes, opening a new chunk when it would not fit.
  auto room = [&](std::size_t bytes, const char* what) -> planecell_lcm::map_update_t& {
    if (empty_size + bytes > max_bytes)
      throw InputError(std::string("map update of frame ") + std::to_string(update.frame_id) + ": one " + what +
                       " needs " + std::to_string(empty_size + bytes) + " bytes, more than the " +
                       std::to_string(max_bytes) + "-byte message budget");
    if (size + bytes > max_bytes) {
      chunks.push_back(fresh());
      size = empty_size;
    }
    size += bytes;
    return chunks.back();
  };
  for (const auto& cell : update.added_cells) {
    planecell_lcm::planecell_t c = to_lcm(cell);
    auto& m = room(static_cast<std::size_t>(c.getEncodedSize()), "cell");
    m.added.push_back(std::move(c));
    ++m.num_added;
  }
  for (const auto& [cell, surface] : update.relabelled_cells) {
    auto& m = room(8, "relabel");
    m.relabelled_cell.push_back(static_cast<std::int32_t>(cell));
    m.relabelled_surface.push_back(static_cast<std::int32_t>(surface));
    ++m.num_relabelled;
  }
  for (const auto id : update.removed_cells) {
    auto& m = room(4, "removal");
    m.removed_cells.push_back(static_cast<std::int32_t>(id));
    ++m.num_removed;
  }
  for (const auto& merge : update.surface_merges) {
    auto& m = room(8, "merge");
    m.merge_absorbed.push_back(static_cast<std::int32_t>(merge.absorbed));
    m.merge_into.push_back(static_cast<std::int32_t>(merge.into));
    ++m.num_merges;
  }
  for (const auto id : update.removed_surfaces) {
    auto& m = room(4, "removed surface");
    m.removed_surfaces.push_back(static_cast<std::int32_t>(id));
    ++m.num_removed_surfaces;
  }
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    chunks[i].chunk_index = static_cast<std::int32_t>(i);
    chunks[i].chunk_count = static_cast<std::int32_t>(chunks.size());
  }
  return chunks;
}

std::optional<MapUpdate> MapUpdateAssembler::add(const planecell_lcm::map_update_t& m) {
  const std::string name =
      std::string(m.settled ? "map_update_t settling the map after frame " : "map_update_t of frame ") +
      std::to_string(m.frame_id);
  if (m.frame_id < 0) throw InputError(name + ": negative frame id");
  if (m.chunk_count < 1 || m.chunk_count > 100000 || m.chunk_index < 0 || m.chunk_index >= m.chunk_count)
    throw InputError(name + ": chunk " + std::to_string(m.chunk_index) + " of " + std::to_string(m.chunk_count));
  if (m.num_added != static_cast<std::int32_t>(m.added.size()) ||
      m.num_relabelled != static_cast<std::int32_t>(m.relabelled_cell.size()) ||
      m.num_relabelled != static_cast<std::int32_t>(m.relabelled_surface.size()) ||
      m.num_removed != static_cast<std::int32_t>(m.removed_cells.size()) ||
      m.num_merges != static_cast<std::int32_t>(m.merge_absorbed.size()) ||
      m.num_merges != static_cast<std::int32_t>(m.merge_into.size()) ||
      m.num_removed_surfaces != static_cast<std::int32_t>(m.removed_surfaces.size()))
    throw InputError(name + ": list counts disagree with the arrays");
  const auto frame = static_cast<std::uint64_t>(m.frame_id);
  const UpdateKey key{frame, m.settled != 0};
  auto key_name = [](const UpdateKey& k) {
    return (k.second ? "the settling after frame " : "frame ") + std::to_string(k.first);
  };
  if (last_complete_ && key <= *last_complete_)
    throw InputError(name + ": out of order (" + key_name(*last_complete_) + " already applied)");
  if (pending_frame_ && key < *pending_frame_)
    throw InputError(name + ": out of order (" + key_name(*pending_frame_) + " under way)");
  if (!pending_frame_ || key > *pending_frame_) {
    if (pending_frame_) ++incomplete_frames_;  // the frame under way lost chunks
    pending_frame_ = key;
    pending_.clear();
    pending_count_ = m.chunk_count;
  }
  if (m.chunk_count != pending_count_) throw InputError(name + ": chunk count changed within the frame");
  if (pending_.contains(m.chunk_index))
    throw InputError(name + ": duplicate chunk " + std::to_string(m.chunk_index));
  // Decode the cells now, so a malformed chunk is rejected before it joins the frame.
  for (const auto& cell : m.added) from_lcm(cell);
  pending_.emplace(m.chunk_index, m);
  if (static_cast<int>(pending_.size()) < pending_count_) return std::nullopt;

  MapUpdate update;
  update.frame_id = frame;
  update.settled = key.second;
  for (const auto& [index, chunk] : pending_) {
    for (const auto& cell : chunk.added) update.added_cells.push_back(from_lcm(cell));
    for (int i = 0; i < chunk.num_relabelled; ++i)
      update.relabelled_cells.emplace_back(static_cast<std::uint32_t>(chunk.relabelled_cell[static_cast<std::size_t>(i)]),
                                           static_cast<std::uint32_t>(chunk.relabelled_surface[static_cast<std::size_t>(i)]));
    for (const auto id : chunk.removed_cells) update.removed_cells.push_back(static_cast<std::uint32_t>(id));
    for (int i = 0; i < chunk.num_merges; ++i)
      update.surface_merges.push_back({frame, static_cast<std::uint32_t>(chunk.merge_absorbed[static_cast<std::size_t>(i)]),
                                       static_cast<std::uint32_t>(chunk.merge_into[static_cast<std::size_t>(i)])});
    for (const auto id : chunk.removed_surfaces) update.removed_surfaces.push_back(static_cast<std::uint32_t>(id));
    update.next_cell_id = static_cast<std::uint32_t>(chunk.next_cell_id);
    update.next_surface_id = static_cast<std::uint32_t>(chunk.next_surface_id);
    update.map_cells = static_cast<std::size_t>(std::max(0, chunk.map_cells));
    update.map_surfaces = static_cast<std::size_t>(std::max(0, chunk.map_surfaces));
  }
  last_complete_ = key;
  pending_frame_.reset();
  pending_.clear();
  return update;
}

// --- the mirror ------------------------------------------------------------------------------------

void MapMirror::apply(const MapUpdate& update) {
  for (const auto& cell : update.added_cells)
    if (cells.contains(cell.id))
      throw InputError("map update of frame " + std::to_string(update.frame_id) + ": adds cell " +
                       std::to_string(cell.id) + " the mirror already has");
  for (const auto& relabel : update.relabelled_cells) {
    const std::uint32_t id = relabel.first;  // a named copy: clang 14 cannot capture a binding
    if (!cells.contains(id) && std::none_of(update.added_cells.begin(), update.added_cells.end(),
                                            [id](const map::MapCell& c) { return c.id == id; }))
      throw InputError("map update of frame " + std::to_string(update.frame_id) + ": relabels unknown cell " +
                       std::to_string(id));
  }
  for (const auto& cell : update.added_cells) cells.emplace(cell.id, cell);
  for (const auto& [id, surface] : update.relabelled_cells) cells.at(id).surface = surface;
  for (const auto id : update.removed_cells) cells.erase(id);
  next_cell_id = update.next_cell_id;
  next_surface_id = update.next_surface_id;
  if (!update.settled) ++frames;
  last_frame_id = update.frame_id;
}

}  // namespace planecell::io
