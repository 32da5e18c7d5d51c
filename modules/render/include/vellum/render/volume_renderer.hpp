#pragma once
// GLSL ray caster into an offscreen framebuffer, and its CPU reference.
#include <memory>

#include "vellum/core/image.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/gl_context.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::render {

/// Renders one volume through GL. Construct with a current context; the volume and its
/// precomputed normal volume are uploaded once by setVolume() (never per frame).
class VolumeRenderer {
 public:
  explicit VolumeRenderer(GlContext& context);
  ~VolumeRenderer();
  VolumeRenderer(const VolumeRenderer&) = delete;
  VolumeRenderer& operator=(const VolumeRenderer&) = delete;

  /// Uploads the volume (any voxel type) and its gradient-normal volume.
  void setVolume(const AnyVolume& volume);
  /// Deforms what is drawn: samples the source at u(v) from `map` (uploaded once as a 3D
  /// texture; call again when it changes). nullptr removes the deformation.
  void setBackwardMap(const BackwardMap* map);
  /// Renders to an RGBA image (row 0 = top). Throws vellum::Error for sizes over 4096.
  RgbaImage render(const RenderSettings& settings);
  /// Milliseconds the last render() spent on the GPU side (glFinish-bounded).
  double lastRenderMs() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// CPU reference ray caster: the same rays, steps, transfer function and compositing as
/// the shaders, for tests. Slow; intended for small images.
RgbaImage renderReferenceCpu(const AnyVolume& volume, const RenderSettings& settings,
                             const BackwardMap* map = nullptr);

}  // namespace vellum::render
