#pragma once
// The deformation engine: control points in, control volume (coarse backward map + attribute
// fields) out. Keeps the rho-field cache ([HVD 1.3] in docs/references.md, beyond the paper): one field per
// control point at control-grid resolution, rebuilt only for points whose SOURCE moved, so
// dragging targets costs no ray casting.
#include <memory>

#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/control_volume.hpp"
#include "vellum/deformation/density.hpp"
#include "vellum/deformation/mls.hpp"

namespace vellum::deformation {

struct DeformParams {
  MlsParams mls;
  DensityParams density;
  int controlScale = 2;  ///< s: 1 (full resolution), 2, 4 (any >= 1 works)
  /// Grid factor of the rho-field cache; 0 = controlScale. A full-resolution map (s = 1) can
  /// still look rho up in coarser fields (rho varies smoothly away from the control points).
  int rhoScale = 0;
  /// Solve well-conditioned grid nodes in single precision (about 2x faster; errors ~1e-4 mm,
  /// below the float storage of the control volume's neighbourhood). mapPoints() is always
  /// double. Affine method without attributes only; the rest stays double.
  bool singlePrecisionGrid = true;
  /// Compute attribute fields when some point has non-default attributes.
  bool attributes = true;
};

struct DeformTimings {
  double densityBuildMs = 0;  ///< normalised density + mip pyramid (once per Deformer)
  double rhoCacheMs = 0;      ///< rho fields rebuilt in the last update()
  int rhoFieldsRebuilt = 0;   ///< how many fields the last update() rebuilt
  double mapMs = 0;           ///< MLS (+ fixed-point iterations) over the control grid
};

class Deformer {
 public:
  /// `source` provides the geometry (output = input geometry) and, with density-aware weights,
  /// the density (copied into a normalised float pyramid; the volume is not referenced later).
  Deformer(const AnyVolume& source, const DeformParams& params);
  ~Deformer();
  Deformer(Deformer&&) noexcept;
  Deformer& operator=(Deformer&&) noexcept;

  const DeformParams& params() const;
  const Geometry& outputGeometry() const;
  const Geometry& grid() const;

  /// Replaces the control points (mm). Fields of points whose source moved are marked stale.
  void setPoints(const ControlPoints& points);
  const ControlPoints& points() const;

  /// Recomputes the control volume for the current points (rebuilding stale rho fields first).
  const ControlVolume& update(Progress& progress = Progress::none());
  const ControlVolume& controlVolume() const;
  /// The same map (density fixed point included) at arbitrary output positions (mm), in
  /// double precision: the reference for tests and for picking. Rebuilds stale rho fields.
  std::vector<Vec3> mapPoints(const std::vector<Vec3>& outputMm,
                              std::vector<std::array<double, 4>>* attributesOut = nullptr);
  const DeformTimings& timings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One-shot convenience: a Deformer, setPoints, update.
ControlVolume computeControlVolume(const AnyVolume& source, const ControlPoints& points,
                                   const DeformParams& params,
                                   Progress& progress = Progress::none());

}  // namespace vellum::deformation
