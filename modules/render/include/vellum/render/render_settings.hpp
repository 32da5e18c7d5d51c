#pragma once
// What to render and how: presets, transfer functions, camera. All distances in mm.
#include <array>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/vec.hpp"

namespace vellum::render {

enum class Preset {
  Bone,            ///< "bone": opaque bone, everything else transparent
  SoftTissueBone,  ///< "soft-tissue": translucent soft tissue over opaque bone
  Skin,            ///< "skin": opaque skin surface
  Mip,             ///< "mip": maximum intensity projection, grey by window/level
};
const params::EnumTable<Preset>& presets();
inline const char* presetName(Preset p) { return presets().name(p); }
/// Parses the names above; throws vellum::Error listing the valid ones.
inline Preset parsePreset(const std::string& name) { return presets().parse(name); }
inline std::vector<Preset> allPresets() { return presets().all(); }

/// Piecewise-linear RGBA over scalar value (HU for CT). Colour in [0,1]; alpha is opacity
/// per millimetre of ray (so images do not change with the sampling step).
struct TransferFunction {
  struct Point {
    double value;
    std::array<float, 4> rgba;
  };
  std::vector<Point> points;  ///< sorted by value
  /// Evaluates at value (clamped to the first/last point).
  std::array<float, 4> evaluate(double value) const;
  static TransferFunction forPreset(Preset p);
};

/// Orbit camera around the volume's centre. Azimuth rotates about the patient's
/// superior axis (+z in LPS), elevation tilts towards it. Azimuth 0, elevation 0 looks
/// from anterior (-y in LPS) towards posterior, with superior up on screen.
struct Camera {
  double azimuthDeg = 30.0;
  double elevationDeg = 15.0;
  double zoom = 1.0;             ///< 1 = the whole volume's bounding sphere fits the view
  Vec3 panMm{0, 0, 0};           ///< shifts the look-at point (mm, physical space)
  double fieldOfViewDeg = 30.0;  ///< vertical; 0 selects orthographic projection
};

/// Cinematic lighting terms (docs/lighting.md): a key light with volumetric shadows and ambient
/// occlusion, both from the transfer function's opacity. Both 0 = the plain headlight shading.
struct Lighting {
  double shadows = 0;            ///< 0..1: how much the key light's shadow darkens (0 = off)
  double occlusion = 0;          ///< 0..1: how much ambient occlusion darkens (0 = off)
  double occlusionRadiusMm = 8;  ///< neighbourhood that occludes
  double azimuthDeg = -45;       ///< key light turned about the view's up axis; 0 = from the eye, < 0 from the left
  double elevationDeg = 40;      ///< key light raised towards the view's up axis
  /// Brightens the lit colour by 2^exposure stops before it is clamped (the shadowed picture
  /// is darker than the headlit one; about +0.3 restores its mid-tones).
  double exposure = 0;
  /// The cinematic path tracer's lights (Cinematic: soft key of lightSizeDeg, fill, sky) in
  /// linear light, ACES tone mapped with the exposure, instead of key + headlight clamped.
  bool toneMap = false;
  bool on() const { return shadows > 0 || occlusion > 0 || toneMap; }
};

/// How the picture is made: the ray caster (one pass, local shading and the lighting terms
/// above), or a progressive Monte Carlo path tracer (docs/lighting.md, "Cinematic").
enum class Quality {
  Standard,   ///< "standard": the ray caster
  Cinematic,  ///< "cinematic": path traced (single or multiple scattering), tone mapped, denoised
};

/// The path tracer's settings (Quality::Cinematic). The key light's direction and the exposure
/// are Lighting's; the light size, fill and sky also light the ray caster with Lighting::toneMap.
struct Cinematic {
  int samples = 64;        ///< paths per pixel
  double timeLimitS = 0;   ///< no sample pass that would end past it (0 = none; at least one pass); see the time_limit row
  int seed = 1;            ///< the same seed gives the same picture (hash-based random numbers)
  int bounces = 1;         ///< scattering events per path: 1 = single scattering (+ sky light)
  double denoise = 0.5;    ///< edge-aware filter at the end (guided by the ray-cast picture), 0 = off
  double lightSizeDeg = 6; ///< the key light's angular radius: soft shadow edges (0 = sharp)
  double fillLight = 0.3;  ///< a second (fill) light, mirrored from the key, relative to the key
  double skyLight = 0.6;   ///< radiance of the surrounding sky light (ambient, occluded by the volume)
  /// Paths are traced at this fraction of the image's width and height and upsampled before the
  /// denoise, whose guide (the ray-cast picture) is full size: 0.5 = a quarter of the paths per
  /// sample pass, edges still sharp.
  double traceScale = 1;
  /// The key light's shadow and the sky's occlusion looked up in the ray caster's light volume
  /// (soft by lightSizeDeg) instead of traced per path: far cheaper, the light volume's
  /// resolution (about 1/192 of the volume) instead of exact shadows.
  bool volumeShadows = false;
};

struct RenderSettings {
  int width = 512;   ///< 1..4096
  int height = 512;  ///< 1..4096
  Preset preset = Preset::SoftTissueBone;
  /// Overrides the preset's transfer function when non-empty.
  TransferFunction transferFunction;
  Camera camera;
  /// Window/level in HU. MIP: maps the maximum to grey. DVR presets: when set (width > 0),
  /// shifts/scales the transfer function's value axis from its default window.
  double windowCenter = 400.0;
  double windowWidth = 2000.0;
  bool shading = true;                          ///< gradient (Blinn-Phong) shading, DVR only
  /// Deformed renders shade with the source's normals turned by the backward map's Jacobian
  /// (J^T grad, so bent anatomy is lit as bent). false: the source's normals as they are (the
  /// old shading; for comparisons, not in the parameter table).
  bool turnDeformedNormals = true;
  std::array<float, 4> background{0.f, 0.f, 0.f, 1.f};  ///< alpha 0 => transparent PNG
  double stepVoxels = 0.5;                      ///< ray step in voxels of the smallest spacing
  /// Offsets each ray's samples by a fixed per-pixel fraction of a step (an integer hash of
  /// the pixel, so images stay deterministic): turns "wood-grain" rings into fine noise.
  bool jitter = true;
  /// Label colours in the 3D view: how much each sample's label colour replaces the transfer
  /// function's colour (0 = off; needs a LabelTint, see label_tint.hpp). DVR only.
  double labelBlend = 0.0;
  /// Clipping box (region of interest): only what lies inside is drawn, as fractions of the
  /// voxel box along its i, j, k axes (of the map grid when deformed); 0..1 = all of it.
  /// The key light's shadows and the path tracer's scattering still see the whole volume.
  std::array<double, 3> clipMin{0, 0, 0}, clipMax{1, 1, 1};
  /// Draws only the samples of this label id (0 = all); needs a LabelTint (the label map).
  /// DVR, ray caster.
  int onlyLabel = 0;
  Lighting lighting;  ///< DVR with shading only
  Quality quality = Quality::Standard;  ///< cinematic: VolumeRenderer::render() path traces (DVR presets)
  Cinematic cinematic;
};

/// Parameter table of RenderSettings (size, preset, camera, window, shading, step, jitter):
/// the CLI flags of `vellum render`/`animate`, the scene file and docs/parameters.md come
/// from it. The transfer function and the background colour are not single numbers and are
/// handled by their own options.
const params::Table<RenderSettings>& renderSettingsTable();
/// Throws vellum::Error naming the first setting outside its range.
void validate(const RenderSettings& s);

}  // namespace vellum::render
