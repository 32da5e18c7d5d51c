#pragma once
// The lights and the tone map, defined ONCE for the ray caster (RenderSettings::Lighting::toneMap)
// and the cinematic path tracer (docs/lighting.md): a key light (a disc: soft shadows), a fill
// light mirrored to the other side, a sky, exposure and ACES filmic. The GLSL twin is
// shaders/lights.glsl (same names, same constants): the CPU reference renderer's side, held to
// the GL one by RenderGl.ToneMappedAreaLightMatchesCpu and LightingMatchesCpuAndShadowsTheFarSide.
// Internal to modules/render.
#include <array>

#include "render_common.hpp"

namespace vellum::render::detail {

/// Irradiance of the key light at normal incidence: pi, so that a white Lambertian surface
/// facing it has radiance 1.
constexpr float kKeyIrradiance = 3.14159265f;
/// Henyey-Greenstein anisotropy of the volume phase function (slightly forward, as tissue).
constexpr float kPhaseG = 0.2f;
/// Elevation of the fill light (degrees): low, on the side opposite the key.
constexpr double kFillElevationDeg = 10;

/// The lights of a frame, physical directions pointing towards them: the key light (a disc of
/// angular radius cinematic.lightSizeDeg), the fill light (the key's azimuth mirrored, low;
/// irradiance cinematic.fillLight x the key's), a sky of radiance sky * (0.75 + 0.25 cos(angle to
/// the view's up)), and the exposure 2^lighting.exposure.
struct SceneLights {
  Vec3 key, fill, up;
  float keyCos = 1;           ///< cos of the key light's angular radius
  float keyE = 0, fillE = 0;  ///< irradiance at normal incidence
  float sky = 0;
  float exposure = 1;  ///< 2^stops
};
SceneLights makeSceneLights(const Frame& f, const RenderSettings& s);

/// Sky radiance towards direction w (physical, unit).
inline float skyRadiance(const SceneLights& l, const Vec3& w) { return l.sky * float(0.75 + 0.25 * dot(w, l.up)); }

/// Display colour of linear radiance already times the exposure: ACES filmic (Narkowicz's fit,
/// input pre-scaled by 0.6 so that 1 maps near the knee), then sRGB. Twin of toneMap() in lights.glsl.
float toneMap(float linear);
/// sRGB-ish table colour -> linear albedo (gamma 2.2, clamped), as srgbToLinear() in lights.glsl.
float srgbToLinear(float c);

/// The ray caster's radiance of one sample under the scene lights (Lighting::toneMap):
/// `albedo` linear; n the gradient normal (length 0: none) and its strength w (0..1,
/// kGradLow..kGradHigh) blending a Lambert + Blinn-Phong surface with an isotropic medium;
/// v towards the eye; T the key light's transmittance (the light volume, softened by the light's
/// size), A the ambient openness (sky occlusion). The fill light is unshadowed. Twin of
/// sceneRadiance() in lights.glsl.
std::array<float, 3> sceneRadiance(const SceneLights& l, const std::array<float, 3>& albedo, Vec3 n, float w,
                                   const Vec3& v, float T, float A);

}  // namespace vellum::render::detail
