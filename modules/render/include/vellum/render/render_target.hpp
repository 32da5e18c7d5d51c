#pragma once
// Drawing into a caller's framebuffer, and the opaque-depth convention that lets opaque
// geometry (render::MeshRenderer, or anything drawn the same way) terminate the ray caster's
// rays: one shared viewport instead of side-by-side images.
//
// Opaque depth convention (the one place it is defined): a GL_DEPTH_COMPONENT32F texture the
// size of the target whose value d at a pixel is the distance in mm along that pixel's ray,
// divided by kOpaqueDepthRangeMm. The ray is the renderer's (detail::pixelRay): from the eye
// for perspective views, from the eye plane for orthographic ones, in the view direction; so
// the distance is |p - eye| (perspective) or (p - eye) . forward (orthographic) for a surface
// point p. d = 1 (the clear value) means no geometry at that pixel. The value is linear in
// distance (written as gl_FragDepth), so a 32-bit float keeps ~1e-5 mm.
#include <array>
#include <memory>
#include <vector>

#include "vellum/core/image.hpp"
#include "vellum/render/gl_context.hpp"

namespace vellum::render {

/// Ray distance (mm) that an opaque depth of 1.0 stands for: far beyond any volume.
inline constexpr double kOpaqueDepthRangeMm = 1.0e5;

/// A caller's framebuffer for VolumeRenderer::renderInto. GL object names are plain unsigned
/// so that this header stays GL-free.
struct RenderTarget {
  unsigned framebuffer = 0;  ///< GL framebuffer name (0: the default framebuffer)
  int width = 0, height = 0; ///< its viewport; must equal the render settings' size
  /// Opaque geometry's depth (convention above), or 0 for none. It must not be attached to
  /// `framebuffer` (sampling an attached texture is a GL feedback loop); FramebufferTarget
  /// keeps the two apart.
  unsigned opaqueDepth = 0;
};

/// An RGBA8 colour texture plus a 32-bit float depth texture, with two framebuffers over
/// them: one with both attachments (the opaque pass: meshes write colour and depth) and one
/// with the colour only (the volume pass, which reads the depth as a texture). What the
/// studio's 3D view displays, and what tests read back. Every call makes `context` current
/// (it must outlive the target), the destructor too.
class FramebufferTarget {
 public:
  explicit FramebufferTarget(GlContext& context);
  ~FramebufferTarget();
  FramebufferTarget(const FramebufferTarget&) = delete;
  FramebufferTarget& operator=(const FramebufferTarget&) = delete;

  /// (Re)allocates when the size changes; contents are undefined afterwards.
  void resize(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }
  /// Colour = rgba (straight = premultiplied for alpha 1; use alpha 0 under meshes so that a
  /// transparent background stays transparent), depth = 1 (no geometry).
  void clear(const std::array<float, 4>& rgba);
  /// The framebuffer with colour and depth attached (for the opaque pass).
  unsigned opaqueFramebuffer() const { return opaqueFbo_; }
  /// The volume pass: the colour-only framebuffer and, when `withDepth`, the depth texture.
  RenderTarget volumeTarget(bool withDepth) const;
  unsigned colourTexture() const { return colour_; }
  unsigned depthTexture() const { return depth_; }
  /// Copies rows [rowBegin, rowEnd) (row 0 = top) of `from`'s colour into this target's
  /// colour (same size); the depth is not copied.
  void copyColourRows(const FramebufferTarget& from, int rowBegin, int rowEnd);
  /// Copies `from`'s colour scaled (linear filter) to this target's whole colour.
  void copyColourScaled(const FramebufferTarget& from);
  /// Reads the colour back (row 0 = top): tests and screenshots.
  RgbaImage readColour() const;
  /// Reads the opaque depth back as ray distances in mm (row 0 = top); +inf where no geometry.
  std::vector<float> readRayDistanceMm() const;

 private:
  GlContext& context_;
  unsigned opaqueFbo_ = 0, volumeFbo_ = 0, colour_ = 0, depth_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace vellum::render
