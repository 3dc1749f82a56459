#pragma once
/// Compact, versioned binary encoding of a frame's planecells: the wire/storage form shared by
/// the extract command, the map store and LCM messages.
///
/// Layout (version 1; all multi-byte fixed fields little-endian):
///   "PCL" magic, version u8, flags u8 (bit 0 histogram, bit 1 statistics, bit 2 sequential ids
///   0, 1, 2, … (ids then not stored), bit 3 planeless polygons), frame id varint,
///   camera fx fy cx cy baseline (f32 ×5), width, height (varint), cell count (varint), cells,
///   CRC-32 (IEEE) of everything before it (u32).
/// Per cell: [id (zig-zag varint delta to previous id + 1) unless sequential],
///   (vertex count << 1 | has_plane) (varint; planeless cells carry no polygon unless bit 3),
///   vertices on the pixel-corner lattice (x + ½, y + ½ rounded) as deltas — the first from the
///   previous cell's first vertex, the rest from the previous vertex — each delta one varint of
///   the Szudzik pairing of the zig-zag coded dx, dy (1 byte when |dx|, |dy| ≤ 5), then
///   with a plane: the plane re-parametrised around the vertex centroid (ū, v̄),
///   d = a·(u − ū) + b·(v − v̄) + d̄, as a, b (IEEE half) and d̄ (i16, 1/64 px); mean colour
///   as RGB 5-6-5 (u16); with the statistics flag: area, inlier count (varint), inlier ratio (u8/255),
///   depth σ (u16, cm);
///   with the histogram flag: the non-zero bins of the 64-bin histogram as (bin u8, value u8/255)
///   pairs after their count (u8).
/// What is lossy: vertices snap to the lattice (extracted cells already lie on it), plane
/// a and b to 11 significant bits and d̄ to 1/64 px, colour to 5-6-5 bits, the histogram to
/// 1/255 (and it is off by default: the compact form carries no histogram). Decoding recomputes the
/// exact 3D plane and vertices from the decoded disparity plane and camera.
#include <cstdint>
#include <span>
#include <vector>

#include "core/planecell.hpp"
#include "core/stereo_camera.hpp"

namespace planecell::io {

inline constexpr std::uint8_t kPlanecellCodecVersion = 2;

/// What goes on the wire besides geometry and colour.
struct PlanecellCodecOptions {
  bool include_histogram = false;   ///< sparse 64-bin colour histogram (for CRF merging)
  bool include_statistics = false;  ///< area, inlier count and ratio, depth σ
  bool include_planeless_polygons = false;  ///< planeless cells keep their image polygon
};

/// A decoded frame.
struct DecodedPlanecells {
  std::uint64_t frame_id = 0;
  StereoCamera camera;
  PlanecellCodecOptions options;  ///< what the encoder included
  std::vector<Planecell> cells;   ///< cells[i].frame_id = frame_id; 3D recomputed
};

/// Encodes cells (image polygons + disparity planes are the source of truth; 3D is not stored).
/// Throws InputError when a vertex lies outside [−1, 65534] px or a count does not fit.
std::vector<std::uint8_t> encode_planecells(const std::vector<Planecell>& cells,
                                            const StereoCamera& camera, std::uint64_t frame_id,
                                            const PlanecellCodecOptions& options = {});

/// Decodes bytes from encode_planecells. Throws InputError naming the offset and the field on
/// a bad magic, an unknown version, truncated or trailing bytes, impossible counts or a CRC
/// mismatch; never reads out of bounds.
DecodedPlanecells decode_planecells(std::span<const std::uint8_t> bytes);

}  // namespace planecell::io
