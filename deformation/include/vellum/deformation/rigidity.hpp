#pragma once
// Bone stays rigid (algorithms.md 1.6): rigid bodies from labels (or a HU threshold), a
// segmentation-aware constraint that blends the backward map towards each body's best rigid
// fit, and the measures (bone RMS non-rigid residual, soft-tissue displacement, fold-over).
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
  const VolumeU16& classes() const { return classes_; }
  /// Class at a physical position (nearest voxel; 0 outside).
  uint16_t classAt(const Vec3& mm) const;
  /// Distance (mm) from every node of `grid` to each component, one field per component;
  /// computed once per grid and cached (thread-safe).
  std::shared_ptr<const std::vector<std::vector<float>>> distanceFields(const Geometry& grid) const;

 private:
  struct Cache {
    std::mutex mutex;
    Geometry grid;
    std::shared_ptr<const std::vector<std::vector<float>>> fields;
  };
  std::shared_ptr<Cache> cache_ = std::make_shared<Cache>();
  static RigidBodies fromMask(VolumeU16 classes, int64_t minVoxels);
  VolumeU16 classes_;
  int components_ = 0;
  Mat3 mmToIndex_;
};

struct RigidityParams {
  /// Width of the band (mm) outside each body over which the map blends from the body's rigid
  /// fit back to the MLS map (smoothstep weight). Inside the body, and within one control-grid
  /// spacing of it, the map is the rigid fit.
  double falloffMm = 10.0;
};

/// Blends `cv` towards each component's best rigid transform (Kabsch fit of v -> u over the
/// nodes whose u lies in the component). Overlapping bands are normalised.
void applyRigidity(ControlVolume& cv, const RigidBodies& bodies, const RigidityParams& params = {},
                   Progress& progress = Progress::none());

struct RigidityReport {
  int components = 0;
  int64_t boneNodes = 0, softNodes = 0, nodes = 0;
  double boneRmsResidualMm = 0;  ///< RMS of u - (R v + t) over bone nodes, per-component fits
  double boneMaxResidualMm = 0;
  double softTissueMeanDisplacementMm = 0;  ///< mean |u(v) - v| over soft-tissue nodes
  double foldFraction = 0;  ///< fraction of interior nodes with Jacobian det(du/dv) <= 0
};

/// Measures a control volume against the bodies (on the control-grid nodes: a node belongs
/// to the class found at its source position u(v)).
RigidityReport measureRigidity(const ControlVolume& cv, const RigidBodies& bodies);

}  // namespace vellum::deformation
