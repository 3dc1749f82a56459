#pragma once
/// A surface's colour histogram as the map keeps it: 16 bits per bin, only the non-zero bins. A
/// surface's colours fill 16 of the 64 bins on average (soft binning spreads a colour over the
/// 2 × 2 × 2 bins around it), so this takes 16 + 2·16 bytes instead of 128.
#include <array>
#include <bit>
#include <cstdint>
#include <memory>
#include <span>

#include "core/planecell.hpp"

namespace planecell::map {

class CompactHistogram {
 public:
  static constexpr std::size_t kBins = kColourHistogramBins;
  static_assert(kBins == 64, "the mask holds one bit per bin");
  using Bins = std::array<std::uint16_t, kBins>;

  CompactHistogram() = default;
  /// The histogram whose bin q holds bins[q].
  explicit CompactHistogram(const Bins& bins);
  CompactHistogram(const CompactHistogram& o);
  CompactHistogram(CompactHistogram&&) noexcept = default;
  CompactHistogram& operator=(const CompactHistogram& o);
  CompactHistogram& operator=(CompactHistogram&&) noexcept = default;
  ~CompactHistogram() = default;

  /// Bin q (0 when q is not a bin).
  std::uint16_t operator[](std::size_t q) const;
  Bins bins() const;
  /// Bit q set when bin q is non-zero.
  std::uint64_t mask() const { return mask_; }
  /// The non-zero bins' values, in bin order (popcount(mask()) of them).
  std::span<const std::uint16_t> nonzero() const {
    return {values_.get(), static_cast<std::size_t>(std::popcount(mask_))};
  }
  /// Heap bytes of the non-zero values.
  std::size_t bytes() const { return nonzero().size() * sizeof(std::uint16_t); }
  bool operator==(const CompactHistogram& o) const;

 private:
  std::uint64_t mask_ = 0;
  std::unique_ptr<std::uint16_t[]> values_;
};

/// h_q → round(clamp(h_q, 0, 1) · 65535): a histogram normalised to sum 1 at 16 bits per bin
/// (error ≤ 2⁻¹⁷ per bin).
CompactHistogram compact(const ColourHistogram& histogram);
/// q → q / 65535.
ColourHistogram expand(const CompactHistogram& histogram);

}  // namespace planecell::map
