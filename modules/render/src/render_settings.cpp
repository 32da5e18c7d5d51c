#include "vellum/render/render_settings.hpp"

#include <algorithm>

#include "render_common.hpp"
#include "vellum/core/error.hpp"

namespace vellum::render {

namespace {
const std::vector<std::string> kQualityNames{"standard", "cinematic"};
}  // namespace

const params::EnumTable<Preset>& presets() {
  static const params::EnumTable<Preset> t{"render preset", {"bone", "soft-tissue", "skin", "mip"}};
  return t;
}

const params::Table<RenderSettings>& renderSettingsTable() {
  using params::Info;
  using R = RenderSettings;
  static const params::Table<R> table{
      params::integer<R>("width", &R::width, {"Width", "image width", "pixels", 1, detail::kMaxImageSize}),
      params::integer<R>("height", &R::height, {"Height", "image height", "pixels", 1, detail::kMaxImageSize}),
      params::choice<R>("preset", &R::preset, presets().names,
                        {"Preset", "transfer function: opaque bone, soft tissue over bone, skin surface, or MIP", ""}),
      params::real<R>("azimuth", params::nested(&R::camera, &Camera::azimuthDeg),
                      {"Azimuth", "camera turn about the superior axis; 0 looks from anterior", "degrees", -3600, 3600}),
      params::real<R>("elevation", params::nested(&R::camera, &Camera::elevationDeg),
                      {"Elevation", "camera tilt towards superior", "degrees", -90, 90}),
      params::real<R>("zoom", params::nested(&R::camera, &Camera::zoom),
                      {"Zoom", "1 = the volume's bounding sphere fills the view (illustrate: what it draws, see --frame)", "", 0.05, 50}),
      params::real<R>("fov", params::nested(&R::camera, &Camera::fieldOfViewDeg),
                      {"Field of view", "vertical; 0 = orthographic projection", "degrees", 0, 120}),
      params::real<R>("window_center", &R::windowCenter,
                      {"Window centre", "MIP grey mapping; DVR: shifts the transfer function", "HU", -32768, 32767}),
      params::real<R>("window_width", &R::windowWidth,
                      {"Window width", "MIP grey mapping; DVR: scales the transfer function (0 = the preset's own)", "HU", 0, 65536}),
      params::flag<R>("shading", &R::shading,
                      {"Shading", "Blinn-Phong shading from the gradient (DVR presets)", ""}),
      params::real<R>("step", &R::stepVoxels,
                      {"Ray step", "sampling step along rays", "voxels", 0.05, 4}),
      params::flag<R>("jitter", &R::jitter,
                      {"Jitter", "fixed per-pixel ray offsets: fine noise instead of wood-grain rings", ""}),
      params::real<R>("label_blend", &R::labelBlend,
                      {"Label colours", "how much label colours tint the volume (0 = off; needs a label map)", "", 0, 1}),
      params::vector<R>("clip_min", &R::clipMin,
                        {"Clip box min", "region of interest: its low corner as fractions of the volume's i, j, k extent", "fraction", 0, 1}),
      params::vector<R>("clip_max", &R::clipMax,
                        {"Clip box max", "region of interest: its high corner as fractions of the volume's i, j, k extent", "fraction", 0, 1}),
      params::integer<R>("only_label", &R::onlyLabel,
                         {"Only label", "draw only this label id's voxels (0 = all; needs a label map)", "", 0, 65535}),
      params::real<R>("shadows", params::nested(&R::lighting, &Lighting::shadows),
                      {"Shadows", "volumetric shadows of the key light: how much they darken (0 = off; shaded DVR; illustrate: a layer over the figure)", "", 0, 1}),
      params::real<R>("occlusion", params::nested(&R::lighting, &Lighting::occlusion),
                      {"Ambient occlusion", "how much crevices darken, from the opacity around each sample (0 = off)", "", 0, 1}),
      params::real<R>("occlusion_radius", params::nested(&R::lighting, &Lighting::occlusionRadiusMm),
                      {"Occlusion radius", "the neighbourhood whose opacity occludes", "mm", 1, 100}),
      params::real<R>("light_azimuth", params::nested(&R::lighting, &Lighting::azimuthDeg),
                      {"Light azimuth", "key light turned about the view's up axis; 0 = from the eye, negative = from the left", "degrees", -180, 180}),
      params::real<R>("light_elevation", params::nested(&R::lighting, &Lighting::elevationDeg),
                      {"Light elevation", "key light raised towards the top of the view", "degrees", -90, 90}),
      params::real<R>("exposure", params::nested(&R::lighting, &Lighting::exposure),
                      {"Exposure", "with shadows or occlusion, or cinematic: brightens the lit colour by this many stops", "stops", -4, 4}),
      params::flag<R>("tone_map", params::nested(&R::lighting, &Lighting::toneMap),
                      {"Tone map", "ray caster (shaded DVR): the cinematic lights (soft key, fill, sky; shadows and occlusion as set) in linear light, ACES tone mapped with the exposure", ""}),
      params::choice<R>("quality", &R::quality, kQualityNames,
                        {"Quality", "standard ray casting, or cinematic: progressive path tracing (DVR presets; docs/lighting.md)", ""}),
      params::integer<R>("samples", params::nested(&R::cinematic, &Cinematic::samples),
                         {"Samples", "cinematic: paths per pixel (a movie frame takes as many)", "", 1, 65536}),
      params::real<R>("time_limit", params::nested(&R::cinematic, &Cinematic::timeLimitS),
                      {"Time limit", "cinematic: no sample pass that would end past it (0 = none); render: the whole command, loading to written figures, shared by its figures; animate: per frame", "s", 0, 86400}),
      params::integer<R>("seed", params::nested(&R::cinematic, &Cinematic::seed),
                         {"Seed", "cinematic: random seed; the same seed gives the same picture", "", 0, 2147483647}),
      params::integer<R>("bounces", params::nested(&R::cinematic, &Cinematic::bounces),
                         {"Bounces", "cinematic: scattering events per path (1 = single scattering)", "", 1, 8}),
      params::real<R>("denoise", params::nested(&R::cinematic, &Cinematic::denoise),
                      {"Denoise", "cinematic: edge-aware filter at the end, guided by the ray-cast picture (0 = off)", "", 0, 1}),
      params::real<R>("light_size", params::nested(&R::cinematic, &Cinematic::lightSizeDeg),
                      {"Light size", "cinematic or tone_map: angular radius of the key light (soft shadow edges; 0 = sharp)", "degrees", 0, 45}),
      params::real<R>("fill_light", params::nested(&R::cinematic, &Cinematic::fillLight),
                      {"Fill light", "cinematic or tone_map: a second light mirrored from the key, relative to it (0 = off)", "", 0, 2}),
      params::real<R>("sky_light", params::nested(&R::cinematic, &Cinematic::skyLight),
                      {"Sky light", "cinematic or tone_map: radiance of the surrounding sky (ambient light the volume occludes)", "", 0, 4}),
      params::real<R>("trace_scale", params::nested(&R::cinematic, &Cinematic::traceScale),
                      {"Trace scale", "cinematic: paths traced at this fraction of the image size, upsampled under the full-size denoise guide", "", 0.25, 1}),
      params::flag<R>("volume_shadows", params::nested(&R::cinematic, &Cinematic::volumeShadows),
                      {"Volume shadows", "cinematic: key-light shadows and sky occlusion from the precomputed light volume instead of traced rays (faster, coarser)", ""}),
  };
  return table;
}

void validate(const RenderSettings& s) { params::validate(renderSettingsTable(), s); }

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
