#pragma once
// What the GL ray caster and the CPU reference share, so that they cannot drift apart:
// camera rays, the ray-box clip, the step, the transfer-function table, shading constants,
// the backward map in index coordinates. Internal to modules/render.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "vellum/core/geometry.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::render::detail {

constexpr int kMaxImageSize = 4096;
constexpr int kTfTableSize = 4096;
constexpr double kEarlyTerminationAlpha = 0.99;
/// Upper bound on steps per ray, against runaway loops from absurd settings.
constexpr int64_t kMaxStepsPerRay = 1 << 16;
/// Default window of the DVR presets' value axis (RenderSettings defaults leave it unchanged).
constexpr double kPresetWindowCenter = 400.0;
constexpr double kPresetWindowWidth = 2000.0;

/// Blinn-Phong with a headlight (light and eye along the ray): ambient + diffuse*|n.l| +
/// specular*|n.l|^shininess (h == l for a headlight). Two-sided.
constexpr float kAmbient = 0.35f;
constexpr float kDiffuse = 0.65f;
constexpr float kSpecular = 0.2f;
constexpr float kShininess = 24.f;
/// With cinematic lighting (RenderSettings::lighting): the share of the diffuse term that comes
/// from the key light (shadowed); the rest stays a headlight fill, so faces turned from the key
/// light keep their form.
constexpr float kKeyLightShare = 0.75f;
/// Shading fades in between these encoded gradient magnitudes (GradientNormals, normal_volume.hpp):
/// homogeneous regions (noise-level gradients) keep their unshaded TF colour.
constexpr float kGradLow = 0.02f;
constexpr float kGradHigh = 0.10f;

/// Throws vellum::Error unless 1 <= width, height <= 4096.
void checkImageSize(int width, int height);

/// Camera and ray-marching set-up for one frame, all in physical mm except `physToBox`.
struct Frame {
  int width = 0, height = 0;
  Vec3 eye, right, up, forward;  ///< orthonormal camera basis; forward = viewing direction
  double halfW = 1, halfH = 1;   ///< perspective: tangents; orthographic: mm
  bool perspective = true;
  /// The box rays are clipped to: index box [-0.5, dims-0.5] of `box` (the volume, or the
  /// map grid when deformed). physToBox maps physical offsets to box index offsets.
  Geometry box;
  Mat3 physToBox;
  /// RenderSettings' clip box in box index coordinates ([-0.5, dims - 0.5] unclipped).
  Vec3 clipLo, clipHi;
  double stepMm = 1;
};

Frame makeFrame(const Geometry& source, const Geometry* mapGrid, const RenderSettings& s);

struct Ray {
  Vec3 origin, dir;  ///< physical, dir unit length
};
/// Ray through the centre of pixel (px, py), row 0 = top.
Ray pixelRay(const Frame& f, int px, int py);

/// Per-pixel sample offset in [0, 1) steps: an integer hash, bit-identical in the shader.
float pixelJitter(int px, int py);

/// Steps k in [k0, k1] at t = (k + jitter) * stepMm along the ray lie inside the box; k1 < k0
/// if none. Also returns the ray in box index coordinates: p(t) = o + t * d.
struct Clip {
  int64_t k0 = 0, k1 = -1;
  double jitter = 0;
  Vec3 o, d;
};
Clip clipRay(const Frame& f, const Ray& r, double jitter);

/// The transfer function after window/level, as a table of kTfTableSize RGBA entries over
/// [lo, hi], with alpha already corrected to the ray step (alpha per mm -> per step).
struct TfTable {
  double lo = 0, hi = 1;
  std::vector<float> rgba;  ///< 4 * kTfTableSize
  /// Linear interpolation between entries, exactly as the shader does it.
  std::array<float, 4> lookup(double value) const;
};
TfTable buildTfTable(const RenderSettings& s, double stepMm);

/// MIP grey level of a maximum value under the settings' window.
double mipGrey(const RenderSettings& s, double maxValue);

/// Source index coordinates (3 floats per map node, x fastest) of a backward map.
/// Throws vellum::Error when the map's sizes do not match its grid.
std::vector<float> mapToSourceIndex(const BackwardMap& map, const Geometry& source);
void validateMap(const BackwardMap& map);

/// sRGB colour shifted by (dL, da, db) in CIE L*a*b* (D65), clamped to [0,1].
std::array<float, 3> labShift(const std::array<float, 3>& rgb, float dL, float da, float db);

/// Trilinear interpolation of an N-channel grid (x fastest) with clamp-to-edge, as GL filters
/// a texture at index coordinates p; each channel times `scale` (1/255 for 8-bit texels). The CPU
/// reference's reading of the attribute texture and of the light volume.
template <int N, class T>
std::array<float, N> sampleClamped(const std::vector<T>& grid, const Dims& d, const Vec3& p, double scale = 1.0) {
  auto clampAxis = [](double v, int64_t n) { return std::clamp(v, 0.0, double(n - 1)); };
  const double x = clampAxis(p.x, d.x), y = clampAxis(p.y, d.y), z = clampAxis(p.z, d.z);
  const auto i0 = std::min<int64_t>(int64_t(x), d.x - 1), j0 = std::min<int64_t>(int64_t(y), d.y - 1),
             k0 = std::min<int64_t>(int64_t(z), d.z - 1);
  const int64_t i1 = std::min(i0 + 1, d.x - 1), j1 = std::min(j0 + 1, d.y - 1), k1 = std::min(k0 + 1, d.z - 1);
  const double tx = x - i0, ty = y - j0, tz = z - k0;
  std::array<float, N> out{};
  for (int c = 0; c < 8; ++c) {
    const int64_t i = (c & 1) ? i1 : i0, j = (c & 2) ? j1 : j0, k = (c & 4) ? k1 : k0;
    const double w = ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz) * scale;
    const T* v = grid.data() + static_cast<size_t>((k * d.y + j) * d.x + i) * N;
    for (int ch = 0; ch < N; ++ch) out[ch] += static_cast<float>(w * double(v[ch]));
  }
  return out;
}

}  // namespace vellum::render::detail
