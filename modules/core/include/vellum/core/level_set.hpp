#pragma once
// Narrow-band level-set evolution: d(phi)/dt = rate(voxel), explicit steps at the CFL limit
// over a band of voxels around the zero level, re-distanced as the front moves. The rate is
// the caller's (the segmentation snake's propagation, curvature and advection terms); the
// stencil below gives it the upwind and central differences the usual terms need.
//
// phi (mm, negative inside) is stored densely but only the band is read or written: the band
// is a list, rebuilt from the voxels next to a sign change (sub-voxel distances from the
// crossings), then grown outward breadth-first with a local Eikonal update. Voxels beyond the
// band hold +-clampValue(), so their sign is always right. Each step updates the "active" part
// of the band (|phi| within two steps of motion plus a voxel). The band is rebuilt every few
// steps, or right after a step in which a voxel changed side next to a non-active voxel.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "vellum/core/geometry.hpp"
#include "vellum/core/progress.hpp"

namespace vellum {

/// Finite differences of phi around one band voxel, for a rate function.
struct LevelSetStencil {
  int64_t index = 0;       ///< linear voxel index (x fastest)
  const float* phi = nullptr;  ///< phi at the voxel; neighbours at phi[lo[a]], phi[hi[a]]
  int64_t lo[3]{}, hi[3]{};    ///< offsets to the lower / upper neighbour per axis, 0 outside the grid
  int64_t stride[3]{};         ///< linear strides of the axes
  double h[3]{};               ///< spacing (mm)
  double dm[3]{}, dp[3]{};     ///< backward / forward differences of phi per axis

  /// |grad phi| for motion along the normal at speed F (> 0 outward), Osher-Sethian upwind.
  double upwindGradient(double F) const;
  /// weight * (mean curvature) * |grad phi| from central differences, into `rate`; false
  /// (rate untouched) where the gradient vanishes.
  bool curvatureRate(double weight, double& rate) const;
  /// Upwind v . grad phi for a velocity v (mm per unit time).
  double upwindAdvection(double vx, double vy, double vz) const;
  /// Central difference of another field on the same grid along `axis` (one-sided at the border).
  double centralDifference(const float* field, int axis) const;
};

/// Bounds a rate function reports for the time step: the largest motion speed (normal plus
/// advection, mm per unit time) and the largest curvature weight (mm² per unit time).
struct LevelSetBounds {
  double speed = 0;
  double curvature = 0;
};

/// d(phi)/dt at one voxel; raises `bounds` to cover it. Called in parallel.
using LevelSetRate = std::function<float(const LevelSetStencil&, LevelSetBounds& bounds)>;

/// When an evolution stops.
struct LevelSetStopping {
  int maxIterations = 2000;
  /// Converged when, over the last `window` steps, the voxels that changed side per step
  /// averaged at most `fraction` * (voxels on the contour).
  double fraction = 0.002;
  int window = 10;
  /// Also stopped ("settled") when the inside's voxel count stayed within
  /// `settleFraction` * (inside voxels) over the last `settleWindow` steps; 0 = off. On a real
  /// CT the contour's noisy edge keeps flipping voxels, so the test above may never pass
  /// although the region no longer changes.
  double settleFraction = 0;
  int settleWindow = 50;
};

struct LevelSetRunResult {
  int iterations = 0;
  bool converged = false;
  bool settled = false;  ///< converged by LevelSetStopping::settleFraction
  double seconds = 0;
  int64_t contourVoxels = 0;  ///< voxels next to the zero level at the end
};

class NarrowBandLevelSet {
 public:
  /// A level set on `grid`; the contour moves at most `cflNumber` (0, 1] voxels a step.
  /// phi() must be filled (densely) before initialise().
  NarrowBandLevelSet(const Geometry& grid, double cflNumber);

  std::vector<float>& phi() { return phi_; }
  const std::vector<float>& phi() const { return phi_; }
  float clampValue() const { return clamp_; }
  double maxSpacing() const { return hmax_; }
  size_t interfaceCount() const { return interfaceCount_; }

  /// Clamps the dense phi() and builds the band from a scan of the whole grid.
  void initialise();
  /// Starts from a converged level set on this grid downsampled 2x (coarse-to-fine), its
  /// zero level moved inward by shrinkMm. Only voxels near the coarse band are interpolated.
  void initialiseFrom(const NarrowBandLevelSet& coarse, double shrinkMm);

  /// What one step did: voxels that changed side, and whether one of them touches a voxel
  /// outside the active list (then the band must be rebuilt before the front can go on).
  struct Change {
    int64_t changed = 0;
    bool leftActive = false;
    int64_t net = 0;  ///< voxels that went inside minus those that went outside
    Change operator+(const Change& o) const { return {changed + o.changed, leftActive || o.leftActive, net + o.net}; }
  };
  /// One explicit step over the active voxels, dt from the CFL limit of the rates' bounds.
  Change step(const LevelSetRate& rate);
  /// Re-distances the band around the current zero level.
  void rebuild();

  /// Steps until convergence or stop.maxIterations (progress units = steps, throws
  /// vellum::Cancelled through it); re-distances at the end when `redistanceAtEnd`.
  /// `observe`, when given, is called every `observeEvery` steps with the level set and the
  /// steps done (a UI shows the contour as it evolves; it runs on the evolving thread).
  LevelSetRunResult run(const LevelSetRate& rate, const LevelSetStopping& stop, const std::string& stage,
                        Progress& progress, bool redistanceAtEnd,
                        const std::function<void(const NarrowBandLevelSet&, int)>& observe = {}, int observeEvery = 10);
  const Geometry& grid() const { return grid_; }

 private:
  bool inside(int64_t q) const { return phi_[q] <= 0; }
  float sampleTrilinear(double x, double y, double z) const;
  void neighbourOffsets(int64_t q, int64_t off[3][2]) const;
  bool neighboursActive(int64_t q) const;
  bool crossing(int64_t q) const;
  float interfaceDistance(int64_t q) const;
  float eikonal(int64_t q, uint8_t maxCode) const;
  void buildBand(const std::vector<int64_t>& iface);
  std::vector<int64_t> growLayer(const std::vector<int64_t>& layer, uint8_t code);
  void sortByIndex(std::vector<int64_t>& v);
  LevelSetStencil stencil(int64_t q) const;

  Geometry grid_;
  Dims d_;
  int64_t sy_, sz_;
  double h_[3];
  double cfl_, hmin_, hmax_, activeWidth_, expandWidth_;
  float clamp_;
  std::vector<float> phi_;
  std::vector<uint8_t> code_;  ///< band layer and flags per voxel (see level_set.cpp)
  std::vector<int64_t> band_, active_;
  std::vector<float> rate_;
  std::vector<int64_t> sortScratch_;
  size_t interfaceCount_ = 0;
};

}  // namespace vellum
