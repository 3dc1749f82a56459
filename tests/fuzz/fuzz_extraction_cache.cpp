/// libFuzzer target: arbitrary bytes → io::decode_extraction_cache. The input's last 4 bytes are
/// first set to its CRC-32, so the fuzzer reaches the parser behind the checksum (a file whose
/// checksum matches but whose sizes lie); only StorageError may come out, and a decoded frame's
/// labels name only its cells.
#include <vector>

#include "fuzz_support.hpp"
#include "io/extraction_cache.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  std::vector<std::uint8_t> bytes(data, data + size);
  if (bytes.size() >= 4) {
    const std::uint32_t crc = io::extraction_cache_crc32(std::span(bytes).first(bytes.size() - 4));
    for (int k = 0; k < 4; ++k) bytes[bytes.size() - 4 + k] = static_cast<std::uint8_t>(crc >> (8 * k));
  }
  // The fingerprint the seeds were written with (make_seeds.cpp), and frame 3.
  fuzz::expect_only_planecell_errors([&] {
    const auto frame = io::decode_extraction_cache(bytes, 0x5eed, 3, "fuzz");
    if (!frame) return;
    for (int y = 0; y < frame->labels.rows; ++y)
      for (int x = 0; x < frame->labels.cols; ++x)
        if (frame->labels.at<std::int32_t>(y, x) >= static_cast<std::int32_t>(frame->cells.size())) __builtin_trap();
  });
  return 0;
}
