#pragma once
// The illustration renderer ([SAVI 2.5] in docs/references.md): a GLSL ray caster over a shape-aware scene
// (signed distance + segment labels, optionally the CT), and its CPU reference.
//
// Model (GL and CPU alike; docs/illustration-renderer.md): the render module's camera, rays,
// box clip, step and per-pixel jitter (render::RenderSettings; transfer function/preset/
// shading fields are ignored). Every segment has its own signed distance (ShapeScene::fields).
// Per sample, each segment's distance is interpolated trilinearly and its gradient taken from
// the interpolated field (eight: central differences over +-1 voxel; nearest: forward
// differences, cheaper); the segment covers clamp(0.5 - d / h, 0, 1) of the sample (h =
// smallest spacing), later segments painting over earlier ones (a soft painter's order), and
// each segment is styled with its OWN distance and gradient — so a bone inside an invisible
// skin renders as the bone alone, and no label staircase reaches the shading.
// The per-step alpha is 1 - (1 - a)^step_mm; front-to-back compositing with early
// termination at 0.99; straight alpha; background from RenderSettings (alpha 0 = transparent).
#include <memory>
#include <optional>
#include <string>

#include "vellum/core/enum_table.hpp"
#include "vellum/core/image.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/illustration/style.hpp"
#include "vellum/render/gl_context.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::illustration {

enum class Interpolation { Eight, Nearest };
const params::EnumTable<Interpolation>& interpolations();  ///< "eight", "nearest"
inline const char* interpolationName(Interpolation i) { return interpolations().name(i); }
inline Interpolation parseInterpolation(const std::string& name) { return interpolations().parse(name); }

/// What is rendered: the shape folder's volumes (same grid), and optionally the CT.
struct ShapeScene {
  VolumeF32 distance;            ///< union distance, mm, negative inside (empty: not loaded)
  LabelVolume segments;          ///< ids 0..255, 0 = unclassified, with the label table
  std::vector<SegmentField> fields;  ///< per-segment distances, paint order (what is rendered)
  std::optional<AnyVolume> ct;   ///< needed only by illum = ct / boundary_measure = ct rows
  /// The scene's grid: the union distance's, or the segments' when it was not loaded (the
  /// renderer draws the per-segment fields only).
  const Geometry& grid() const { return distance.empty() ? segments.geometry() : distance.geometry(); }
};

/// Loads DIR/distance.nrrd, DIR/segments.nrrd and the per-segment distances
/// (DIR/distances.json); FileError naming the file for a missing folder/file (an older shape
/// folder: "run `vellum shape` again"), mismatched grids or ids over 255. `unionDistance`
/// false: distance.nrrd's header is read and checked, its samples are not (ShapeScene::distance
/// stays empty; the renderer needs only the per-segment fields).
ShapeScene loadShapeFolder(const std::filesystem::path& dir, bool unionDistance = true);
/// Throws vellum::Error when the volumes' grids differ or ids exceed 255.
void validateScene(const ShapeScene& scene);

struct IllustrationSettings {
  /// Size, camera, step, jitter, background. The step defaults to one voxel here (the
  /// render module's 0.5): styled surfaces come from a smooth distance field, and the
  /// per-pixel jitter hides sampling rings.
  render::RenderSettings render;
  Interpolation interpolation = Interpolation::Eight;
  /// Adaptive step: where every segment's distance says the samples ahead are all alike
  /// (empty space, or deep inside a translucent fill), one sample stands for them (the
  /// reference, false, marches every step; figures agree within the PSNR in
  /// docs/benchmarks-illustration.md).
  bool adaptiveStep = true;
  /// Image-space refinement (illustration/src/image_refine.hpp): trace every
  /// 2^refineLevels-th pixel in x and y first, then halve the spacing where neighbours differ
  /// by more than refineTolerance (0..1) or pass near ink, interpolating the rest. 0: a ray
  /// through every pixel (the reference). GL and the CPU reference refine alike.
  int refineLevels = 0;
  float refineTolerance = 4.f / 255.f;
  IllustrationSettings() { render.stepVoxels = 1.0; }
};

/// GL renderer. The scene is uploaded once by setScene() (per-segment distances as RGBA16_SNORM,
/// four segments a texel, slab by slab; CT and its gradient when a style needs them);
/// styles are a small lookup texture, updated per render. Shaders are specialised per
/// interpolation mode and per the style's features with #defines.
class IllustrationRenderer {
 public:
  explicit IllustrationRenderer(render::GlContext& context);
  ~IllustrationRenderer();
  IllustrationRenderer(const IllustrationRenderer&) = delete;
  IllustrationRenderer& operator=(const IllustrationRenderer&) = delete;

  void setScene(const ShapeScene& scene);
  RgbaImage render(const Style& style, const IllustrationSettings& settings);
  /// Milliseconds of the last render's draw (glFinish-bounded), excluding uploads and the
  /// shader's first-use compilation.
  double lastRenderMs() const;
  /// Milliseconds setScene() spent (packing + upload of the distances, block ranges).
  double lastUploadMs() const;
  /// Rays the last render() traced per image pixel (1 without refinement; refineLevels).
  double lastTracedFraction() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// CPU reference of the same model (TBB over rows). Slow; for tests and small images.
RgbaImage renderIllustrationCpu(const ShapeScene& scene, const Style& style,
                                const IllustrationSettings& settings);

}  // namespace vellum::illustration
