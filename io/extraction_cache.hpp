#pragma once
/// On-disk cache of one frame's extraction products (camera-frame planecells and label image),
/// exact to the bit, so that the mapping stages (transform, merge, store) can be re-run on a
/// sequence without recomputing SGM and extraction (`planecell replay --extraction-cache DIR`:
/// tuning and profiling the map on a fixed set of frames).
///
/// File layout (version 1, little-endian, x86-64 / AArch64 hosts):
///   "PCXC" magic, version u8, fingerprint u64 (what produced the products: the caller's hash of
///   the SGM/extraction configuration, camera and input files), frame id u64,
///   plane_fraction f64, cell_size_px i32,
///   labels rows i32, cols i32, zlib-compressed size u32 and the zlib stream of the CV_32S label
///   image (rows·cols·4 bytes, row-major),
///   cell count u32, per cell: id u32, frame_id u64, has_plane u8, disparity plane a b c (f64),
///   plane normal xyz and offset (f64), image vertex count u32 and (u, v) f32 pairs, 3D vertex
///   count u32 and (x, y, z) f32 triples, mean RGB (f32 ×3), histogram (f32 × 64), area_px u32,
///   inlier_count u32, inlier_ratio f32, depth_sigma_m f32, normal_sigma_rad f32, surface u32,
///   CRC-32 (zlib's, IEEE) of everything before it (u32).
/// The dense disparity and outlier masks are not kept (the mapping stages do not read them).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "mapping/planecell/extraction.hpp"

namespace planecell::io {

inline constexpr std::uint8_t kExtractionCacheVersion = 1;

/// The cache file of frame `frame_id` in `dir` (DIR/NNNNNN.pcx).
std::filesystem::path extraction_cache_path(const std::filesystem::path& dir, std::uint64_t frame_id);

/// Writes `frame` (labels, cells, plane_fraction, cell_size_px) to `path` through a temporary file
/// renamed over it, so a killed writer never leaves a half file under that name. The temporary
/// file is the writer's own (named after its process and thread): two replays sharing a cache
/// folder may write the same frame at once, and the last rename wins with the same bytes. Throws
/// StorageError naming the file when it cannot be written (e.g. a full disk).
void write_extraction_cache(const std::filesystem::path& path, std::uint64_t fingerprint,
                            std::uint64_t frame_id, const extraction::PlanecellFrame& frame);

/// Reads the products cached in `path` for frame `frame_id`: nullopt when the file does not exist
/// or was made with another fingerprint or version (stale: the caller recomputes and rewrites it).
/// Throws StorageError naming the file when it is truncated, corrupt (CRC, sizes, label ids) or
/// holds another frame.
std::optional<extraction::PlanecellFrame> read_extraction_cache(const std::filesystem::path& path,
                                                                std::uint64_t fingerprint,
                                                                std::uint64_t frame_id);

/// read_extraction_cache of bytes already read (`what` names them in errors).
std::optional<extraction::PlanecellFrame> decode_extraction_cache(std::span<const std::uint8_t> bytes,
                                                                  std::uint64_t fingerprint,
                                                                  std::uint64_t frame_id, const std::string& what);

/// The checksum the file's last 4 bytes hold: zlib's CRC-32 of everything before them.
std::uint32_t extraction_cache_crc32(std::span<const std::uint8_t> bytes);

}  // namespace planecell::io
