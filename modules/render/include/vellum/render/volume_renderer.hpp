#pragma once
// GLSL ray caster into an offscreen framebuffer, and its CPU reference.
#include <functional>
#include <memory>

#include "vellum/core/image.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/label_tint.hpp"
#include "vellum/render/gl_context.hpp"
#include "vellum/render/render_settings.hpp"
#include "vellum/render/render_target.hpp"

namespace vellum::render {

namespace detail {
struct LightSource;
}

/// Renders one volume through GL. Construct with a current context, which must outlive the
/// renderer; the volume is uploaded once by setVolume() (never per frame).
///
/// Rendering model (identical in renderReferenceCpu): rays from an orbit camera in physical
/// mm, clipped to the volume's oriented voxel box, sampled every stepVoxels * min spacing
/// (plus a fixed per-pixel jitter unless disabled), trilinear sampling with the background
/// outside, a 4096-entry transfer-function table with alpha corrected for the step,
/// front-to-back compositing with early termination at alpha 0.99, headlight Blinn-Phong
/// shading from the gradient computed where it is sampled (central differences of the
/// trilinear volume, one voxel either side: no stored normal volume). MIP maps the maximum through window/level.
/// The output has straight (not premultiplied) alpha; corners that miss the volume take the
/// background colour and alpha. Empty space (blocks of 8^3 voxels that the transfer function
/// makes fully transparent, or that cannot raise a MIP maximum) is skipped on the GPU only;
/// this does not change the picture. Volumes are limited to GL_MAX_3D_TEXTURE_SIZE per axis
/// (2048 on llvmpipe).
class VolumeRenderer {
 public:
  explicit VolumeRenderer(GlContext& context);
  ~VolumeRenderer();
  VolumeRenderer(const VolumeRenderer&) = delete;
  VolumeRenderer& operator=(const VolumeRenderer&) = delete;

  /// Uploads the volume (any voxel type).
  void setVolume(const AnyVolume& volume);
  /// The CPU part of setVolume() (the value range for the gradients' scale, the empty-space
  /// block ranges, the light source):
  /// no GL, so an interactive viewer makes it on a worker thread and uploads it with the
  /// overload below on the context's thread.
  struct Prepared;
  /// withLight = false leaves the light source out (a viewer that draws unlit holds no 21 MiB
  /// of block means at 512^2 x 350 for nothing): until setLightSource() the renderer then
  /// draws without the lighting terms and the path tracer without volume shadows.
  static std::shared_ptr<const Prepared> prepare(const AnyVolume& volume, bool withLight = true);
  /// setVolume() with its CPU part already made (by prepare() from this same volume).
  void setVolume(const AnyVolume& volume, const Prepared& prepared);
  /// The same spread over calls, for a viewer that must keep drawing: the first call
  /// allocates the volume texture, each later one uploads whole z slices,
  /// about `maxBytes` (at least one slice), and returns true once the volume is complete. Until then nothing is drawn (the previous
  /// volume is gone). Calling with another volume or setVolume() starts over.
  bool uploadVolumeStep(std::shared_ptr<const AnyVolume> volume, std::shared_ptr<const Prepared> prepared,
                        size_t maxBytes);
  /// uploadVolumeStep() made elsewhere, for a viewer whose frames must not wait for the
  /// allocation and copy of the textures (llvmpipe clears and fills 175 MB at
  /// 512x512x350 — seconds under load): makeVolumeTextures() runs on another thread, on a GL
  /// context that shares objects with this renderer's and is current there (no renderer state
  /// is touched; it returns once the textures are complete); adoptVolumeTextures() then makes
  /// them the drawn volume, on the renderer's thread, in about no time. Textures not adopted are
  /// deleted by discardVolumeTextures().
  struct VolumeTextures;
  /// Filled about `slabBytes` a call (Mesa holds a lock shared by the contexts through each),
  /// `betweenSlabs` (may be empty) called between two calls.
  static std::shared_ptr<VolumeTextures> makeVolumeTextures(const AnyVolume& volume, const Prepared& prepared,
                                                            size_t slabBytes = size_t(-1),
                                                            const std::function<void()>& betweenSlabs = {});
  /// The same from an int16 volume the caller holds anyway (a viewer's CT: no AnyVolume copy).
  static std::shared_ptr<VolumeTextures> makeVolumeTextures(const VolumeI16& volume, const Prepared& prepared,
                                                            size_t slabBytes = size_t(-1),
                                                            const std::function<void()>& betweenSlabs = {});
  void adoptVolumeTextures(const std::shared_ptr<VolumeTextures>& textures, const Prepared& prepared);
  /// What the lighting terms (RenderSettings::lighting) and the path tracer's volume shadows
  /// are computed from, made on demand for a volume prepared without it (prepare(volume,
  /// false)): no GL, so a viewer makes it on a worker when lighting is first switched on.
  using LightSource = detail::LightSource;
  static std::shared_ptr<const LightSource> makeLightSource(const AnyVolume& volume);
  /// The same from an int16 volume the caller holds (a viewer's CT: no AnyVolume copy).
  static std::shared_ptr<const LightSource> makeLightSource(const VolumeI16& volume);
  /// Hands the current volume its light source (made from that same volume; nullptr drops it);
  /// the pictures are then those of a renderer prepared with it. A new volume drops it.
  /// Throws vellum::Error for a light source of another grid.
  void setLightSource(std::shared_ptr<const LightSource> light);
  bool hasLightSource() const;
  /// True when drawing with `settings` reads the light source (lighting on with shading, or
  /// the path tracer's volume shadows; not MIP).
  static bool usesLightSource(const RenderSettings& settings);
  void discardVolumeTextures(const std::shared_ptr<VolumeTextures>& textures);
  /// Deforms what is drawn: samples the source at u(v) from `map` (uploaded once as a 3D
  /// texture; call again when it changes). nullptr removes the deformation.
  void setBackwardMap(const BackwardMap* map);
  /// The same, sharing `map` instead of copying it; the map drawn before is released before
  /// this one is prepared (a movie's frames: one map's textures and cells in memory, not two).
  void setBackwardMap(std::shared_ptr<const BackwardMap> map);
  /// The CPU part of setBackwardMap() (validation, the source-index texels, the map cells'
  /// empty-space ranges, the snap's frames): no GL, so an interactive viewer makes it on a
  /// worker thread, for the volume `volume` was prepared from, and uploads it with
  /// uploadBackwardMapStep() on the context's thread. Throws vellum::Error for malformed maps.
  struct PreparedBackwardMap;
  static std::shared_ptr<const PreparedBackwardMap> prepareBackwardMap(std::shared_ptr<const BackwardMap> map,
                                                                       const Prepared& volume);
  /// setBackwardMap() spread over calls: each call uploads whole z slabs of the map's textures
  /// (and of the rigid snap's class volume when the map brings a new one), about `maxBytes`
  /// (at least one slab), and returns true once the map is the one drawn. Until then the
  /// previous map (or none) is still drawn, unchanged. Calling with another prepared map,
  /// setBackwardMap() or a new volume starts over. A map prepared for another volume than the
  /// current one is prepared again here, at once.
  bool uploadBackwardMapStep(std::shared_ptr<const PreparedBackwardMap> map, size_t maxBytes);
  /// Label colours for RenderSettings::labelBlend > 0 (ids on the volume's grid; uploaded
  /// once; call again when they change). nullptr removes them. Call after setVolume.
  void setLabelTint(const LabelTint* tint);
  /// Renders to an RGBA image (row 0 = top). Throws vellum::Error for sizes over 4096.
  /// settings.quality == Cinematic (DVR presets): progressive path tracing, tone mapped and
  /// denoised (docs/lighting.md; CPU reference: path_tracer.hpp); lastSamples() says how many
  /// samples the time limit allowed. The row and target variants below always ray cast.
  RgbaImage render(const RenderSettings& settings);
  /// Renders only rows [rowBegin, rowEnd) (row 0 = top) of the image `settings` describes
  /// into `image`, which must already be settings.width x settings.height; other rows are
  /// left as they are. The pixels are exactly those of render() (same rays, same jitter: the
  /// rest of the image is scissored away), so an interactive viewer can spread one
  /// full-resolution frame over several display frames.
  void renderRows(const RenderSettings& settings, int rowBegin, int rowEnd, RgbaImage& image);
  /// Draws into a caller's framebuffer: no glFinish, no read-back (the caller displays or
  /// reads the target). The target must be settings.width x settings.height. Without
  /// target.opaqueDepth the pixels written are exactly render()'s. With it (the convention of
  /// render_target.hpp), each ray keeps only the samples in front of the opaque surface
  /// (t < its ray distance) and the volume composited from them is blended, premultiplied, over
  /// the colour already in the target (GL_ONE, GL_ONE_MINUS_SRC_ALPHA): the surface colour
  /// where there is geometry; elsewhere the result is render()'s composite over
  /// settings.background, premultiplied (the same bytes for an opaque background).
  void renderInto(const RenderSettings& settings, const RenderTarget& target);
  /// renderInto() for rows [rowBegin, rowEnd) only (row 0 = top; the rest is scissored away):
  /// the studio's banded refinement.
  void renderIntoRows(const RenderSettings& settings, const RenderTarget& target, int rowBegin, int rowEnd);
  /// renderInto() for the tile of columns [colBegin, colEnd) and rows [rowBegin, rowEnd) only
  /// (row 0 = top; the rest is scissored away; the same pixels as a whole renderInto()): the
  /// studio's tiled refinement, where one deformed full-width row can cost over a frame.
  void renderIntoTile(const RenderSettings& settings, const RenderTarget& target, int colBegin, int colEnd,
                      int rowBegin, int rowEnd);
  /// Milliseconds the last render() spent on the GPU side (glFinish-bounded).
  double lastRenderMs() const;
  /// GPU milliseconds of a recent renderInto() (GL_TIME_ELAPSED, read without stalling). On
  /// llvmpipe this misses rasterisation deferred past the query (docs/benchmarks-render.md):
  /// time with glFinish there.
  double lastGpuMs() const;
  /// Samples per pixel of the last cinematic render() (0 before any).
  int lastSamples() const;
  /// Progressive cinematic rendering, for a viewer that refines while the camera rests:
  /// beginCinematic() starts a picture of `settings` (a DVR preset; the denoise guide is ray
  /// cast now and the float sums cleared), each addCinematicSamples(n) adds n paths per pixel
  /// and returns the total so far, resolveCinematic() is the picture of the sums so far (tone
  /// mapped, denoised). N samples added in any batches resolve to exactly render()'s picture
  /// with samples = N and the same seed. Independent of render(), which keeps its own sums.
  /// Begin again after changing the view, volume, map or tint.
  void beginCinematic(const RenderSettings& settings);
  /// guideInBands: the same without the denoise guide's ray cast, which the caller then draws
  /// in bands of rows with addCinematicGuideRows (a viewer keeps each frame short; the same
  /// pixels as one ray cast) before the first resolveCinematic().
  void beginCinematic(const RenderSettings& settings, bool guideInBands);
  /// Ray casts rows [rowBegin, rowEnd) (row 0 = top) of the denoise guide; returns how many
  /// of its rows are still to draw (0: complete, or no guide: cinematic.denoise = 0).
  int addCinematicGuideRows(int rowBegin, int rowEnd);
  int addCinematicSamples(int n);
  /// At most n samples, no pass predicted to end past `timeLimitS` seconds (0 = none; at least one):
  /// a caller that bounds a whole command (`vellum render --time-limit`) gives what is left.
  int addCinematicSamples(int n, double timeLimitS);
  /// The next sample over image rows [rowBegin, rowEnd) only (row 0 = top), for a viewer that
  /// cannot afford a whole pass in one frame: call with consecutive bands from row 0; the
  /// sample counts (and is returned in the total) once a band ends at the last row. Resolve
  /// between whole samples only. The sums are bit-identical to whole passes.
  int addCinematicRows(int rowBegin, int rowEnd);
  RgbaImage resolveCinematic();
  /// Samples per pixel summed since beginCinematic() (0 before).
  int cinematicSamples() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  void finishVolume(const Geometry& g, const Prepared& prepared);
  template <class T>
  static std::shared_ptr<VolumeTextures> makeTexturesOf(const Volume<T>& volume, const Prepared& prepared,
                                                        size_t slabBytes, const std::function<void()>& betweenSlabs);
};

/// Opaque geometry for the CPU reference, per pixel (row 0 = top, settings' size): the
/// surface colour (alpha ignored: opaque) and the ray distance in mm (+inf: none). What a
/// FramebufferTarget holds after the mesh pass (readColour, readRayDistanceMm).
struct OpaqueLayer {
  RgbaImage colour;
  std::vector<float> distanceMm;
};

/// CPU reference ray caster: the same rays, steps, transfer function and compositing as
/// the shaders, for tests. Slow; intended for small images. With `opaque`, as renderInto()
/// with an opaque depth: samples at t < the surface distance, then the volume over the surface
/// colour where there is one.
RgbaImage renderReferenceCpu(const AnyVolume& volume, const RenderSettings& settings,
                             const BackwardMap* map = nullptr, const LabelTint* tint = nullptr,
                             const OpaqueLayer* opaque = nullptr);

}  // namespace vellum::render
