#include "mapping/map/compact_histogram.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace planecell::map {

CompactHistogram::CompactHistogram(const Bins& bins) {
  for (std::size_t q = 0; q < kBins; ++q)
    if (bins[q] != 0) mask_ |= std::uint64_t{1} << q;
  const auto n = static_cast<std::size_t>(std::popcount(mask_));
  if (n == 0) return;
  values_ = std::make_unique<std::uint16_t[]>(n);
  std::size_t k = 0;
  for (std::uint16_t h : bins)
    if (h != 0) values_[k++] = h;
}

CompactHistogram::CompactHistogram(const CompactHistogram& o) : mask_(o.mask_) {
  const std::span<const std::uint16_t> values = o.nonzero();
  if (values.empty()) return;
  values_ = std::make_unique<std::uint16_t[]>(values.size());
  std::copy(values.begin(), values.end(), values_.get());
}

CompactHistogram& CompactHistogram::operator=(const CompactHistogram& o) {
  if (this != &o) *this = CompactHistogram(o);
  return *this;
}

std::uint16_t CompactHistogram::operator[](std::size_t q) const {
  if (q >= kBins || !((mask_ >> q) & 1)) return 0;
  // Its rank among the non-zero bins: the set bits below q.
  return values_[static_cast<std::size_t>(std::popcount(mask_ & ((std::uint64_t{1} << q) - 1)))];
}

CompactHistogram::Bins CompactHistogram::bins() const {
  Bins out{};
  std::size_t k = 0;
  for (std::size_t q = 0; q < kBins; ++q)
    if ((mask_ >> q) & 1) out[q] = values_[k++];
  return out;
}

bool CompactHistogram::operator==(const CompactHistogram& o) const {
  const auto a = nonzero(), b = o.nonzero();
  return mask_ == o.mask_ && std::equal(a.begin(), a.end(), b.begin(), b.end());
}

CompactHistogram compact(const ColourHistogram& histogram) {
  CompactHistogram::Bins bins{};
  for (std::size_t q = 0; q < bins.size(); ++q)
    bins[q] = static_cast<std::uint16_t>(std::lround(std::clamp(histogram[q], 0.0f, 1.0f) * 65535.0f));
  return CompactHistogram(bins);
}

ColourHistogram expand(const CompactHistogram& histogram) {
  ColourHistogram out{};
  const CompactHistogram::Bins bins = histogram.bins();
  for (std::size_t q = 0; q < out.size(); ++q) out[q] = static_cast<float>(bins[q]) / 65535.0f;
  return out;
}

}  // namespace planecell::map
