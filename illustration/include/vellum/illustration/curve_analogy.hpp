#pragma once
// Curve-analogy shape deformation ([SAVI 2.3] in docs/references.md; issue 9): bend a segment's mesh so that
// its outline seen from a camera takes the shape of an illustrator's curve, and carry other
// meshes and the CT along through mean value coordinates.
//
//   M0 -> proxy M1 (decimated, repaired, closed)
//   C1 = outline of M1's image from the (orthographic) camera, in image pixels
//   C0 (drawing pixels) -> similarity-aligned to C1, both resampled to the same count
//   Laplacian curve deformation of C1 toward C0's shape, anchors kept in place
//   lift to 3D at the handles' depths (moves in the image plane only) -> ARAP of M1 with the
//   silhouette vertices on C1 as handles -> MVC transfer of M0 (and other meshes) w.r.t. M1.
#include <filesystem>
#include <vector>

#include "vellum/core/geometry.hpp"
#include "vellum/illustration/curve.hpp"
#include "vellum/illustration/mean_value_coordinates.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/render/projection.hpp"

namespace vellum::illustration {

/// The silhouette of a mesh seen through `projection`: the longest closed loop of edges
/// between a front- and a back-facing triangle, as mesh vertex ids and their pixels
/// (x right, y down, as Projection::toPixel) and depths (mm along the view).
struct Silhouette {
  std::vector<uint32_t> vertices;
  Polyline2 pixels;
  std::vector<double> depths;
};
/// Throws vellum::Error when the mesh has no silhouette loop (empty or open mesh).
/// Orthographic projections only (the front/back test uses one view direction).
Silhouette silhouetteLoop(const TriMesh& mesh, const render::Projection& projection);

/// Every vertex on an edge between a front- and a back-facing triangle (orthographic).
std::vector<uint32_t> silhouetteVertices(const TriMesh& mesh, const render::Projection& projection);

/// The outline of the mesh's image: the outer contour of its projected triangles (OpenCV,
/// rasterised at `supersample` x the view's resolution), in the view's pixels. This, not the
/// silhouette loop, is C1: on a faceted mesh the front/back boundary also wanders across
/// faces seen edge-on (the flat ends of a limb in a side view), while the outline does not.
Polyline2 projectedOutline(const TriMesh& mesh, const render::Projection& projection,
                           int supersample = 4);

/// Reads {"points": [[x, y], ...]} (image pixels, >= 3 points; closed outline).
/// Throws vellum::FileError naming the file and the problem.
Polyline2 loadCurveJson(const std::filesystem::path& path);

/// A closed, manifold proxy of `mesh` with about `targetFaces` faces (OpenMesh quadric
/// decimation, CGAL repair).
TriMesh simplifyProxy(const TriMesh& mesh, int64_t targetFaces);

struct CurveAnalogyOptions {
  int samples = 200;          ///< points of the resampled C0/C1
  double lambda = 10.0;       ///< anchor weight of the Laplacian curve deformation
  int anchors = 4;            ///< C1 points kept in place: where the aligned C0 agrees best
  int64_t proxyFaces = 2000;  ///< face budget of the proxy M1
  int arapIterations = 10;
  int fixedVertices = 2;      ///< M1 vertices farthest from the handles kept in place by ARAP
  /// Largest rotation (degrees) of the C0 -> C1 similarity; beyond it only if nothing fits.
  double maxRotationDeg = 30.0;
  double handleTolerancePx = 1.5;  ///< silhouette vertices this close to C1 become handles
};

struct CurveAnalogyResult {
  TriMesh proxy;                  ///< M1
  std::vector<Vec3> proxyDeformed;  ///< M1's vertices after ARAP (same faces)
  Polyline2 c1, c0Aligned, c1Deformed;  ///< resampled curves in pixels
  std::vector<int> anchors;       ///< indices into c1
  Polyline2 silhouetteAfter;      ///< outline of the deformed M1 (pixels)
  int handles = 0;                ///< M1 vertices moved by the curve
  double hausdorffBeforePx = 0;   ///< H(M1's outline, aligned C0)
  double hausdorffAfterPx = 0;    ///< H(deformed M1's outline, aligned C0)
  double proxyMs = 0, curveMs = 0, arapMs = 0;
};

/// Steps 1-4 of the curve analogy (C1 = projectedOutline of M1; handles = M1 vertices on
/// front/back-facing edges within `handleTolerancePx` of it) for one mesh M0 and a closed drawing curve C0 (pixels of
/// `projection`'s image). The result's cage pair (proxy, proxyDeformed) moves other points
/// with transferByMeanValueCoordinates.
CurveAnalogyResult curveAnalogy(const TriMesh& m0, const Polyline2& c0,
                                const render::Projection& projection,
                                const CurveAnalogyOptions& options = {});

/// Moves a mesh's vertices with the cage (MVC w.r.t. `rest`, applied to `deformed`).
TriMesh transferMesh(const TriMesh& mesh, const Cage& rest, const std::vector<Vec3>& deformed);

/// Backward map of the CT: for every voxel centre y of `grid` (the output), the MVC of y
/// with respect to the DEFORMED cage applied to the REST cage, i.e. where y's content comes
/// from. Evaluated every `step` voxels and trilinearly interpolated in between. Returns 3
/// floats per voxel (x fastest), the layout of deformation::saveBackwardMapNrrd.
std::vector<float> cageBackwardMap(const Cage& rest, const std::vector<Vec3>& deformed,
                                   const Geometry& grid, int step = 4);

}  // namespace vellum::illustration

namespace vellum::illustration {

/// C0 from a drawing (PNG/JPG; OpenCV): the largest outer contour of its dark strokes
/// (grey < `darkThreshold` in 0..255, strokes closed by a 2-pixel morphological closing,
/// holes filled), in the drawing's pixels. `width`/`height` receive the image size.
/// Throws vellum::FileError naming the file when it cannot be read or has no dark region.
Polyline2 loadDrawingOutline(const std::filesystem::path& path, int& width, int& height,
                             int darkThreshold = 128);

/// A pen drawing of a closed curve: dark strokes `strokePx` wide on white (PNG, atomic).
void writeCurveDrawing(const std::filesystem::path& path, int width, int height,
                       const Polyline2& curve, int strokePx = 3);

/// Before/after plate (PNG, atomic): the original silhouette (grey), the aligned drawing
/// curve (red, dashed look by dots) and the deformed silhouette (blue) on white, at the
/// view's image size.
void writeCurvePlate(const std::filesystem::path& path, int width, int height,
                     const Polyline2& before, const Polyline2& drawing, const Polyline2& after);

}  // namespace vellum::illustration
