#pragma once
/// Byte encodings of the map store's blobs (io::MapStore), one function pair per blob, for every
/// store version this build reads. All are lossless: decode(encode(x)) == x bit for bit.
///
/// Version 8 (current) adds a surface's count of the frames that observed it
/// (map::Surface::frames_observed, MapConfig::confirm_frames); versions before it decode with
/// their observation count in its place. Version 7 writes surfaces as 6 does with a sparse histogram (a mask of the non-zero
/// bins and their values), the last observed frame, the cell ids as differences, and the
/// SurfaceDetail only for a live surface (map::Surface; MapConfig::dormant_after_frames).
/// Version 6 stores each group of reals as floats when every value in it is exactly a
/// float (a flag byte says which), and a cell's vertices as zigzag varints of millimetres (the
/// first absolute, then differences) when every coordinate is exactly float(k / 1000) for an
/// integer k; otherwise raw IEEE bytes. The map rounds its reals to those precisions where they
/// enter it (map::to_float_precision, map::snap_to_mm), so nearly every group takes the short
/// form. Versions 4 and 5: doubles and float vertices as raw bytes; 5 deflates surface blobs.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/plane.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::io::map_codec {

/// Oldest and newest store versions whose blobs these functions read and write.
constexpr int kOldestVersion = 3;
constexpr int kCurrentVersion = 8;

/// A surface blob of store `version` (3 and 4: raw; 5: raw size u32 + zlib stream of the raw
/// encoding; 6 and 7: the same around the compact encodings). Throws StorageError beyond 64 MiB
/// raw, and for a dormant surface below version 7. Versions before 7 decode into live surfaces
/// with last_observed_frame 0; before 8 with frames_observed = observations.
std::vector<std::uint8_t> encode_surface(const map::Surface& s, int version = kCurrentVersion);
/// Decodes a surface blob of store `version`; `where` names the store in the StorageError raised
/// for a truncated, oversized or corrupt blob.
map::Surface decode_surface(std::uint32_t id, const void* data, std::size_t size,
                            const std::string& where, int version = kCurrentVersion);

/// A cell's plane (normal, offset): 4 doubles up to version 5, a real group in 6.
std::vector<std::uint8_t> encode_plane(const Plane3& plane, int version = kCurrentVersion);
Plane3 decode_plane(const void* data, std::size_t size, const std::string& what,
                    int version = kCurrentVersion);

/// A cell's polygon: float x, y, z per vertex up to version 5; in 6 a tag byte, then millimetre
/// varints (tag 1) or the raw floats (tag 0).
std::vector<std::uint8_t> encode_vertices(const std::vector<Eigen::Vector3f>& vertices,
                                          int version = kCurrentVersion);
std::vector<Eigen::Vector3f> decode_vertices(const void* data, std::size_t size,
                                             const std::string& what,
                                             int version = kCurrentVersion);

}  // namespace planecell::io::map_codec
