#pragma once
// Opaque triangle meshes drawn with the ray caster's camera into a FramebufferTarget's colour
// and opaque depth (render_target.hpp), so that VolumeRenderer::renderInto terminates its rays
// at them. Plain arrays in: the render module knows nothing of the shape pipeline.
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "vellum/render/gl_context.hpp"
#include "vellum/render/projection.hpp"
#include "vellum/render/render_target.hpp"

namespace vellum::render {

struct SurfaceMesh {
  std::vector<float> positionsMm;   ///< x y z per vertex, physical (LPS) mm
  std::vector<uint32_t> triangles;  ///< 3 vertex indices per triangle
  std::array<float, 3> rgb{0.8f, 0.8f, 0.8f};  ///< base colour in [0, 1]
};

/// Shading (the ray caster's headlight, two-sided): light and eye along the pixel's ray,
/// colour = min(rgb (kAmbient + kDiffuse |n.l|) + kSpecular |n.l|^kShininess, 1) with the
/// volume's constants, n the interpolated area-weighted vertex normal. Depth test on, writes
/// colour (alpha 1) and the opaque depth; near/far clipping is off (GL_DEPTH_CLAMP), so
/// nothing between the eye and the volume is cut away.
class MeshRenderer {
 public:
  explicit MeshRenderer(GlContext& context);
  ~MeshRenderer();
  MeshRenderer(const MeshRenderer&) = delete;
  MeshRenderer& operator=(const MeshRenderer&) = delete;

  /// Uploads the meshes (once; call again when they change). Throws vellum::Error naming the
  /// mesh for an index out of range or a position count that is not a multiple of 3.
  void setMeshes(const std::vector<SurfaceMesh>& meshes);
  size_t meshCount() const;
  /// Draws mesh i when visible[i] (all when `visible` is empty) with `camera` into the
  /// target's opaque framebuffer; does not clear it. The camera must have the target's size.
  /// `depthBiasMm` > 0 writes the depth that much nearer than the surface (the colour stays
  /// where it is), so that rays stop short of it: a mesh made from a segment of the volume
  /// coincides with that segment's own blurred boundary, whose samples would otherwise
  /// speckle over the mesh.
  void draw(const Projection& camera, FramebufferTarget& target, const std::vector<bool>& visible = {},
            double depthBiasMm = 0);
  /// GPU milliseconds of a recent draw (GL timer query, read without stalling; 0 before any).
  /// Not a measure on llvmpipe, which rasterises after the query ends (see lastGpuMs()).
  double lastDrawMs() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Area-weighted vertex normals (3 floats per vertex; zero for unused vertices).
std::vector<float> vertexNormals(const SurfaceMesh& mesh);

}  // namespace vellum::render
