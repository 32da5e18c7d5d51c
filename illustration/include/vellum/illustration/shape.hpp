#pragma once
// Clean shapes and the shape-aware representation ([SAVI 2.2, 2.4] in docs/references.md).
//
//   segments (label ids)  -> per-segment binary mask
//   -> denoise: Whitaker-style constrained curvature flow on an OpenVDB narrow band
//   -> mesh: OpenVDB volumeToMesh (isovalue 0), vertices in mm
//   -> process: OpenMesh tangential smoothing + quadric decimation (normal-deviation and
//      aspect-ratio constraints), CGAL PMP repair (stitch, degenerate faces, holes,
//      self-intersections, outward orientation) and checks
//   -> distances: per-segment signed distances (mm, negative inside) on the CT grid
//   -> segmentation volume (first segment in order whose distance is < 0; shells; grow)
//
// OpenVDB, OpenMesh and CGAL stay inside src/*.cpp; this header only uses Vellum types.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::illustration {

/// One segment of the shape pipeline: the union of some label ids.
struct Segment {
  std::string name;
  std::vector<uint16_t> ids;
  std::array<uint8_t, 3> rgb{255, 255, 255};
};

/// Parses "NAME=ID[,ID..]" or "ID[,ID..]" (name from the label table; needs exactly one id).
/// Ids must exist in the label table or in the voxels; throws vellum::Error with a one-line
/// message naming the spec otherwise. The colour is the first id's table colour.
Segment parseSegmentSpec(const std::string& spec, const LabelVolume& labels);

/// A triangle mesh; vertices in physical millimetres (LPS), faces counter-clockwise seen
/// from outside (outward normals).
struct TriMesh {
  std::vector<std::array<float, 3>> vertices;
  std::vector<std::array<uint32_t, 3>> faces;
};

/// Checks made by code on every output mesh (CGAL).
struct MeshChecks {
  bool closed = false;             ///< no border edges
  bool manifold = false;           ///< no non-manifold vertices or edges
  bool outward = false;            ///< enclosed volume is positive
  int64_t selfIntersections = 0;   ///< pairs of intersecting faces
  double volumeMm3 = 0;            ///< signed enclosed volume
  double voxelVolumeMm3 = 0;       ///< voxel count of the segment x voxel volume
  double maxBoundaryDistanceMm = 0;  ///< max over vertices of the distance to the voxel faces
                                     ///< of the original binary boundary
  int64_t holesFilled = 0, degenerateRemoved = 0;  ///< repair statistics
  bool selfIntersectionsRepaired = false;
};

/// Whitaker (2000) constrained denoising of a binary mask (non-zero = inside).
struct DenoiseOptions {
  int iterations = 5;  ///< mean-curvature steps (each followed by the band constraint); see README
  /// Margin (voxels) of the constraint at voxel centres: phi <= -m inside, >= +m outside.
  /// The zero level set then stays within 0.5 - m of the original voxel faces, and a
  /// one-voxel-thin sheet keeps a thickness of at least 2m.
  double marginVoxels = 0.15;
};
/// Dense result of denoiseMask: phi in voxel units (negative inside), clamped to +-2 voxels
/// away from the surface. The constraint holds at every voxel centre: phi <= -m where the
/// mask is set and phi >= +m where it is not, so the zero level set never leaves the band of
/// half a voxel around the binary boundary (the voxel faces between inside and outside).
VolumeF32 denoiseMask(const VolumeU8& mask, const DenoiseOptions& options = {});

struct ShapeOptions {
  DenoiseOptions denoise;
  /// Per-segment face budget for the decimation; 0 = no decimation.
  int64_t targetFaces = 20000;
  int smoothingIterations = 3;  ///< OpenMesh tangential smoothing passes
  /// OpenVDB volumeToMesh adaptivity (0: uniform marching, one quad per boundary voxel face;
  /// small values merge flat regions and cut the decimation's work by 10x or more).
  double adaptivity = 0.05;
  /// Half-width (mm) of the band around each surface where distances are exact (0:
  /// defaultExactBandMm); widened per segment for its shells and grow offsets.
  double exactBandMm = 0.0;
};

/// Parameter table of ShapeOptions (keys = `vellum shape` flags; see `vellum params`).
const params::Table<ShapeOptions>& shapeOptionsTable();

/// Offset shell: "NAME boundary" = voxels of segment `segment` with -thickness < d <= 0.
struct Shell {
  std::string segment;
  double thicknessMm = 1.0;
};
/// Grow (positive) or shrink (negative) a segment by `offsetMm`.
struct Grow {
  std::string segment;
  double offsetMm = 0;
};

struct SegmentShape {
  Segment segment;
  TriMesh mesh;
  MeshChecks checks;
};

/// One segment's own signed distance, for the renderer (docs/shape.md, "Per-segment
/// distances"): nested and touching segments each keep the distance to their own boundary,
/// which the union distance loses. Quantised to int16 hundredths of a millimetre
/// (kFieldQuantumMm), clamped to the exact band (+-band beyond it, with the right sign).
struct SegmentField {
  uint16_t id = 0;         ///< the segment's id in the segmentation (paint order = id order)
  std::string name;
  VolumeI16 distance;      ///< d / kFieldQuantumMm, negative inside
  uint16_t shellId = 0;    ///< the id of its `--shell` layer (0: none): -shellMm < d <= 0
  float shellMm = 0;
};
constexpr double kFieldQuantumMm = 0.01;
/// d (mm) -> field value, rounded and clamped to +-32767; where a structure thinner than a
/// voxel passes between two voxel centres, both take at most minus half its chord, so that
/// trilinear interpolation keeps it (segment_fields.cpp, keepThin).
VolumeI16 quantiseField(const VolumeF32& distanceMm);
/// Default exact band: three voxels of the smallest spacing, and at least two voxels of the
/// largest (the renderer's gradient stencil reaches one voxel each way on every axis).
double defaultExactBandMm(const Geometry& g);

/// Writes DIR/distance-<id>.nrrd (raw int16) for every field and DIR/distances.json (ids,
/// names, files, shells, quantum).
void saveSegmentFields(const std::vector<SegmentField>& fields, const std::filesystem::path& dir);
/// Reads what saveSegmentFields wrote; FileError naming the file (an older shape folder
/// without distances.json gets a one-line "make it again" message).
std::vector<SegmentField> loadSegmentFields(const std::filesystem::path& dir);

struct StageTimes {
  double denoiseMs = 0, meshMs = 0, processMs = 0, distancesMs = 0, segmentationMs = 0;
};

struct ShapeResult {
  std::vector<SegmentShape> shapes;
  VolumeF32 distance;        ///< signed distance (mm) of the union, on the input grid
  /// Ids from 1 in segment order, then shells (n+1.. in --shell order); 0 unclassified.
  /// Where segments overlap the later one wins (painter's order: list the enclosing
  /// structures first, e.g. skin, then muscle, then bone).
  LabelVolume segmentation;
  /// Per-segment distances (after grow offsets) with their shells, in segment order.
  std::vector<SegmentField> fields;
  StageTimes times;
};

/// Builds clean meshes for the segments (denoise, mesh, process), in parallel over segments.
std::vector<SegmentShape> buildShapes(const LabelVolume& labels,
                                      const std::vector<Segment>& segments,
                                      const ShapeOptions& options, StageTimes& times,
                                      Progress& progress = Progress::none());

/// Per-segment signed distances of closed meshes sampled on `grid` (mm, negative inside;
/// nested components handled: a point is inside when an odd number of the mesh's closed
/// components enclose it). Exact (to the mesh) within `bandMm` of each surface, widened by
/// extraBandMm[i] + 2 voxels for mesh i; beyond, clamped to +-band (volume background =
/// the band) with the correct sign. buildRepresentation extends the union's far field.
struct DistanceOptions {
  double bandMm = 0.0;  ///< 0: defaultExactBandMm
};
std::vector<VolumeF32> signedDistances(const std::vector<TriMesh>& meshes, const Geometry& grid,
                                       const DistanceOptions& options = {},
                                       const std::vector<double>& extraBandMm = {});

/// Combines per-segment distances (after grow offsets) into the union distance (min over
/// segments) and the segmentation volume: voxel = i where segment i's distance < 0 (the last
/// such segment in order), or its shell id where -t < d_i <= 0.
void buildRepresentation(std::vector<VolumeF32>& distances, const std::vector<Segment>& segments,
                         const std::vector<Shell>& shells, VolumeF32& unionDistance,
                         LabelVolume& segmentation);

/// Fields of per-segment distances (after grow offsets) for buildRepresentation's ids and
/// shells (the first shell of a segment is the one painted).
std::vector<SegmentField> makeSegmentFields(const std::vector<VolumeF32>& distances,
                                            const std::vector<Segment>& segments,
                                            const std::vector<Shell>& shells);

/// The whole pipeline.
ShapeResult runShapePipeline(const LabelVolume& labels, const std::vector<Segment>& segments,
                             const std::vector<Shell>& shells, const std::vector<Grow>& grows,
                             const ShapeOptions& options, Progress& progress = Progress::none());

/// Mesh checks by CGAL (no repair): closed, manifold, self-intersections, volume, outward.
/// (voxelVolumeMm3 and maxBoundaryDistanceMm are filled by buildShapes.)
MeshChecks checkMesh(const TriMesh& mesh);

/// Mesh export: "ply" (binary little-endian), "obj", "stl" (binary). Atomic.
void saveMesh(const TriMesh& mesh, const std::filesystem::path& path, const std::string& format);
/// Reads a binary little-endian PLY as saveMesh writes it (float x y z; triangles).
/// Throws vellum::FileError naming the file for anything else or a truncated file.
TriMesh loadMesh(const std::filesystem::path& path);

}  // namespace vellum::illustration
