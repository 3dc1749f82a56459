#pragma once
/// Compact, versioned binary encoding of a frame's camera-frame planecells (the paper's
/// per-frame size measure; `extract` reports it as compact_bytes). The map store and the LCM map
/// updates keep exact world-frame cells instead: this form is lossy and camera-frame.
///
/// Layout (version 3; multi-byte fixed fields little-endian; the decoder refuses versions 1 and 2):
///   "PCL" magic, version u8, flags u8 (bit 0 histogram, bit 1 statistics, bit 2 sequential ids
///   0, 1, 2, … (ids then not stored), bit 3 planeless polygons), frame id varint,
///   camera fx fy cx cy baseline (f32 ×5), width, height (varint), cell count (varint),
///   geometry size in bytes (varint) and the geometry bit stream, one record per cell,
///   CRC-32 (IEEE) of everything before it (u32).
/// Geometry bit stream: bits packed most significant first, the last byte padded with zero bits
///   (no other spare bits or bytes).
///   Codes: EG_k(u), u ≥ 0, is order-k exp-Golomb (with q = (u >> k) + 1 of z + 1 bits: z zero
///   bits, q, then the low k bits of u); SEG_k(s) = EG_k(zig-zag s); C_c(v), v ≥ 0, ranks v in
///   the order c, c − 1, c + 1, c − 2, c + 2, …, 0, 2c, 2c + 1, … (rank r) and writes r one bits
///   and a zero if r < 15, else 15 one bits and EG_0(r − 15).
///   Per cell: has_plane (1 bit), then, if it has a plane or bit 3 is set, its polygon: vertices
///   v_0 … v_(n−1) on the pixel-corner lattice (x + ½, y + ½ rounded), coded against the vertices
///   and directed edges v_k → v_(k+1 mod n) of the polygons before it. Edge a → b is open while
///   b → a has not been recorded (the boundary with a later cell, which runs it b → a); the
///   frontier is the set of vertices with an open edge, ordered by (y, x). Polygon:
///     EG_2(u). u = 0: explicit: C_2(n), and if n > 0, v_0 as SEG_5(dx) SEG_5(dy) from p, the
///       v_0 of the last non-empty polygon before ((0, 0) if none), then n − 1 fresh vertices.
///     u > 0: v_0 is the frontier vertex s = unzigzag(u − 1) places from p in (y, x) order
///       (s ≥ 0: the s-th at or after p, counting from 0; s < 0: the −s-th before it;
///       |s| ≤ 1024). Backward run, if v_0 has an open edge v_0 → w: C_2(b) and b steps from
///       j = v_0, each taking the oldest open edge j → w out of j, recording w → j and moving to
///       j = w: these w are v_(n−1), v_(n−2), …, v_(n−b). Forward run, if then v_0 has an open
///       edge w → v_0: C_1(f) and f steps from j = v_0, each taking the oldest open edge w → j
///       into j, recording j → w and moving to j = w: v_1 … v_f. Then C_2(m) and m fresh
///       vertices v_(f+1) … v_(f+m); n = 1 + f + m + b.
///     A fresh vertex is SEG_3(dx) SEG_3(dy) from the vertex before it. After a polygon all its
///     edges are recorded in order k = 0 … n − 1 (self-loops are not). "Oldest" is in recording
///     order. Shared junctions thus cost a few bits per polygon instead of two bytes each.
/// Per cell record: [id (zig-zag varint delta to previous id + 1) unless sequential], then
///   with a plane: the plane re-parametrised around the vertex centroid (ū, v̄),
///   d = a·(u − ū) + b·(v − v̄) + d̄, as a, b (IEEE half) and d̄ (i16, 1/64 px); mean colour
///   as RGB 5-6-5 (u16); with the statistics flag: area, inlier count (varint), inlier ratio
///   (u8/255), depth σ (u16, cm); with the histogram flag: the non-zero bins of the 64-bin
///   histogram as (bin u8, value u8/255) pairs after their count (u8).
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

inline constexpr std::uint8_t kPlanecellCodecVersion = 3;

/// What goes on the wire besides geometry and colour.
struct PlanecellCodecOptions {
  bool include_histogram = false;           ///< sparse 64-bin colour histogram (for CRF merging)
  bool include_statistics = false;          ///< area, inlier count and ratio, depth σ
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

/// The stream's checksum: CRC-32 (IEEE 802.3, reflected, init and final xor 0xFFFFFFFF) of
/// `data`, as stored little-endian in the last 4 bytes over everything before them.
std::uint32_t planecell_codec_crc32(std::span<const std::uint8_t> data);

/// Decodes bytes from encode_planecells. Throws InputError naming the offset and the field on
/// a bad magic, an unknown (or older) version, truncated or trailing bytes, impossible counts,
/// a reference to a vertex or shared edge that does not exist, or a CRC mismatch; never reads
/// out of bounds, and runs in time near-linear in the input size.
DecodedPlanecells decode_planecells(std::span<const std::uint8_t> bytes);

}  // namespace planecell::io
