#pragma once
// Bone stays rigid ([HVD 1.6] in docs/references.md): rigid bodies from labels (or a HU threshold), a
// segmentation-aware constraint that blends the backward map towards each body's best rigid
// fit, and the measures (bone RMS non-rigid residual, soft-tissue displacement, fold-over).
#include <array>
#include <memory>
#include <mutex>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/control_volume.hpp"

namespace vellum::deformation {

/// Tissue classes over the SOURCE volume: 0 air/background, 1 soft tissue, 2 + c rigid
/// component c (26-connected components of the rigid voxels: on the phantom, one per bone).
class RigidBodies {
 public:
  /// Rigid voxels = labels in `rigidIds`; soft tissue = every other non-zero label.
  /// Components smaller than `minVoxels` count as soft tissue (stray voxels of a noisy
  /// segmentation; the phantom's bones are whole components and lose nothing).
  static RigidBodies fromLabels(const LabelVolume& labels, const std::vector<uint16_t>& rigidIds,
                                int64_t minVoxels = 20);
  /// Rigid voxels = value >= boneHu; soft tissue = airHu < value < boneHu.
  static RigidBodies fromThreshold(const AnyVolume& ct, double boneHu = 300, double airHu = -500,
                                   int64_t minVoxels = 20);

  int componentCount() const { return components_; }
  const VolumeU16& classes() const { return *classes_; }
  const std::shared_ptr<const VolumeU16>& classesPtr() const { return classes_; }
  /// Per component: index-space bounding box {min i, j, k, max i, j, k} in classes().
  const std::vector<std::array<int64_t, 6>>& boxes() const { return boxes_; }
  /// Class at a physical position (nearest voxel; 0 outside).
  uint16_t classAt(const Vec3& mm) const;
  /// What the rigid blend needs on one grid: distances (mm) from its nodes to the components,
  /// and which of its cells can hold a body voxel.
  struct GridFields {
    std::vector<std::vector<float>> perBody;  ///< one distance field per component
    std::vector<float> nearest;               ///< the minimum over the components
    /// Per cell (indexed by its lowest node): 1 where some rigid voxel's nearest-voxel region
    /// reaches into the cell, so classAt() can be >= 2 only at positions in such cells.
    std::vector<uint8_t> bodyCells;
  };
  /// The fields on `grid`, computed once per grid and cached for the last few grids (an
  /// interactive session alternates a preview grid and the exact one; thread-safe).
  std::shared_ptr<const GridFields> gridFields(const Geometry& grid) const;

 private:
  struct Cache {
    std::mutex mutex;
    /// Most recently used first.
    std::vector<std::pair<Geometry, std::shared_ptr<const GridFields>>> entries;
  };
  std::shared_ptr<Cache> cache_ = std::make_shared<Cache>();
  static RigidBodies fromMask(VolumeU16 classes, int64_t minVoxels);
  std::shared_ptr<const VolumeU16> classes_ = std::make_shared<VolumeU16>();
  int components_ = 0;
  std::vector<std::array<int64_t, 6>> boxes_;  // per component: min ijk, max ijk
  Mat3 mmToIndex_;
};

struct RigidityParams {
  /// Width of the band (mm) outside each body over which the map blends from the body's rigid
  /// fit back to the MLS map (smoothstep weight). Inside the body, and within one control-grid
  /// spacing of it, the map is the rigid fit.
  double falloffMm = 10.0;
};

/// Blends `cv` towards each component's best rigid transform (Kabsch fit of v -> u over the
/// nodes whose u lies in the component). Overlapping bands are normalised. Also sets
/// cv.rigidSnap, so that synthesize() / upsampleMap() give every voxel whose source lands in a
/// body exactly that body's transform (see RigidSnap).
void applyRigidity(ControlVolume& cv, const RigidBodies& bodies, const RigidityParams& params = {},
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
  double boneRmsResidualMm = 0;  ///< RMS of u - (R v + t) over bone samples, per-component fits
  double boneMaxResidualMm = 0;
  double softTissueMeanDisplacementMm = 0;  ///< mean |u(v) - v| over soft-tissue samples
  /// Fraction of interior samples with Jacobian det(du/dv) <= 0 (central differences between
  /// direct neighbours on the sampled grid).
  double foldFraction = 0;
};

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
