#pragma once
// 3D level-set active contours ("snakes") started from seed bubbles, like ITK-SNAP.
//
// The contour is the zero level of phi (negative inside) and moves by
//   d(phi)/dt = -alpha * S * |grad phi|                      propagation
//               + beta * K * kappa * |grad phi|             curvature (K = S for edge speed, 1 otherwise)
//               + gamma * grad S . grad phi                  advection (pulls towards low S)
// with S the speed image, kappa the mean curvature (sum of principal curvatures, 1/mm).
// Only a narrow band of voxels around the contour is stored as a list and updated
// (a few voxels either side, re-distanced every few steps), so each iteration costs in
// proportion to the surface, not the volume. Units: phi in mm, speeds in mm per unit time;
// the time step follows the CFL limit (the contour moves at most `cflNumber` voxels a step).
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

/// A spherical start region.
struct Bubble {
  Vec3 centerMm;
  double radiusMm = 5.0;
};

enum class SpeedType {
  Threshold,  ///< region competition: S in [-1, 1], positive inside the HU interval
  Edge,       ///< S = g = 1 / (1 + (|grad(G_sigma * I)| / kappa)^exponent) in (0, 1]
};
const params::EnumTable<SpeedType>& speedTypes();  ///< "threshold" (alias "region") | "edge"
inline SpeedType parseSpeedType(const std::string& name) { return speedTypes().parse(name); }

/// Smooth two-sided region speed: S(I) = tanh(min(I - lower, upper - I) / smoothnessHu),
/// so S = +1 well inside [lower, upper], -1 well outside, 0 at the thresholds.
struct ThresholdSpeedParams {
  double lower = -500;        ///< HU (default: soft tissue against air)
  double upper = 300;         ///< HU (default: soft tissue against bone, low enough that thin
                              ///< partial-volumed cortex still stops the contour)
  double smoothnessHu = 60;   ///< width of the transition; larger = smoother, slower near the edge
};

/// Edge speed from the smoothed gradient magnitude (HU/mm; per axis the larger one-sided
/// difference, so that one-voxel walls keep their edge).
/// Defaults: exponent 4 and kappa 120 HU/mm, not the classic 1/(1+(x/kappa)²) with kappa 100.
/// The classic curve falls too slowly: at 5 kappa g is still 0.04 (0.0016 with exponent 4), so
/// the always-outward edge snake creeps over the skin into the air and through the
/// partial-volumed edges of thin cortex into the bones. Measured on the knee phantom at 128³
/// (soft tissue, seed in the muscle, advection 2): Dice 0.46 (the whole grid) with exponent 2
/// for kappa 100 or 120, 0.994 with these defaults; docs/segmentation.md.
struct EdgeSpeedParams {
  double sigmaMm = 1.0;       ///< Gaussian blur before the gradient (mm)
  double kappaHuPerMm = 120;  ///< gradient magnitude at which g = 0.5
  double exponent = 4.0;      ///< 2 is the classic 1/(1+(x/kappa)²)
};

struct SpeedImage {
  VolumeF32 values;
  SpeedType type = SpeedType::Threshold;
};

SpeedImage thresholdSpeed(const VolumeI16& ct, const ThresholdSpeedParams& params = {},
                          Progress& progress = Progress::none());
SpeedImage edgeSpeed(const VolumeI16& ct, const EdgeSpeedParams& params = {},
                     Progress& progress = Progress::none());

/// Separable Gaussian blur with sigma in mm (per-axis kernels from the spacing; truncated at
/// 3 sigma; outside the grid = the volume's background). Parallel.
VolumeF32 gaussianBlur(const VolumeI16& ct, double sigmaMm, Progress& progress = Progress::none());

struct SnakeParams {
  double propagation = 1.0;   ///< alpha
  double curvature = 0.2;     ///< beta (mm): smooths; too high shrinks thin parts
  /// gamma: pulls the contour onto edges (towards low speed). Unset: 0 for threshold speed,
  /// kDefaultEdgeAdvection for edge speed (it holds the contour in the edge's valley instead
  /// of letting propagation push it over a weak edge).
  std::optional<double> advection;
  int maxIterations = 2000;   ///< hard limit (at the finest level)
  /// Converged when, over the last `convergenceWindow` iterations, the voxels that changed
  /// side per iteration averaged at most convergenceFraction * (voxels on the contour).
  double convergenceFraction = 0.002;
  int convergenceWindow = 10;
  double cflNumber = 0.5;     ///< at most this many voxels of contour motion per iteration
  /// Coarse-to-fine: evolve first on the speed image downsampled 2x per level, then refine
  /// on the next finer level (min-pooled speed, so thin barriers and edges stay closed; an
  /// edge-speed level starts one coarse voxel inside the coarse contour, because that snake
  /// only grows and could not undo a coarse crossing of a thin wall). -1 = automatic (one
  /// coarse level per factor 2 while the coarse grid keeps >= 64 voxels on the smallest axis,
  /// at most 2), 0 = single resolution.
  int coarseLevels = -1;
  /// Settled (stops as converged) when the inside's volume changed by at most this fraction
  /// over the last `settleWindow` iterations of a level; 0 = off. On a real CT the contour's
  /// noisy edge keeps flipping voxels, so the test above may not pass in 2000 iterations
  /// although the region no longer grows (ct-feet-vhf: docs/benchmarks-segmentation.md).
  double settleFraction = 0.002;
  int settleWindow = 50;
};

inline constexpr double kDefaultEdgeAdvection = 2.0;

/// The advection weight the snake uses for `type` (params.advection or its default).
inline double resolvedAdvection(const SnakeParams& params, SpeedType type) {
  return params.advection.value_or(type == SpeedType::Edge ? kDefaultEdgeAdvection : 0.0);
}

struct SnakeResult {
  Mask mask;                  ///< phi <= 0 (inside)
  VolumeF32 phi;              ///< final level set (mm): near-distance in the narrow band (re-distanced
                              ///< at most 5 steps before the end), +-band width elsewhere
  int iterations = 0;         ///< at the finest level
  int coarseIterations = 0;   ///< summed over the coarse levels
  bool converged = false;
  bool settled = false;       ///< converged by SnakeParams::settleFraction at the finest level
  double seconds = 0;
  double secondsPerIteration = 0;  ///< at the finest level
  int64_t finalContourVoxels = 0;  ///< voxels adjacent to the zero level at the end
};

/// Sees the snake's inside while it evolves (see evolveSnake).
using SnakeObserver = std::function<void(const Mask& inside, int iteration)>;

/// Evolves a contour from `bubbles` on `speed`. Throws vellum::Error for no bubbles or a
/// bubble outside the grid, vellum::Cancelled through `progress` (units = iterations).
/// `observe`, when given, sees the contour as it evolves: every `observeEvery` iterations the
/// inside (phi <= 0) on the grid of the level being evolved (coarse levels first), on the
/// evolving thread. A UI uses it to draw the snake live.
SnakeResult evolveSnake(const SpeedImage& speed, const std::vector<Bubble>& bubbles,
                        const SnakeParams& params = {}, Progress& progress = Progress::none(),
                        const SnakeObserver& observe = {}, int observeEvery = 10);

/// evolveSnake started from the inside of `start` (on the speed image's grid) instead
/// of bubbles: a snake continued on a larger region (the studio's box grown where the
/// contour reached its edge). The coarse levels start from `start` sampled on their grids.
/// Throws vellum::Error when `start` is on another grid or empty.
SnakeResult evolveSnakeFrom(const SpeedImage& speed, const Mask& start, const SnakeParams& params = {},
                        Progress& progress = Progress::none(), const SnakeObserver& observe = {},
                        int observeEvery = 10);

}  // namespace vellum::segmentation
