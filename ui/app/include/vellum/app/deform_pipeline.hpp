#pragma once
// Deformation as a request: what `vellum deform` does beyond parsing its flags (load the
// volume and the control points, build the control volume, keep the bones rigid, synthesise,
// write the volume, the backward map and the attribute field, report timings and rigidity
// measures as JSON), and the engine settings `vellum animate` shares with it. The command
// line fills a request from its flags; runDeform runs it.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::app {

/// The deformation engine and its rigid bones: shared by `vellum deform`, `vellum animate`
/// and the studio's export command line.
struct DeformEngine {
  deformation::DeformParams params;  ///< deformParamsTable(): --method, --power, --control-scale ...
  /// params.mls.power was given explicitly (even at its default): it wins over a point file's power.
  bool powerGiven = false;
  deformation::Upsampling upsampling = deformation::Upsampling::Trilinear;
  std::string labels;              ///< label map on the volume's grid; empty: no rigid bones
  std::vector<uint16_t> rigidIds;  ///< the label ids that stay rigid: one body per id, whatever its connectivity
  /// Bodies of several ids (`--rigid-labels 4+5,6+7`: one body each; ids of one-id entries go to
  /// rigidIds). An id may be in several groups (split by piece: RigidBodies::fromLabelGroups).
  std::vector<std::vector<uint16_t>> rigidGroups;
  /// All bodies: rigidGroups, then one per id of rigidIds.
  std::vector<std::vector<uint16_t>> bodyGroups() const;
  /// Fills rigidGroups / rigidIds from `--rigid-labels` tokens ("4+5", "6", ...). Error on a bad token.
  void setRigidLabels(const std::vector<std::string>& tokens);
  /// The `--rigid-labels` value: groups joined by '+', then the single ids, comma-separated.
  std::string rigidLabelsArgument() const;
  std::vector<uint16_t> fixedIds;  ///< label ids that do not move at all
  std::vector<double> fixedBoxMm;  ///< boxes that do not move: x0,y0,z0,x1,y1,z1 (mm, physical LPS) each, 6 numbers per box
  double rigidFalloffMm = 10;      ///< blend band outside each bone
  int rigidityStride = 1;          ///< voxel-level rigidity measures: every N-th voxel per axis
  /// Repair the blend's folds in tissue (deformation::repairFolds): `deform --fold-repair`
  /// (deformRequestTable); rigidity() carries it. `animate`, `pose` and the studio call
  /// applyRigidity with RigidityParams' default, which repairs too.
  bool foldRepair = true;
  /// The rigid blend's parameters: rigidFalloffMm and foldRepair.
  deformation::RigidityParams rigidity() const;

  /// The parameters to run with: `params`, except that a point file's power stands when the
  /// power was not given. Validated (vellum::Error naming the parameter).
  deformation::DeformParams resolved(std::optional<double> filePower) const;
  /// The rigid bodies of `labels` (read through `load`'s region, so that a cropped or
  /// downsampled volume gets the same region); nullopt without labels. FileError when the
  /// label map's grid differs from `grid`; Error when labels are given without rigid or fixed
  /// ids (or a fixed region without labels). `grid` may be the label map's grid grown by whole
  /// voxels (an output padded by --pad-mm): the labels are then placed in it, 0 around.
  std::optional<deformation::RigidBodies> rigidBodies(const Geometry& grid, const io::LoadOptions& load) const;
  /// The bodies of a label map in memory (the studio's; `rigidBodies` above loads the file): the
  /// same bodies, `labelMap` placed in `grid` when that is its grid grown by whole voxels.
  deformation::RigidBodies rigidBodies(const LabelVolume& labelMap, const Geometry& grid) const;
  /// fixedIds and fixedBoxMm as regions (Error unless the boxes are 6 numbers each).
  deformation::FixedRegions fixedRegions() const;
};

/// The stride of the voxel-level measures that are for comparison or between keyframes: on a
/// large volume (over 32 M voxels: a 512^2 x 350 CT) at least 2, which cuts what such a
/// measure costs ~8x (`deform`'s "before"; `animate` then measures its in-between frames at
/// their nodes only); else `stride`.
int coarseMeasureStride(const Geometry& grid, int stride);

/// upsampling, labels, rigid_falloff, rigidity_stride (the engine's own parameters are
/// deformParamsTable(); the rigid ids are a list, not a table row).
const params::Table<DeformEngine>& deformEngineTable();

struct DeformRequest {
  std::filesystem::path input;   ///< volume file or DICOM folder
  std::filesystem::path points;  ///< control points JSON (mm)
  /// Control points made in memory (`vellum pose` generates them): used instead of `points`.
  std::optional<deformation::PointFile> pointSet;
  /// Known forward transforms (source -> output) of rigid bodies by their first label id
  /// (`vellum pose`: the joints'): they replace those bodies' fits in the rigid blend.
  std::vector<std::pair<uint16_t, RigidTransform>> boneTransforms;
  bool keepMap = false;  ///< DeformResult::map gets the full-resolution map (`vellum pose`'s measures)
  /// Makes the whole full-resolution backward map (3 floats, source mm, per output voxel) in
  /// place of the MLS engine and the rigid blend (`vellum pose --map twist`: twistMap()); needs
  /// the rigid bodies (labels). Writes what it did into `report` (the run report's "twist").
  /// The rigidity report, synthesis and outputs stay the same.
  std::function<std::vector<float>(const Geometry& output, const deformation::RigidBodies& bodies,
                                   nlohmann::json& report, Progress& progress)>
      mapMaker;
  std::filesystem::path output;  ///< the deformed volume (same geometry and type)
  std::filesystem::path mapOut;         ///< backward map NRRD; empty: not written
  std::filesystem::path attributesOut;  ///< attribute field NRRD; empty: not written
  std::filesystem::path report;         ///< report JSON; empty: not written (still returned)
  bool psnr = false;  ///< also synthesise at s = 1 and report the PSNR against it
  /// Grow the output box by this much on every side (mm; background there) so that what moves
  /// out of the input's box is not cut; -1: by the largest control-point displacement (plus a
  /// control cell). The output's origin moves out with it: world positions stay where they were.
  double padMm = 0;
  bool noGzip = false;  ///< NRRD outputs (volume, --map-out, --attributes-out) raw, not gzip
  bool force = false;  ///< a DICOM output may replace a Vellum folder of another kind
  DeformEngine engine;
  io::LoadOptions load;  ///< series, raw layout, region (the label map gets the same region)
  std::string commandLine;  ///< for the report's shared keys (run_report.hpp)
};

/// psnr, pad_mm, fold_repair (engine.foldRepair), no_gzip (the paths and the engine's settings have their own flags and tables).
const params::Table<DeformRequest>& deformRequestTable();

struct DeformResult {
  AnyVolume output;                   ///< what was written to request.output
  deformation::DeformParams params;   ///< as run (the point file's power resolved)
  size_t points = 0;
  std::vector<std::string> warnings;  ///< the loader's (e.g. resampled slices)
  /// timings_ms and cpu_ms per stage, rigidity before/after (voxels and nodes), psnr_db_vs_s1,
  /// input, output, points, dims, params, upsampling: what request.report holds.
  nlohmann::json report;
  std::vector<float> map;  ///< with request.keepMap: the upsampled map, 3 floats (source mm) per output voxel
};

/// Runs the request: every output written atomically, the input never overwritten.
/// Throws FileError naming a bad file, Error for a bad request, Cancelled through `progress`.
DeformResult runDeform(const DeformRequest& request, Progress& progress = Progress::none());

/// A rigidity report as `vellum deform` and `vellum animate` write it.
nlohmann::json toJson(const deformation::RigidityReport& r);
/// What the fold repair did (control-grid cells below its threshold before and after, ...);
/// null when it did not run.
nlohmann::json toJson(const deformation::FoldRepairStats& s, bool ran);

}  // namespace vellum::app
