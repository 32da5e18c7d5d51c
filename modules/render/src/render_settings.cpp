#include "vellum/render/render_settings.hpp"

#include <algorithm>

#include "vellum/core/error.hpp"

namespace vellum::render {

const char* presetName(Preset p) {
  switch (p) {
    case Preset::Bone: return "bone";
    case Preset::SoftTissueBone: return "soft-tissue";
    case Preset::Skin: return "skin";
    case Preset::Mip: return "mip";
  }
  return "?";
}

std::vector<Preset> allPresets() {
  return {Preset::Bone, Preset::SoftTissueBone, Preset::Skin, Preset::Mip};
}

Preset parsePreset(const std::string& name) {
  for (Preset p : allPresets())
    if (name == presetName(p)) return p;
  throw Error("unknown render preset '" + name + "'; valid: bone, soft-tissue, skin, mip");
}

std::array<float, 4> TransferFunction::evaluate(double value) const {
  if (points.empty()) return {0, 0, 0, 0};
  if (value <= points.front().value) return points.front().rgba;
  if (value >= points.back().value) return points.back().rgba;
  // First point strictly above value; the one before it is at or below.
  auto hi = std::upper_bound(points.begin(), points.end(), value,
                             [](double v, const Point& p) { return v < p.value; });
  auto lo = hi - 1;
  const double span = hi->value - lo->value;
  const float t = span > 0 ? static_cast<float>((value - lo->value) / span) : 1.f;
  std::array<float, 4> out{};
  for (int c = 0; c < 4; ++c) out[c] = lo->rgba[c] + t * (hi->rgba[c] - lo->rgba[c]);
  return out;
}

// Values in HU, designed around the default window (centre 400, width 2000). Alpha is
// opacity per mm: 0.9 makes bone opaque within about two millimetres.
TransferFunction TransferFunction::forPreset(Preset p) {
  TransferFunction tf;
  switch (p) {
    case Preset::Bone:
      tf.points = {{-1024, {0.f, 0.f, 0.f, 0.f}},
                   {150, {0.85f, 0.75f, 0.6f, 0.f}},
                   {300, {0.93f, 0.87f, 0.75f, 0.5f}},
                   {1000, {1.f, 0.97f, 0.9f, 0.9f}},
                   {3071, {1.f, 1.f, 1.f, 0.9f}}};
      break;
    case Preset::SoftTissueBone:
      tf.points = {{-1024, {0.f, 0.f, 0.f, 0.f}},
                   {-300, {0.75f, 0.4f, 0.3f, 0.f}},
                   {-100, {0.85f, 0.55f, 0.4f, 0.01f}},
                   {100, {0.8f, 0.3f, 0.25f, 0.03f}},
                   {180, {0.85f, 0.6f, 0.5f, 0.03f}},
                   {300, {0.93f, 0.87f, 0.75f, 0.5f}},
                   {1000, {1.f, 0.97f, 0.9f, 0.9f}},
                   {3071, {1.f, 1.f, 1.f, 0.9f}}};
      break;
    case Preset::Skin:
      tf.points = {{-1024, {0.f, 0.f, 0.f, 0.f}},
                   {-700, {0.9f, 0.7f, 0.6f, 0.f}},
                   {-300, {0.93f, 0.75f, 0.65f, 0.7f}},
                   {3071, {0.95f, 0.8f, 0.7f, 0.9f}}};
      break;
    case Preset::Mip:
      // Unused by the MIP shader (it maps the maximum through window/level); a grey ramp so
      // that evaluate() still says something sensible.
      tf.points = {{-600, {0.f, 0.f, 0.f, 1.f}}, {1400, {1.f, 1.f, 1.f, 1.f}}};
      break;
  }
  return tf;
}

}  // namespace vellum::render
