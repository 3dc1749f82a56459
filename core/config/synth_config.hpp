#pragma once
/// Configuration of the synthetic stereo world (io/synthetic).
#include <cstdint>

namespace planecell {

/// A KITTI-like street of textured planes seen from a driving stereo rig.
struct SynthConfig {
  int frames = 100;
  std::uint64_t seed = 1;
  int width = 1242;
  int height = 375;
  bool loop = false;  ///< drive the same street twice
};

template <class Visitor>
void visit_fields(SynthConfig& c, Visitor&& visit) {
  visit("frames", c.frames);
  visit("seed", c.seed);
  visit("width", c.width);
  visit("height", c.height);
  visit("loop", c.loop);
}

}  // namespace planecell
