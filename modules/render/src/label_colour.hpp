#pragma once
// Label colours of a sample (label_tint.hpp), shared by the CPU ray caster and the CPU path
// tracer; twin of labelTint() in raycast.frag.glsl. Internal to modules/render.
#include <array>
#include <cmath>

#include "render_common.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/render/label_tint.hpp"

namespace vellum::render::detail {

/// `rgb` pulled towards the label colours around source index u by `blend`: the one-hot
/// colours of the 8 voxels around u, trilinear and weighted by each voxel's opacity in `tf`
/// (smooth across a boundary; a bone's surface sample takes the bone's colour, not that of the
/// faint tissue beside it). Untinted voxels (id 0, hidden) pull towards rgb itself. Without
/// any opaque corner, plain trilinear weights.
template <class V>
std::array<float, 3> tintByLabels(std::array<float, 3> rgb, const Vec3& u, const Volume<V>& vol, const TfTable& tf,
                                  const LabelTint& tint, float blend) {
  const Dims& d = tint.ids.dims();
  const double fx = std::floor(u.x), fy = std::floor(u.y), fz = std::floor(u.z);
  const int64_t bx = int64_t(fx), by = int64_t(fy), bz = int64_t(fz);
  const float f[3] = {float(u.x - fx), float(u.y - fy), float(u.z - fz)};
  std::array<float, 3> pull{0, 0, 0}, plainPull{0, 0, 0};
  float wsum = 0, psum = 0;
  for (int n = 0; n < 8; ++n) {
    const int o[3] = {n & 1, (n >> 1) & 1, (n >> 2) & 1};
    const int64_t i = bx + o[0], j = by + o[1], k = bz + o[2];
    if (i < 0 || j < 0 || k < 0 || i >= d.x || j >= d.y || k >= d.z) continue;
    float w = 1;
    for (int a = 0; a < 3; ++a) w *= o[a] ? f[a] : 1 - f[a];
    const float alpha = tf.lookup(double(vol(i, j, k)))[3];
    const uint16_t id = tint.ids(i, j, k);
    const std::array<uint8_t, 4> lc = id < kMaxTintLabels ? tint.colours[id] : std::array<uint8_t, 4>{0, 0, 0, 0};
    wsum += w * alpha;
    psum += w;
    for (int ch = 0; ch < 3; ++ch) {
      const float toward = (lc[3] / 255.f) * (lc[size_t(ch)] / 255.f - rgb[size_t(ch)]);
      pull[size_t(ch)] += w * alpha * toward;
      plainPull[size_t(ch)] += w * toward;
    }
  }
  if (!(wsum > 1e-6f)) pull = plainPull, wsum = psum;
  if (wsum > 0)
    for (int ch = 0; ch < 3; ++ch) rgb[size_t(ch)] += blend * pull[size_t(ch)] / wsum;
  return rgb;
}

}  // namespace vellum::render::detail
