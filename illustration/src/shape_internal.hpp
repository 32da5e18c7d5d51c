#pragma once
// Internal interfaces between the shape pipeline's translation units. Each heavy library
// (OpenVDB, OpenMesh, CGAL) lives in its own .cpp behind these plain types.
#include <cstdint>
#include <memory>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::illustration::detail {

/// A binary mask cropped to the segment's bounding box plus padding; voxel (i,j,k) of the
/// box is voxel (i+ox, j+oy, k+oz) of the full grid. Outside the box everything is outside.
struct MaskBox {
  int64_t ox = 0, oy = 0, oz = 0;
  int64_t nx = 0, ny = 0, nz = 0;
  std::vector<uint8_t> inside;
  int64_t count = 0;  ///< voxels inside
  bool at(int64_t gi, int64_t gj, int64_t gk) const {  // full-grid index
    const int64_t i = gi - ox, j = gj - oy, k = gk - oz;
    if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return false;
    return inside[static_cast<size_t>((k * ny + j) * nx + i)] != 0;
  }
};

/// Mask of the voxels whose label is one of `ids`, cropped with `pad` voxels of padding.
MaskBox extractMask(const VolumeU16& labels, const std::vector<uint16_t>& ids, int pad);
MaskBox maskFromVolume(const VolumeU8& mask, int pad);

/// An OpenVDB level set in full-grid index space (opaque outside denoise.cpp).
struct LevelSet;
struct LevelSetDeleter { void operator()(LevelSet*) const; };
using LevelSetPtr = std::unique_ptr<LevelSet, LevelSetDeleter>;

LevelSetPtr denoiseLevelSet(const MaskBox& mask, int iterations, double margin);
/// Dense phi (voxel units) over the full grid geometry.
VolumeF32 levelSetToDense(const LevelSet& ls, const Geometry& g);
/// Triangles of the zero level set, vertices in index coordinates of the full grid.
TriMesh extractIndexMesh(const LevelSet& ls, double adaptivity = 0.0);

/// OpenMesh: quadric decimation to `targetFaces` (0: none), then tangential smoothing. The
/// budget is honoured: when the guarded pass (error <= maxErrorMm, normals within
/// `maxNormalDeviationDeg`; 0 = no normal guard) stops above it, looser passes follow.
TriMesh smoothAndDecimate(const TriMesh& mesh, int smoothingIterations, int64_t targetFaces,
                          double maxErrorMm, double maxNormalDeviationDeg = 25.0);

/// CGAL PMP: repair into a closed, manifold, outward, self-intersection-free mesh.
TriMesh repairMesh(const TriMesh& mesh, MeshChecks& stats);

/// Max distance (mm) from the mesh vertices to the voxel faces of the original binary
/// boundary (searched within `radius` voxels; farther vertices report the search radius).
double maxDistanceToBinaryBoundary(const TriMesh& mesh, const MaskBox& mask, const Geometry& g,
                                   int radius = 3);

/// One mesh's signed distance on the grid (signedDistances for one mesh; distance.cpp).
VolumeF32 signedDistance(const TriMesh& mesh, const Geometry& g, const DistanceOptions& options,
                         double extraBandMm);
/// The same into `out`, whose storage is reused when it already has the grid's dims (one
/// buffer for all segments: each fresh volume-sized allocation costs its page faults).
void signedDistanceInto(const TriMesh& mesh, const Geometry& g, const DistanceOptions& options,
                        double extraBandMm, VolumeF32& out);

/// Field i (id i + 1) of `count` segments: quantised distance and the segment's first shell
/// (makeSegmentFields for one segment).
SegmentField segmentField(size_t i, const VolumeF32& distance, const std::vector<Segment>& segments,
                          const std::vector<Shell>& shells, size_t count);

/// buildRepresentation one segment at a time (in paint order), so that only one segment's
/// float distance needs to be alive: the union distance (min), the labels (later segments
/// paint over earlier ones, shells where -t < d <= 0), then the union's far field.
class RepresentationBuilder {
 public:
  RepresentationBuilder(const Geometry& g, const std::vector<Segment>& segments, const std::vector<Shell>& shells);
  void add(size_t i, const VolumeF32& distance);
  /// `scratch` (optional): a spare buffer of any size for the far field's squared distances,
  /// e.g. the storage of the last segment's distance.
  void finish(VolumeF32& unionDistance, LabelVolume& segmentation, std::vector<float>* scratch = nullptr);

 private:
  std::vector<Segment> segments_;
  std::vector<double> shellT_;
  std::vector<uint16_t> shellId_;
  std::vector<Label> table_;
  VolumeF32 union_;
  VolumeU16 ids_;
  double far_;
  bool first_ = true;
};

/// Maps index-space vertices to physical mm, flipping the winding if the map is mirrored.
void indexToPhysical(TriMesh& mesh, const Geometry& g);

}  // namespace vellum::illustration::detail
