/// Compact binary codec of a frame's planecells (see planecell_codec.hpp for the layout).
#include "io/planecell_codec.hpp"

#include <opencv2/core/cvdef.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "core/error.hpp"

namespace planecell::io {
namespace {

constexpr std::array<std::uint8_t, 3> kMagic = {'P', 'C', 'L'};
constexpr std::uint8_t kFlagHistogram = 1u << 0;
constexpr std::uint8_t kFlagStatistics = 1u << 1;
constexpr std::uint8_t kFlagSequentialIds = 1u << 2;  ///< ids are 0, 1, 2, … and not stored
constexpr std::uint8_t kFlagPlanelessPolygons = 1u << 3;
constexpr std::uint8_t kKnownFlags =
    kFlagHistogram | kFlagStatistics | kFlagSequentialIds | kFlagPlanelessPolygons;
constexpr double kDisparityStep = 1.0 / 64.0;   ///< d̄ quantum (px)
constexpr double kMinVertexDisparityPx = 0.25;  ///< as extraction::convert_to_3d

// Geometry codes (see the layout in planecell_codec.hpp); orders and centres chosen together on
// the extracted cells of the 8 KITTI 2012/2015 and Middlebury pairs in ../shared/data.
constexpr int kFirstVertexOrder = 2;     ///< EG order of the first-vertex symbol u
constexpr int kExplicitVertexOrder = 5;  ///< SEG order of an explicit first vertex's dx, dy
constexpr int kFreshVertexOrder = 3;     ///< SEG order of a fresh vertex's dx, dy
constexpr std::uint64_t kExplicitCountCentre = 2;  ///< C_c centre of an explicit polygon's n
constexpr std::uint64_t kBackwardCentre = 2;       ///< … of the backward run b
constexpr std::uint64_t kForwardCentre = 1;        ///< … of the forward run f
constexpr std::uint64_t kFreshCentre = 2;          ///< … of the fresh vertex count m
constexpr std::uint64_t kUnaryLimit = 15;          ///< C_c: ranks from here on escape to EG_0
constexpr std::int64_t kMaxFrontierOffset = 1024;  ///< |s| of a first-vertex reference
/// Fewest bits a fresh vertex takes (two SEG_3 codes): bounds a decoded count before reserving.
constexpr std::size_t kMinFreshVertexBits = 2 * std::size_t{kFreshVertexOrder + 1};
constexpr int kMaxExpGolombZeros = 40;  ///< longer prefixes are corrupt (values < 2^46)

using Lattice = std::array<std::int64_t, 2>;  ///< pixel-corner lattice point (x, y), 0…65535

std::uint64_t zigzag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
std::int64_t unzigzag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

struct CodeWriter {
  std::vector<std::uint8_t> out;
  void u8(std::uint8_t v) { out.push_back(v); }
  void varint(std::uint64_t v) {
    while (v >= 0x80) {
      out.push_back(static_cast<std::uint8_t>(v | 0x80));
      v >>= 7;
    }
    out.push_back(static_cast<std::uint8_t>(v));
  }
  void svarint(std::int64_t v) { varint(zigzag(v)); }
  void u16(std::uint16_t v) {
    u8(static_cast<std::uint8_t>(v));
    u8(static_cast<std::uint8_t>(v >> 8));
  }
  void u32(std::uint32_t v) {
    for (int k = 0; k < 4; ++k) u8(static_cast<std::uint8_t>(v >> (8 * k)));
  }
  void f32(float f) {
    std::uint32_t bits;
    std::memcpy(&bits, &f, 4);
    u32(bits);
  }
};

struct CodeReader {
  std::span<const std::uint8_t> in;
  std::size_t pos = 0;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError("planecell codec: " + what + " at byte " + std::to_string(pos) + " of " +
                     std::to_string(in.size()));
  }
  void need(std::size_t n, const char* field) const {
    if (in.size() - pos < n) fail(std::string("truncated input while reading ") + field);
  }
  std::size_t remaining() const { return in.size() - pos; }
  std::uint8_t u8(const char* field) {
    need(1, field);
    return in[pos++];
  }
  std::uint16_t u16(const char* field) {
    need(2, field);
    const std::uint16_t v = static_cast<std::uint16_t>(in[pos] | (in[pos + 1] << 8));
    pos += 2;
    return v;
  }
  std::uint32_t u32(const char* field) {
    need(4, field);
    std::uint32_t v = 0;
    for (int k = 0; k < 4; ++k) v |= static_cast<std::uint32_t>(in[pos + k]) << (8 * k);
    pos += 4;
    return v;
  }
  float f32(const char* field) {
    const std::uint32_t bits = u32(field);
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  }
  std::uint64_t varint(const char* field) {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      const std::uint8_t byte = u8(field);
      v |= static_cast<std::uint64_t>(byte & 0x7F) << shift;
      if ((byte & 0x80) == 0) return v;
    }
    fail(std::string("over-long varint in ") + field);
  }
  std::int64_t svarint(const char* field) { return unzigzag(varint(field)); }
};

/// C_c rank of v ≥ 0: c, c − 1, c + 1, c − 2, c + 2, …, 0, 2c, 2c + 1, … ↦ 0, 1, 2, …
std::uint64_t fold(std::uint64_t v, std::uint64_t centre) {
  if (v < centre) return 2 * (centre - v) - 1;
  if (v <= 2 * centre) return 2 * (v - centre);
  return v;
}
std::uint64_t unfold(std::uint64_t rank, std::uint64_t centre) {
  if (rank > 2 * centre) return rank;
  return rank % 2 == 0 ? centre + rank / 2 : centre - (rank + 1) / 2;
}

/// The geometry bit stream, most significant bit first; the last byte is padded with zeros.
struct BitWriter {
  std::vector<std::uint8_t> out;
  std::uint8_t pending = 0;  ///< bits not yet in out
  int pending_bits = 0;

  void bit(bool b) {
    pending = static_cast<std::uint8_t>(pending << 1 | (b ? 1u : 0u));
    if (++pending_bits == 8) {
      out.push_back(pending);
      pending = 0;
      pending_bits = 0;
    }
  }
  void bits(std::uint64_t value, int count) {
    for (int k = count - 1; k >= 0; --k) bit((value >> k) & 1u);
  }
  /// EG_k(u): z zeros, q = (u >> k) + 1 in its z + 1 bits, the low k bits of u.
  void exp_golomb(std::uint64_t u, int k) {
    const std::uint64_t q = (u >> k) + 1;
    const int width = static_cast<int>(std::bit_width(q));
    bits(0, width - 1);
    bits(q, width);
    bits(u, k);
  }
  void signed_exp_golomb(std::int64_t s, int k) { exp_golomb(zigzag(s), k); }
  /// C_c(v): the rank r of v around c as r ones and a zero, or 15 ones and EG_0(r − 15).
  void count(std::uint64_t v, std::uint64_t centre) {
    const std::uint64_t rank = fold(v, centre);
    for (std::uint64_t k = 0; k < std::min(rank, kUnaryLimit); ++k) bit(true);
    if (rank < kUnaryLimit)
      bit(false);
    else
      exp_golomb(rank - kUnaryLimit, 0);
  }
  std::vector<std::uint8_t> finish() {
    if (pending_bits > 0) out.push_back(static_cast<std::uint8_t>(pending << (8 - pending_bits)));
    pending = 0;
    pending_bits = 0;
    return std::move(out);
  }
};

struct BitReader {
  std::span<const std::uint8_t> in;  ///< the geometry section
  std::size_t offset = 0;            ///< of in[0] in the frame (for messages)
  std::size_t frame_size = 0;        ///< (for messages)
  std::size_t pos = 0;               ///< in bits
  std::uint64_t cell = 0;            ///< being decoded (for messages)

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError("planecell codec: " + what + " (cell " + std::to_string(cell) + ") at byte " +
                     std::to_string(offset + pos / 8) + " (bit " + std::to_string(pos % 8) +
                     ") of " + std::to_string(frame_size));
  }
  std::size_t remaining_bits() const { return in.size() * 8 - pos; }
  bool bit(const char* field) {
    if (pos >= in.size() * 8) fail(std::string("truncated geometry while reading ") + field);
    const bool b = (in[pos / 8] >> (7 - pos % 8)) & 1u;
    ++pos;
    return b;
  }
  std::uint64_t bits(int count, const char* field) {
    std::uint64_t v = 0;
    for (int k = 0; k < count; ++k) v = v << 1 | (bit(field) ? 1u : 0u);
    return v;
  }
  std::uint64_t exp_golomb(int k, const char* field) {
    int zeros = 0;
    while (!bit(field))
      if (++zeros > kMaxExpGolombZeros) fail(std::string("over-long code in ") + field);
    const std::uint64_t q = std::uint64_t{1} << zeros | bits(zeros, field);
    return (q - 1) << k | bits(k, field);
  }
  std::int64_t signed_exp_golomb(int k, const char* field) {
    return unzigzag(exp_golomb(k, field));
  }
  std::uint64_t count(std::uint64_t centre, const char* field) {
    std::uint64_t rank = 0;
    while (rank < kUnaryLimit && bit(field)) ++rank;
    if (rank == kUnaryLimit) rank += exp_golomb(0, field);
    return unfold(rank, centre);
  }
};

/// The vertices and directed edges of the polygons coded so far, kept identically by the encoder
/// and the decoder: a later polygon's shared boundary is coded as runs along its open edges.
/// Edge a → b is open while b → a has not been recorded. Every operation is amortised O(log n)
/// but the frontier walks, which take at most kMaxFrontierOffset steps.
class SharedBoundaries {
 public:
  /// `expected_vertices` only sizes the tables.
  explicit SharedBoundaries(std::size_t expected_vertices) {
    vertices_.reserve(expected_vertices);
    index_.reserve(expected_vertices);
    edges_.reserve(3 * expected_vertices);
    links_.reserve(4 * expected_vertices);
  }

  std::optional<std::uint32_t> find(const Lattice& p) const {
    const auto it = index_.find(key(p));
    if (it == index_.end()) return std::nullopt;
    return it->second;
  }
  const Lattice& point(std::uint32_t v) const { return vertices_[v].p; }

  /// Records edge a → b (a second time changes nothing): it closes b → a if that is open, else
  /// it opens.
  void record(std::uint32_t a, std::uint32_t b) {
    if (a == b || !edges_.insert(edge_key(a, b)).second) return;
    if (edges_.contains(edge_key(b, a))) {
      if (--vertices_[a].open == 0) frontier_.erase(key(vertices_[a].p));
      if (--vertices_[b].open == 0) frontier_.erase(key(vertices_[b].p));
    } else {
      append(vertices_[a].out, b);
      append(vertices_[b].in, a);
      if (vertices_[a].open++ == 0) frontier_.insert(key(vertices_[a].p));
      if (vertices_[b].open++ == 0) frontier_.insert(key(vertices_[b].p));
    }
  }
  /// Records a polygon's edges v_k → v_(k+1 mod n), in order, adding its new vertices.
  void record_polygon(const std::vector<Lattice>& polygon) {
    ids_.clear();
    for (const Lattice& p : polygon) ids_.push_back(insert(p));
    for (std::size_t k = 0; k < ids_.size(); ++k) record(ids_[k], ids_[(k + 1) % ids_.size()]);
  }
  /// w of the oldest open edge j → w.
  std::optional<std::uint32_t> open_out(std::uint32_t j) {
    return oldest_open(vertices_[j].out, [&](std::uint32_t w) { return edge_key(w, j); });
  }
  /// w of the oldest open edge w → j.
  std::optional<std::uint32_t> open_in(std::uint32_t j) {
    return oldest_open(vertices_[j].in, [&](std::uint32_t w) { return edge_key(j, w); });
  }

  /// s such that `to` is the s-th frontier vertex at or after `from` in (y, x) order (s ≥ 0), or
  /// the −s-th before it; none when `to` is not on the frontier or |s| > kMaxFrontierOffset.
  std::optional<std::int64_t> frontier_offset(const Lattice& from, const Lattice& to) const {
    const std::uint32_t target = key(to);
    if (!frontier_.contains(target)) return std::nullopt;
    auto it = frontier_.lower_bound(key(from));
    if (target >= key(from)) {
      for (std::int64_t s = 0; s <= kMaxFrontierOffset; ++s, ++it)
        if (*it == target) return s;
    } else {
      for (std::int64_t s = -1; s >= -kMaxFrontierOffset; --s)
        if (*--it == target) return s;
    }
    return std::nullopt;
  }
  /// The frontier vertex s places from `from` (as frontier_offset); none past either end.
  std::optional<Lattice> frontier_at(const Lattice& from, std::int64_t s) const {
    auto it = frontier_.lower_bound(key(from));
    for (; s > 0 && it != frontier_.end(); --s) ++it;
    for (; s < 0 && it != frontier_.begin(); ++s) --it;
    if (s != 0 || it == frontier_.end()) return std::nullopt;
    return Lattice{*it & 0xFFFFu, *it >> 16};
  }

 private:
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  /// The far ends of the edges that opened at a vertex, oldest first, as a list in links_;
  /// entries before `first` are closed.
  struct EdgeList {
    std::uint32_t first = kNone, last = kNone;
  };
  struct Link {
    std::uint32_t other, next;
  };
  struct Vertex {
    Lattice p;
    EdgeList out, in;        ///< targets / sources of the edges that opened here
    std::uint32_t open = 0;  ///< open edges at this vertex
  };
  /// (y, x) order on the lattice.
  static std::uint32_t key(const Lattice& p) {
    return static_cast<std::uint32_t>(p[1]) << 16 | static_cast<std::uint32_t>(p[0]);
  }
  static std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
    return std::uint64_t{a} << 32 | b;
  }
  std::uint32_t insert(const Lattice& p) {
    const auto [it, added] =
        index_.try_emplace(key(p), static_cast<std::uint32_t>(vertices_.size()));
    if (added) vertices_.push_back(Vertex{p, {}, {}, 0});
    return it->second;
  }
  void append(EdgeList& list, std::uint32_t other) {
    const auto link = static_cast<std::uint32_t>(links_.size());
    links_.push_back({other, kNone});
    if (list.first == kNone)
      list.first = link;
    else
      links_[list.last].next = link;
    list.last = link;
  }
  /// An entry is open while its twin (twin_of(other)) is not recorded; the closed entries before
  /// the oldest open one are dropped for good, so every entry is passed over once.
  template <class TwinOf>
  std::optional<std::uint32_t> oldest_open(EdgeList& list, TwinOf twin_of) {
    while (list.first != kNone && edges_.contains(twin_of(links_[list.first].other)))
      list.first = links_[list.first].next;
    if (list.first == kNone) return std::nullopt;
    return links_[list.first].other;
  }

  std::vector<Vertex> vertices_;
  std::vector<Link> links_;
  std::unordered_map<std::uint32_t, std::uint32_t> index_;  ///< lattice key → vertex
  std::unordered_set<std::uint64_t> edges_;                 ///< recorded a → b
  std::set<std::uint32_t> frontier_;  ///< lattice keys of the vertices with an open edge
  std::vector<std::uint32_t> ids_;    ///< scratch of record_polygon
};

void write_fresh(BitWriter& w, const Lattice& p, const Lattice& before) {
  w.signed_exp_golomb(p[0] - before[0], kFreshVertexOrder);
  w.signed_exp_golomb(p[1] - before[1], kFreshVertexOrder);
}

/// Codes a polygon against the shared boundaries so far, then records it (layout: "Polygon").
void encode_polygon(BitWriter& w, SharedBoundaries& shared, const std::vector<Lattice>& polygon,
                    Lattice& previous_first) {
  const std::size_t n = polygon.size();
  const std::optional<std::int64_t> offset =
      n > 0 ? shared.frontier_offset(previous_first, polygon[0]) : std::nullopt;
  if (!offset) {
    w.exp_golomb(0, kFirstVertexOrder);
    w.count(n, kExplicitCountCentre);
    if (n > 0) {
      w.signed_exp_golomb(polygon[0][0] - previous_first[0], kExplicitVertexOrder);
      w.signed_exp_golomb(polygon[0][1] - previous_first[1], kExplicitVertexOrder);
    }
    for (std::size_t k = 1; k < n; ++k) write_fresh(w, polygon[k], polygon[k - 1]);
  } else {
    w.exp_golomb(zigzag(*offset) + 1, kFirstVertexOrder);
    const std::uint32_t first = *shared.find(polygon[0]);  // on the frontier, so known
    // Backward run: v_(n−1), v_(n−2), … along the open edges out of v_0 (the earlier neighbours
    // ran them the other way).
    std::size_t b = 0;
    if (shared.open_out(first)) {
      for (std::uint32_t j = first; b + 1 < n; ++b) {
        const auto next = shared.open_out(j);
        if (!next || shared.point(*next) != polygon[n - 1 - b]) break;
        shared.record(*next, j);
        j = *next;
      }
      w.count(b, kBackwardCentre);
    }
    // Forward run: v_1, v_2, … along open edges into v_0.
    std::size_t f = 0;
    if (shared.open_in(first)) {
      for (std::uint32_t j = first; f + 1 + b < n; ++f) {
        const auto next = shared.open_in(j);
        if (!next || shared.point(*next) != polygon[f + 1]) break;
        shared.record(j, *next);
        j = *next;
      }
      w.count(f, kForwardCentre);
    }
    w.count(n - 1 - b - f, kFreshCentre);
    for (std::size_t k = f + 1; k < n - b; ++k) write_fresh(w, polygon[k], polygon[k - 1]);
  }
  shared.record_polygon(polygon);
  if (n > 0) previous_first = polygon[0];
}

/// A fresh vertex: SEG_3(dx) SEG_3(dy) from the vertex before it.
Lattice read_fresh(BitReader& r, const Lattice& before) {
  const std::int64_t dx = r.signed_exp_golomb(kFreshVertexOrder, "vertex dx");
  const std::int64_t dy = r.signed_exp_golomb(kFreshVertexOrder, "vertex dy");
  const Lattice p = {before[0] + dx, before[1] + dy};
  if (p[0] < 0 || p[1] < 0 || p[0] > 65535 || p[1] > 65535)
    r.fail("fresh vertex outside the lattice");
  return p;
}

/// Reads a polygon written by encode_polygon, then records it. Every run step closes an open
/// edge and every other vertex takes at least kMinFreshVertexBits, so the work is bounded by the
/// input size.
std::vector<Lattice> decode_polygon(BitReader& r, SharedBoundaries& shared,
                                    Lattice& previous_first) {
  std::vector<Lattice> polygon;
  const std::uint64_t u = r.exp_golomb(kFirstVertexOrder, "first vertex");
  if (u == 0) {
    const std::uint64_t n = r.count(kExplicitCountCentre, "vertex count");
    if (n > 1 + r.remaining_bits() / kMinFreshVertexBits) r.fail("vertex count too large");
    if (n > 0) {
      const std::int64_t dx = r.signed_exp_golomb(kExplicitVertexOrder, "first vertex dx");
      const std::int64_t dy = r.signed_exp_golomb(kExplicitVertexOrder, "first vertex dy");
      const Lattice p = {previous_first[0] + dx, previous_first[1] + dy};
      if (p[0] < 0 || p[1] < 0 || p[0] > 65535 || p[1] > 65535)
        r.fail("first vertex outside the lattice");
      polygon.reserve(n);
      polygon.push_back(p);
    }
    for (std::uint64_t k = 1; k < n; ++k) polygon.push_back(read_fresh(r, polygon.back()));
  } else {
    if (u - 1 > 2 * static_cast<std::uint64_t>(kMaxFrontierOffset))
      r.fail("first vertex reference out of range");
    const auto p = shared.frontier_at(previous_first, unzigzag(u - 1));
    if (!p) r.fail("first vertex refers to no vertex on a shared boundary");
    const std::uint32_t first = *shared.find(*p);
    polygon.push_back(*p);
    std::vector<Lattice> backward;  // v_(n−1), v_(n−2), …
    if (shared.open_out(first)) {
      const std::uint64_t b = r.count(kBackwardCentre, "backward run");
      std::uint32_t j = first;
      for (std::uint64_t k = 0; k < b; ++k) {
        const auto next = shared.open_out(j);
        if (!next) r.fail("backward run longer than the shared boundary");
        shared.record(*next, j);
        backward.push_back(shared.point(*next));
        j = *next;
      }
    }
    if (shared.open_in(first)) {
      const std::uint64_t f = r.count(kForwardCentre, "forward run");
      std::uint32_t j = first;
      for (std::uint64_t k = 0; k < f; ++k) {
        const auto next = shared.open_in(j);
        if (!next) r.fail("forward run longer than the shared boundary");
        shared.record(j, *next);
        polygon.push_back(shared.point(*next));
        j = *next;
      }
    }
    const std::uint64_t m = r.count(kFreshCentre, "fresh vertex count");
    if (m > r.remaining_bits() / kMinFreshVertexBits) r.fail("fresh vertex count too large");
    for (std::uint64_t k = 0; k < m; ++k) polygon.push_back(read_fresh(r, polygon.back()));
    polygon.insert(polygon.end(), backward.rbegin(), backward.rend());
  }
  shared.record_polygon(polygon);
  if (!polygon.empty()) previous_first = polygon.front();
  return polygon;
}

std::uint16_t to_half(double v) {
  return cv::float16_t(static_cast<float>(std::clamp(v, -60000.0, 60000.0))).bits();
}
double from_half(std::uint16_t bits) { return static_cast<float>(cv::float16_t::fromBits(bits)); }

/// Mean colour as RGB 5-6-5.
std::uint16_t rgb565(const Eigen::Vector3f& rgb) {
  auto q = [](float v, int levels) {
    return static_cast<std::uint16_t>(std::lround(std::clamp(v, 0.0f, 255.0f) * levels / 255.0f));
  };
  return static_cast<std::uint16_t>(q(rgb.x(), 31) << 11 | q(rgb.y(), 63) << 5 | q(rgb.z(), 31));
}
Eigen::Vector3f from_rgb565(std::uint16_t c) {
  return {std::round((c >> 11) * 255.0f / 31.0f), std::round(((c >> 5) & 63) * 255.0f / 63.0f),
          std::round((c & 31) * 255.0f / 31.0f)};
}

/// Mean of lattice vertices in pixel-centre coordinates (identical in encoder and decoder).
Eigen::Vector2d centroid(const std::vector<Lattice>& lattice) {
  if (lattice.empty()) return Eigen::Vector2d::Zero();
  std::int64_t sx = 0, sy = 0;
  for (const auto& q : lattice) {
    sx += q[0];
    sy += q[1];
  }
  const double n = static_cast<double>(lattice.size());
  return {static_cast<double>(sx) / n - 0.5, static_cast<double>(sy) / n - 0.5};
}

}  // namespace

std::uint32_t planecell_codec_crc32(std::span<const std::uint8_t> data) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::uint8_t byte : data) {
    crc ^= byte;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

std::vector<std::uint8_t> encode_planecells(const std::vector<Planecell>& cells,
                                            const StereoCamera& camera, std::uint64_t frame_id,
                                            const PlanecellCodecOptions& options) {
  CodeWriter w;
  w.out.reserve(64 + cells.size() * 24);
  for (std::uint8_t m : kMagic) w.u8(m);
  w.u8(kPlanecellCodecVersion);
  bool sequential = true;
  for (std::size_t k = 0; k < cells.size() && sequential; ++k) sequential = cells[k].id == k;
  w.u8(static_cast<std::uint8_t>(
      (options.include_histogram ? kFlagHistogram : 0) |
      (options.include_statistics ? kFlagStatistics : 0) | (sequential ? kFlagSequentialIds : 0) |
      (options.include_planeless_polygons ? kFlagPlanelessPolygons : 0)));
  w.varint(frame_id);
  for (double v : {camera.fx, camera.fy, camera.cx, camera.cy, camera.baseline_m})
    w.f32(static_cast<float>(v));
  w.varint(static_cast<std::uint64_t>(std::max(0, camera.width)));
  w.varint(static_cast<std::uint64_t>(std::max(0, camera.height)));
  w.varint(cells.size());

  // Geometry first: every polygon coded against those before it.
  std::vector<std::vector<Lattice>> lattices(cells.size());
  {
    BitWriter geometry;
    std::size_t vertices = 0;
    for (const Planecell& cell : cells) vertices += cell.vertices_px.size();
    SharedBoundaries shared(vertices);
    Lattice previous_first = {0, 0};
    for (std::size_t k = 0; k < cells.size(); ++k) {
      const Planecell& cell = cells[k];
      geometry.bit(cell.has_plane);
      if (!cell.has_plane && !options.include_planeless_polygons) continue;
      for (const auto& p : cell.vertices_px) {
        const double x = std::round(p.x() + 0.5), y = std::round(p.y() + 0.5);
        if (!(x >= 0.0 && y >= 0.0 && x <= 65535.0 && y <= 65535.0))
          throw InputError("encode_planecells: cell " + std::to_string(cell.id) +
                           " has a vertex outside the image lattice (" + std::to_string(p.x()) +
                           ", " + std::to_string(p.y()) + ")");
        lattices[k].push_back({static_cast<std::int64_t>(x), static_cast<std::int64_t>(y)});
      }
      encode_polygon(geometry, shared, lattices[k], previous_first);
    }
    const std::vector<std::uint8_t> bits = geometry.finish();
    w.varint(bits.size());
    w.out.insert(w.out.end(), bits.begin(), bits.end());
  }

  std::int64_t previous_id = -1;
  for (std::size_t k = 0; k < cells.size(); ++k) {
    const Planecell& cell = cells[k];
    const std::vector<Lattice>& lattice = lattices[k];
    if (!sequential) w.svarint(static_cast<std::int64_t>(cell.id) - previous_id - 1);
    previous_id = cell.id;
    if (cell.has_plane) {
      const Eigen::Vector2d mu = centroid(lattice);
      const std::uint16_t a = to_half(cell.disparity_plane.a);
      const std::uint16_t b = to_half(cell.disparity_plane.b);
      // d̄ at the centroid: the decoded plane is exact there up to half a quantum (1/128 px).
      const double d_mean = cell.disparity_plane.at(mu.x(), mu.y());
      const double q = std::clamp(std::round(d_mean / kDisparityStep), -32768.0, 32767.0);
      w.u16(a);
      w.u16(b);
      w.u16(static_cast<std::uint16_t>(static_cast<std::int16_t>(q)));
    }
    w.u16(rgb565(cell.mean_rgb));
    if (options.include_statistics) {
      w.varint(cell.area_px);
      w.varint(cell.inlier_count);
      w.u8(static_cast<std::uint8_t>(
          std::clamp(std::round(cell.inlier_ratio * 255.0f), 0.0f, 255.0f)));
      w.u16(static_cast<std::uint16_t>(
          std::clamp(std::round(cell.depth_sigma_m * 100.0f), 0.0f, 65535.0f)));
    }
    if (options.include_histogram) {
      std::uint8_t nonzero = 0;
      for (float h : cell.histogram) nonzero += std::round(h * 255.0f) > 0.0f;
      w.u8(nonzero);
      for (int bin = 0; bin < kColourHistogramBins; ++bin) {
        const float q = std::round(cell.histogram[bin] * 255.0f);
        if (q <= 0.0f) continue;
        w.u8(static_cast<std::uint8_t>(bin));
        w.u8(static_cast<std::uint8_t>(std::min(q, 255.0f)));
      }
    }
  }
  w.u32(planecell_codec_crc32(w.out));
  return std::move(w.out);
}

DecodedPlanecells decode_planecells(std::span<const std::uint8_t> bytes) {
  CodeReader r{bytes};
  if (bytes.size() < kMagic.size() + 2 + 4) r.fail("input too short for a planecell frame");
  for (std::uint8_t m : kMagic)
    if (r.u8("magic") != m) r.fail("bad magic (not a planecell frame)");
  const std::uint8_t version = r.u8("version");
  if (version != kPlanecellCodecVersion)
    r.fail("unsupported version " + std::to_string(version) + " (this build reads " +
           std::to_string(kPlanecellCodecVersion) + ")");
  // The checksum covers everything before it: verify before trusting any count.
  const std::uint32_t stored = static_cast<std::uint32_t>(bytes[bytes.size() - 4]) |
                               static_cast<std::uint32_t>(bytes[bytes.size() - 3]) << 8 |
                               static_cast<std::uint32_t>(bytes[bytes.size() - 2]) << 16 |
                               static_cast<std::uint32_t>(bytes[bytes.size() - 1]) << 24;
  if (planecell_codec_crc32(bytes.first(bytes.size() - 4)) != stored)
    r.fail("checksum mismatch (corrupt or truncated frame)");
  r.in = bytes.first(bytes.size() - 4);

  DecodedPlanecells out;
  const std::uint8_t flags = r.u8("flags");
  if (flags & ~kKnownFlags) r.fail("unknown flags");
  const bool sequential = flags & kFlagSequentialIds;
  out.options.include_planeless_polygons = flags & kFlagPlanelessPolygons;
  out.options.include_histogram = flags & kFlagHistogram;
  out.options.include_statistics = flags & kFlagStatistics;
  out.frame_id = r.varint("frame id");
  out.camera.fx = r.f32("camera fx");
  out.camera.fy = r.f32("camera fy");
  out.camera.cx = r.f32("camera cx");
  out.camera.cy = r.f32("camera cy");
  out.camera.baseline_m = r.f32("camera baseline");
  const std::uint64_t width = r.varint("image width"), height = r.varint("image height");
  if (width > 65535 || height > 65535) r.fail("implausible image size");
  out.camera.width = static_cast<int>(width);
  out.camera.height = static_cast<int>(height);
  try {
    out.camera.validate("planecell codec camera");
  } catch (const ConfigError& e) {
    r.fail(e.what());
  }
  const std::uint64_t count = r.varint("cell count");
  // Each cell takes at least its colour (2 bytes).
  if (count > r.remaining() / 2) r.fail("cell count " + std::to_string(count) + " too large");
  out.cells.resize(count);

  std::vector<std::vector<Lattice>> lattices(count);
  {
    const std::uint64_t geometry_size = r.varint("geometry size");
    if (geometry_size > r.remaining())
      r.fail("geometry size " + std::to_string(geometry_size) + " too large");
    BitReader g{r.in.subspan(r.pos, geometry_size), r.pos, r.in.size()};
    // About one vertex per byte on extracted frames (more come as the tables grow).
    SharedBoundaries shared(std::min<std::size_t>(geometry_size, std::size_t{1} << 20));
    Lattice previous_first = {0, 0};
    for (std::uint64_t k = 0; k < count; ++k) {
      g.cell = k;
      out.cells[k].has_plane = g.bit("has-plane bit");
      if (out.cells[k].has_plane || out.options.include_planeless_polygons)
        lattices[k] = decode_polygon(g, shared, previous_first);
    }
    g.cell = count;  // past the last
    if (g.remaining_bits() >= 8)
      g.fail(std::to_string(g.remaining_bits() / 8) + " bytes past the last polygon");
    if (g.remaining_bits() > 0 && g.bits(static_cast<int>(g.remaining_bits()), "padding") != 0)
      g.fail("non-zero padding after the last polygon");
    r.pos += geometry_size;
  }

  std::int64_t previous_id = -1;
  for (std::uint64_t k = 0; k < count; ++k) {
    Planecell& cell = out.cells[k];
    const std::vector<Lattice>& lattice = lattices[k];
    const std::int64_t id = previous_id + 1 + (sequential ? 0 : r.svarint("cell id"));
    if (id < 0 || id > 0xFFFFFFFFll) r.fail("cell id out of range");
    cell.id = static_cast<std::uint32_t>(id);
    previous_id = id;
    cell.frame_id = out.frame_id;
    cell.vertices_px.clear();
    for (const auto& q : lattice)
      cell.vertices_px.emplace_back(static_cast<float>(q[0]) - 0.5f,
                                    static_cast<float>(q[1]) - 0.5f);
    if (cell.has_plane) {
      const Eigen::Vector2d mu = centroid(lattice);
      const double a = from_half(r.u16("plane a"));
      const double b = from_half(r.u16("plane b"));
      const double d_mean = static_cast<std::int16_t>(r.u16("plane d")) * kDisparityStep;
      if (!std::isfinite(a) || !std::isfinite(b)) r.fail("non-finite plane");
      cell.disparity_plane = {a, b, d_mean - a * mu.x() - b * mu.y()};
      cell.plane = plane_from_disparity(cell.disparity_plane, out.camera);
      for (const auto& p : cell.vertices_px) {
        const double d = std::max(kMinVertexDisparityPx, cell.disparity_plane.at(p.x(), p.y()));
        cell.vertices_m.push_back(out.camera.back_project(p.x(), p.y(), d).cast<float>());
      }
    }
    cell.mean_rgb = from_rgb565(r.u16("mean colour"));
    if (out.options.include_statistics) {
      const std::uint64_t area = r.varint("area"), inliers = r.varint("inlier count");
      if (area > 0xFFFFFFFFull || inliers > 0xFFFFFFFFull) r.fail("statistics out of range");
      cell.area_px = static_cast<std::uint32_t>(area);
      cell.inlier_count = static_cast<std::uint32_t>(inliers);
      cell.inlier_ratio = r.u8("inlier ratio") / 255.0f;
      cell.depth_sigma_m = r.u16("depth sigma") / 100.0f;
    }
    if (out.options.include_histogram) {
      cell.histogram.fill(0.0f);
      const int nonzero = r.u8("histogram size");
      for (int k = 0; k < nonzero; ++k) {
        const int bin = r.u8("histogram bin");
        if (bin >= kColourHistogramBins) r.fail("histogram bin out of range");
        cell.histogram[bin] = r.u8("histogram value") / 255.0f;
      }
    }
  }
  if (r.remaining() != 0) r.fail(std::to_string(r.remaining()) + " trailing bytes");
  return out;
}

}  // namespace planecell::io
