#pragma once
// Bone stays rigid ([HVD 1.6] in docs/references.md): rigid bodies from labels (or a HU threshold), a
// segmentation-aware constraint that blends the backward map towards each body's best rigid
// fit, and the measures (bone RMS non-rigid residual, soft-tissue displacement, fold-over).
#include <algorithm>
#include <array>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/rigid_fit.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/control_volume.hpp"
#include "vellum/deformation/fold_repair.hpp"

namespace vellum::deformation {

/// What stays put: label ids and boxes (mm, physical LPS) whose voxels do not move at all
/// (displacement exactly 0 there; the map blends back to the MLS map outside them over the
/// same band as a rigid body). Every voxel inside a box is fixed, air and bone included.
struct FixedRegions {
  std::vector<uint16_t> ids;
  std::vector<std::array<double, 6>> boxesMm;  ///< {x0, y0, z0, x1, y1, z1}, any corner order
  bool empty() const { return ids.empty() && boxesMm.empty(); }
};

/// Whether `p` (mm) lies in a fixed box {x0, y0, z0, x1, y1, z1} (any corner order, faces
/// included): a voxel whose centre does is fixed.
inline bool insideFixedBox(const std::array<double, 6>& box, const Vec3& p) {
  for (int a = 0; a < 3; ++a) {
    const double lo = std::min(box[static_cast<size_t>(a)], box[static_cast<size_t>(a + 3)]);
    const double hi = std::max(box[static_cast<size_t>(a)], box[static_cast<size_t>(a + 3)]);
    if (!(p[a] >= lo && p[a] <= hi)) return false;
  }
  return true;
}

/// Tissue classes over the SOURCE volume: 0 air/background, 1 soft tissue, 2 + c body c.
/// From labels, body c is one rigid label id (all its voxels, whatever their connectivity);
/// from a HU threshold, one 26-connected component. With fixed regions, the last body is
/// them: a body whose transform is the identity, not fitted.
class RigidBodies {
 public:
  /// One rigid body per id of `rigidIds`, whatever its connectivity (a bone split by a bad
  /// slice stays one body); different ids are different bodies even where they touch.
  /// Two rules for the pieces (26-connected parts of one id):
  ///  - a piece mostly enclosed by another rigid id (more than half of its face contacts are
  ///    with that id's voxels, all its pieces together) is that id's core and joins its body:
  ///    a marrow or cancellous label inside a cortex label (the phantom's 5 in 4, 7 in 6, 11
  ///    in 8 and in 9) moves with its bone; an id all of whose pieces are cores has no body of
  ///    its own (its cores go where its largest piece goes);
  ///  - a piece smaller than `minVoxels` that touches no other rigid voxel and is not its id's
  ///    largest piece is soft tissue (specks of a noisy segmentation); every other piece,
  ///    however far from the id's main mass, is that id's body.
  /// `fixed` (ids and boxes) override the rigid ids. Throws vellum::Error for an id both
  /// rigid and fixed.
  static RigidBodies fromLabels(const LabelVolume& labels, const std::vector<uint16_t>& rigidIds,
                                int64_t minVoxels = 20, const FixedRegions& fixed = {});
  /// The same with bodies of several ids (`--rigid-labels 4+5,6+7`): each group is one body
  /// (the pieces rules apply between groups). An id listed in several groups (the phantom's
  /// 11 in 8+11 and 9+11) is split by piece: each goes to the group whose other ids it touches
  /// most (no contact: the first group listing it). fromLabels() is one group per id.
  static RigidBodies fromLabelGroups(const LabelVolume& labels, const std::vector<std::vector<uint16_t>>& groups,
                                     int64_t minVoxels = 20, const FixedRegions& fixed = {});
  /// Rigid voxels = value >= boneHu, one body per 26-connected component (components smaller
  /// than `minVoxels` are soft tissue); soft tissue = airHu < value < boneHu. Without labels
  /// nothing says which piece is which bone, so pieces of one bone are separate bodies.
  static RigidBodies fromThreshold(const AnyVolume& ct, double boneHu = 300, double airHu = -500,
                                   int64_t minVoxels = 20);

  /// What one body is made of.
  struct Body {
    std::vector<uint16_t> ids;  ///< label ids (its group's, as given; then the cores that joined); empty from a threshold
    int64_t voxels = 0;
    int pieces = 0;             ///< 26-connected pieces of its group's ids (cores of other groups not counted)
    bool fixed = false;         ///< the fixed regions: identity transform, never fitted
  };
  /// Bodies, movable ones first, then (when there are fixed regions) the fixed one.
  int componentCount() const { return static_cast<int>(bodies_.size()); }
  const std::vector<Body>& bodies() const { return bodies_; }
  /// Index of the fixed body, or -1.
  int fixedBody() const { return fixedBody_; }
  /// Voxels of specks (pieces under minVoxels) left to soft tissue.
  int64_t droppedVoxels() const { return dropped_; }
  const VolumeU16& classes() const { return *classes_; }
  const std::shared_ptr<const VolumeU16>& classesPtr() const { return classes_; }
  /// Per component: index-space bounding box {min i, j, k, max i, j, k} in classes().
  const std::vector<std::array<int64_t, 6>>& boxes() const { return boxes_; }
  /// Class at a physical position (nearest voxel; 0 outside).
  uint16_t classAt(const Vec3& mm) const;
  /// True where the nearest voxel is tissue (not air, not outside): what the fold measure counts.
  bool tissueAt(const Vec3& mm) const;
  /// What the rigid blend needs on one grid: distances (mm) from its nodes to the components,
  /// and which of its cells can hold a body voxel.
  struct GridFields {
    /// A body's distance field (mm) on the nodes of a box of the grid: the body and every node
    /// within the reach the fields were made for; beyond the box the distance is larger than
    /// that reach (+infinity here). The whole grid when made for an unbounded reach.
    struct BodyField {
      std::array<int64_t, 3> lo{0, 0, 0};  ///< the box's first node
      Dims dims{0, 0, 0};                  ///< empty: the body covers no node
      std::vector<float> dist;
      /// At node (i, j, k) of the grid.
      double at(int64_t i, int64_t j, int64_t k) const;
      /// Trilinear at continuous grid index `gi` (clamped to the grid like the nearest field),
      /// +infinity where its stencil leaves the box.
      double sample(const Vec3& gi, const Dims& grid) const;
    };
    std::vector<BodyField> perBody;  ///< one per component
    std::vector<float> nearest;      ///< the minimum over the components (+infinity beyond every box)
    double reachMm = 0;              ///< the distance up to which the fields are exact
    /// Per cell (indexed by its lowest node): 1 where some rigid voxel's nearest-voxel region
    /// reaches into the cell, so classAt() can be >= 2 only at positions in such cells.
    std::vector<uint8_t> bodyCells;
  };
  /// The fields on `grid`, exact up to `reachMm` from each body (each field on the body's box
  /// grown by the reach: a small bone does not pay for a whole-grid field), computed once per
  /// grid and cached for the last few grids (an interactive session alternates a preview grid
  /// and the exact one; a cached entry made for a larger reach serves; thread-safe).
  std::shared_ptr<const GridFields> gridFields(const Geometry& grid,
                                               double reachMm = std::numeric_limits<double>::infinity()) const;

 private:
  struct Cache {
    std::mutex mutex;
    /// Most recently used first.
    std::vector<std::pair<Geometry, std::shared_ptr<const GridFields>>> entries;
  };
  std::shared_ptr<Cache> cache_ = std::make_shared<Cache>();
  static RigidBodies fromMask(VolumeU16 classes, int64_t minVoxels);
  void finish(VolumeU16 classes);
  std::shared_ptr<const VolumeU16> classes_ = std::make_shared<VolumeU16>();
  /// Fixed-box voxels that are air (class = the fixed body, but not tissue); empty without boxes.
  std::shared_ptr<const VolumeU8> boxAir_;
  std::vector<Body> bodies_;
  int fixedBody_ = -1;
  int64_t dropped_ = 0;
  std::vector<std::array<int64_t, 6>> boxes_;  // per component: min ijk, max ijk
  Mat3 mmToIndex_;
};

struct RigidityParams {
  RigidityParams() = default;
  /// `{falloff}`: the band width, everything else as default.
  RigidityParams(double falloff) : falloffMm(falloff) {}  // NOLINT(google-explicit-constructor)
  /// Width of the band (mm) outside each body over which the map blends from the body's rigid
  /// fit back to the MLS map (smoothstep weight). Inside the body, and within one control-grid
  /// spacing of it, the map is the rigid fit.
  double falloffMm = 10.0;
  /// Repair the folds the blend makes in tissue (repairFolds(): the free nodes of each folding
  /// cell moved; nodes inside a body or a fixed region locked, so they stay exact). On by
  /// default: every path that builds a map (deform, animate, pose, the studio) calls
  /// applyRigidity and gets the same repaired map.
  bool repairFolds = true;
  FoldRepairParams folds;
};

/// Blends `cv` towards each body's best rigid transform (Kabsch fit of v -> u over the
/// nodes whose u lies in the body, all its pieces together). Overlapping bands are
/// normalised. The fixed body (if any) is the identity and wins: a corner of a cell holding a
/// fixed voxel (at v or at u) is exactly v; beyond, its band mixes the identity into the
/// bodies' blend by its own weight alone, over `falloffMm` narrowed so that it ends where the
/// nearest moving body's core begins (a fixed band over a turning bone folds the tissue beside
/// it: issue 23's feet). Also sets
/// cv.rigidSnap, so that synthesize() / upsampleMap() give every voxel whose source lands in a
/// body exactly that body's transform (see RigidSnap). Then (params.repairFolds) the folds in
/// tissue are repaired with the nodes set to a fit or to the identity locked; returns what the
/// repair did (all zero when it did not run).
FoldRepairStats applyRigidity(ControlVolume& cv, const RigidBodies& bodies, const RigidityParams& params = {},
                              Progress& progress = Progress::none());
/// The same with known transforms per body (RigidBodies::bodies() order), backward (output v
/// -> source u): a set entry replaces that body's fit (`vellum pose`: a bone's transform is
/// its joints' rotation, not the MLS map's compromise with its neighbours); the fixed body
/// stays the identity.
FoldRepairStats applyRigidity(ControlVolume& cv, const RigidBodies& bodies, const RigidityParams& params,
                              const std::vector<std::optional<RigidTransform>>& prescribed,
                              Progress& progress = Progress::none());

struct RigidityReport {
  /// True: measured on the full-resolution map that resampling uses (upsampled from the
  /// control grid); false: on the control-grid nodes only (optimistic: it misses what
  /// interpolation between nodes does to voxels near a body's boundary).
  bool voxelLevel = false;
  int stride = 1;  ///< voxel level: every stride-th voxel along each axis was visited
  int components = 0;
  /// Samples (nodes or voxels) classed bone / soft tissue, and all samples visited.
  int64_t boneNodes = 0, softNodes = 0, nodes = 0;
  double boneRmsResidualMm = 0;  ///< RMS of u - (R v + t) over bone samples, per-body fits
  double boneMaxResidualMm = 0;
  double softTissueMeanDisplacementMm = 0;  ///< mean |u(v) - v| over soft-tissue samples (0 when none: see softNodes)
  double softTissueMaxDisplacementMm = 0;
  /// Fraction of the interior TISSUE samples (source position not air) with Jacobian
  /// det(du/dv) <= 0 (central differences between direct neighbours on the sampled grid), and
  /// the smallest det over them; 0 and +inf when there are none (see tissueSamples).
  double foldFraction = 0;
  double minJacobian = 0;
  Vec3 minJacobianAtMm{0, 0, 0};  ///< the output position (mm) of that smallest det: where to look
  int64_t tissueSamples = 0;
  /// Per body (RigidBodies::bodies() order): the best rigid fit of the whole body over the
  /// samples whose source lies in it, and the non-rigid residual about it.
  struct Body {
    std::vector<uint16_t> ids;
    bool fixed = false;
    int64_t samples = 0;
    bool fitted = false;  ///< false: too few samples for a fit (not measured)
    double rmsResidualMm = 0, maxResidualMm = 0;
    double rotationDeg = 0;  ///< angle of the fit's rotation
    Vec3 translationMm{0, 0, 0};
  };
  std::vector<Body> bodies;
  /// The fixed regions: |u - v| over the samples whose output position v lies in them (they
  /// must not move: 0).
  int64_t fixedSamples = 0;
  double fixedMaxDisplacementMm = 0, fixedMeanDisplacementMm = 0;
  /// Samples outside the fixed regions that show their content moved (u in them, |u - v| >
  /// 1e-3 mm): a moving bone's rigid transform reaching into a fixed bone at a joint, or the
  /// blend band dragging fixed tissue; and the largest such |u - v|.
  int64_t fixedContentElsewhere = 0;
  double fixedContentElsewhereMaxMm = 0;
};

/// The worst of several reports (an animation's frames): per measure the worst value (largest
/// residuals, displacements of the fixed regions and fold fraction; smallest Jacobian), per
/// body too; sample counts are the largest. Empty input: a default report.
RigidityReport worstOf(const std::vector<RigidityReport>& reports);

/// Node level: measures a control volume on its nodes (a node belongs to the class found at
/// its source position u(v)). Per-component rigid fits from the nodes.
RigidityReport measureRigidity(const ControlVolume& cv, const RigidBodies& bodies);

/// Voxel level: the same measures over a full-resolution backward map (3 floats per output
/// voxel, x fastest, as upsampleMap() returns it) on `output`, visiting every `stride`-th voxel
/// per axis (1 = every voxel); rigid fits from the visited voxels.
RigidityReport measureRigidityMap(const std::vector<float>& mapMm, const Geometry& output,
                                  const RigidBodies& bodies, int stride = 1);

/// Voxel level from a control volume: upsamples it exactly as synthesize() does
/// (3 floats per output voxel, memory budget checked) and calls measureRigidityMap().
RigidityReport measureRigidityVoxels(const ControlVolume& cv, const Geometry& output,
                                     const RigidBodies& bodies,
                                     Upsampling upsampling = Upsampling::Trilinear, int stride = 1);

}  // namespace vellum::deformation
