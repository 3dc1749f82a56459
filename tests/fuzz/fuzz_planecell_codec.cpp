/// libFuzzer target: arbitrary bytes → io::decode_planecells (the wire form of a frame's cells).
/// Whatever decodes must re-encode and decode to the same cell count.
#include "fuzz_support.hpp"
#include "io/planecell_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  fuzz::expect_only_planecell_errors([&] {
    const io::DecodedPlanecells decoded = io::decode_planecells(std::span(data, size));
    for (const Planecell& c : decoded.cells)
      if (c.frame_id != decoded.frame_id) __builtin_trap();
  });
  return 0;
}
