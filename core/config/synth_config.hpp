#pragma once
/// Configuration of the synthetic stereo world (io/synthetic).
#include <cstdint>

namespace planecell {

/// A KITTI-like street of textured planes seen from a driving stereo rig.
/// The intrinsics are those of a KITTI 1242×375 image (`kSynthReferenceWidth/Height`); for other
/// image sizes fx, fy, cx are scaled by width/1242 and cy by height/375, so the view stays KITTI-like.
struct SynthConfig {
  int frames = 100;
  std::uint64_t seed = 1;
  int width = 1242;
  int height = 375;
  bool loop = false;  ///< drive around a closed block twice (the second lap re-observes the first)

  double fx = 721.5377;  ///< px, at 1242×375
  double fy = 721.5377;
  double cx = 609.5593;
  double cy = 172.854;
  double baseline_m = 0.54;
  double camera_height_m = 1.65;  ///< optical centre above the road
  double speed_mps = 10.0;        ///< nominal driving speed (the loop adapts it to close two laps)
  double frame_rate_hz = 10.0;    ///< times.txt spacing
  double sensor_noise_sigma = 1.0;  ///< Gaussian noise per view (grey levels, 0 = none)
  double max_range_m = 400.0;     ///< surfaces further away are not drawn (background excepted)
  int png_compression = 1;        ///< 0..9, 1 = fast
};

inline constexpr int kSynthReferenceWidth = 1242;
inline constexpr int kSynthReferenceHeight = 375;

template <class Visitor>
void visit_fields(SynthConfig& c, Visitor&& visit) {
  visit("frames", c.frames);
  visit("seed", c.seed);
  visit("width", c.width);
  visit("height", c.height);
  visit("loop", c.loop);
  visit("fx", c.fx);
  visit("fy", c.fy);
  visit("cx", c.cx);
  visit("cy", c.cy);
  visit("baseline_m", c.baseline_m);
  visit("camera_height_m", c.camera_height_m);
  visit("speed_mps", c.speed_mps);
  visit("frame_rate_hz", c.frame_rate_hz);
  visit("sensor_noise_sigma", c.sensor_noise_sigma);
  visit("max_range_m", c.max_range_m);
  visit("png_compression", c.png_compression);
}

}  // namespace planecell
