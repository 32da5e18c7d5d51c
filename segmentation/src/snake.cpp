// The 3D snake (see snake.hpp for the equation): its speed terms, the coarse-to-fine speed
// pyramid and the seed bubbles, evolved by core's narrow-band level set (core/level_set.hpp).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <cmath>
#include <limits>
#include <memory>

#include "vellum/core/level_set.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/segmentation/snake.hpp"

namespace vellum::segmentation {
namespace {

/// The snake's d(phi)/dt at a band voxel (see snake.hpp): propagation, curvature and
/// advection on the speed image S.
struct SnakeRate {
  const float* S;
  bool edge;
  double propagation, curvature, advection;

  float operator()(const LevelSetStencil& st, LevelSetBounds& bounds) const {
    const double s = S[st.index];
    double out = 0;
    // Propagation (upwind, Osher-Sethian): outward speed F = alpha * S.
    const double F = propagation * s;
    if (F != 0) out -= F * st.upwindGradient(F);
    double speedBound = std::abs(F);
    // Curvature: kappa * |grad phi| from central differences.
    if (curvature != 0) {
      const double w = curvature * (edge ? s : 1.0);
      double term = 0;
      if (st.curvatureRate(w, term)) {
        out += term;
        bounds.curvature = std::max(bounds.curvature, std::abs(w));
      }
    }
    // Advection towards low speed, as motion with velocity V = -gamma * grad S:
    // d(phi)/dt = -V . grad phi (upwind).
    if (advection != 0) {
      const double vx = -advection * st.centralDifference(S, 0), vy = -advection * st.centralDifference(S, 1),
                   vz = -advection * st.centralDifference(S, 2);
      out -= st.upwindAdvection(vx, vy, vz);
      speedBound += std::abs(vx) + std::abs(vy) + std::abs(vz);
    }
    bounds.speed = std::max(bounds.speed, speedBound);
    return static_cast<float>(out);
  }
};

/// Downsamples by 2 per axis taking the MINIMUM speed of each 2x2x2 block (the coarse voxel
/// centre sits at the centre of its block). The minimum keeps thin barriers (a cortex one voxel
/// thick) closed at the coarse level, so the coarse contour never leaks through them; it may
/// stop short of narrow passages, which the finer level then fills.
VolumeF32 downsample2(const VolumeF32& v) {
  const Dims d = v.dims();
  Geometry g = v.geometry();
  g.dims = {(d.x + 1) / 2, (d.y + 1) / 2, (d.z + 1) / 2};
  g.origin = v.geometry().indexToPhysical({0.5, 0.5, 0.5});
  g.spacing = v.geometry().spacing * 2.0;
  VolumeF32 out(g, 0.0f, v.background());
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          float lo = std::numeric_limits<float>::infinity();
          for (int64_t c = 2 * k; c <= std::min(2 * k + 1, d.z - 1); ++c)
            for (int64_t b = 2 * j; b <= std::min(2 * j + 1, d.y - 1); ++b)
              for (int64_t a = 2 * i; a <= std::min(2 * i + 1, d.x - 1); ++a) lo = std::min(lo, v(a, b, c));
          out(i, j, k) = lo;
        }
  });
  return out;
}

/// Dense signed distance (mm) to the union of the bubbles, clamped.
void bubblePhi(const Geometry& g, const std::vector<Bubble>& bubbles, std::vector<float>& phi, float clamp) {
  const Dims d = g.dims;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const Vec3 x = g.indexToPhysical({double(i), double(j), double(k)});
          double best = std::numeric_limits<double>::infinity();
          for (const Bubble& b : bubbles) best = std::min(best, norm(x - b.centerMm) - b.radiusMm);
          phi[static_cast<size_t>((k * d.y + j) * d.x + i)] = static_cast<float>(std::clamp<double>(best, -clamp, clamp));
        }
  });
}

/// One coarse level per factor 2 while the coarse grid keeps >= 64 voxels on its longest axis
/// and >= 24 on its shortest, at most 2. (The shortest axis alone, >= 64, left a limb-sized
/// box of a real scan — 181 x 181 x 100 voxels on ct-feet-vhf — with no coarse level at all:
/// every step of the growth from the seed ran at full resolution.)
int autoLevels(const Dims& d) {
  int64_t lo = std::min({d.x, d.y, d.z}), hi = std::max({d.x, d.y, d.z});
  int levels = 0;
  while (levels < 2 && hi / 2 >= 64 && lo / 2 >= 24) { lo /= 2; hi /= 2; ++levels; }
  return levels;
}

void checkParams(const SnakeParams& p) {
  if (p.maxIterations < 1) throw Error("snake: iterations must be >= 1");
  if (!(p.cflNumber > 0 && p.cflNumber <= 1)) throw Error("snake: CFL number must be in (0, 1]");
  if (p.curvature < 0) throw Error("snake: curvature weight must be >= 0");
  if (p.settleFraction < 0 || p.settleWindow < 1) throw Error("snake: settle fraction must be >= 0, window >= 1");
}

/// Fills phi (the coarsest level's grid) with the start region, clamped to +-clamp.
using StartPhi = std::function<void(const Geometry& g, std::vector<float>& phi, float clamp)>;

SnakeResult evolve(const SpeedImage& speed, const StartPhi& startPhi, const SnakeParams& p, Progress& progress,
                   const SnakeObserver& observe, int observeEvery);

}  // namespace

SnakeResult evolveSnake(const SpeedImage& speed, const std::vector<Bubble>& bubbles, const SnakeParams& p,
                        Progress& progress, const SnakeObserver& observe, int observeEvery) {
  if (bubbles.empty()) throw Error("snake: at least one seed bubble is needed");
  checkParams(p);
  const Geometry& g = speed.values.geometry();
  for (const Bubble& b : bubbles) {
    seedsToVoxels(g, {b.centerMm});  // throws for a centre outside the grid
    if (!(b.radiusMm > 0)) throw Error("snake: bubble radius must be > 0 mm");
  }
  return evolve(speed, [&](const Geometry& lg, std::vector<float>& phi, float clamp) { bubblePhi(lg, bubbles, phi, clamp); },
                p, progress, observe, observeEvery);
}

SnakeResult evolveSnakeFrom(const SpeedImage& speed, const Mask& start, const SnakeParams& p, Progress& progress,
                        const SnakeObserver& observe, int observeEvery) {
  checkParams(p);
  const Geometry& g = speed.values.geometry();
  if (!(start.dims() == g.dims)) throw Error("snake: the start region is not on the speed image's grid");
  if (countVoxels(start) == 0) throw Error("snake: the start region is empty");
  return evolve(
      speed,
      [&](const Geometry& lg, std::vector<float>& phi, float clamp) {
        // Nearest voxel of the start region at each (coarse) voxel's centre: inside or outside.
        const Geometry::ToIndex toStart = g.physicalToIndexMap();
        parallelFor(lg.dims.z, [&](int64_t k0, int64_t k1) {
          for (int64_t k = k0; k < k1; ++k)
            for (int64_t j = 0; j < lg.dims.y; ++j)
              for (int64_t i = 0; i < lg.dims.x; ++i) {
                const bool in = start.sampleNearest(toStart(lg.indexToPhysical({double(i), double(j), double(k)}))) != 0;
                phi[static_cast<size_t>((k * lg.dims.y + j) * lg.dims.x + i)] = in ? -clamp : clamp;
              }
        });
      },
      p, progress, observe, observeEvery);
}

namespace {
SnakeResult evolve(const SpeedImage& speed, const StartPhi& startPhi, const SnakeParams& p, Progress& progress,
                   const SnakeObserver& observe, int observeEvery) {
  const Geometry& g = speed.values.geometry();
  const auto t0 = std::chrono::steady_clock::now();
  const bool edge = speed.type == SpeedType::Edge;
  // Coarse levels: min-pooling keeps barriers (thin walls, edges) closed at the coarse level;
  // for edge speed each finer level starts inside the coarse contour (see below).
  const int levels = p.coarseLevels < 0 ? autoLevels(g.dims) : std::min(p.coarseLevels, 4);

  // Speed pyramid: pyramid[0] = finest.
  std::vector<VolumeF32> pyramid;
  for (int l = 0; l < levels; ++l) pyramid.push_back(downsample2(l == 0 ? speed.values : pyramid.back()));

  SnakeResult res;
  const LevelSetStopping stop{p.maxIterations, p.convergenceFraction, p.convergenceWindow, p.settleFraction,
                              p.settleWindow};
  const double advection = resolvedAdvection(p, speed.type);
  std::unique_ptr<NarrowBandLevelSet> coarser;  // the converged level below, until the next one starts from it
  for (int l = levels; l >= 0; --l) {
    const VolumeF32& S = l == 0 ? speed.values : pyramid[l - 1];
    auto ev = std::make_unique<NarrowBandLevelSet>(S.geometry(), p.cflNumber);
    const LevelSetRate rate = SnakeRate{S.data(), edge, p.propagation, p.curvature, advection};
    if (!coarser) {
      startPhi(S.geometry(), ev->phi(), ev->clampValue());
      ev->initialise();
    } else {
      // Edge speed only expands, so a coarse contour that crossed a thin wall (its position is
      // only known to about a coarse voxel) could never come back: start the finer level one
      // coarse voxel inside it and let it expand to the edges at full detail.
      ev->initialiseFrom(*coarser, edge ? coarser->maxSpacing() : 0.0);
      coarser.reset();
    }
    const std::string stage = l == 0 ? "snake" : "snake (1/" + std::to_string(1 << l) + " resolution)";
    const auto toMask = [&](const NarrowBandLevelSet& ls, int iteration) {
      Mask inside(ls.grid(), 0, 0.0);
      const float* ph = ls.phi().data();
      uint8_t* m = inside.data();
      tbb::parallel_for(tbb::blocked_range<size_t>(0, inside.size(), 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i < r.end(); ++i) m[i] = ph[i] <= 0;
      });
      observe(inside, iteration);
    };
    const LevelSetRunResult r =
        observe ? ev->run(rate, stop, stage, progress, l > 0, toMask, observeEvery) : ev->run(rate, stop, stage, progress, l > 0);
    if (l > 0) {
      res.coarseIterations += r.iterations;
      coarser = std::move(ev);
      continue;
    }
    res.iterations = r.iterations;
    res.converged = r.converged;
    res.settled = r.settled;
    res.secondsPerIteration = r.iterations > 0 ? r.seconds / r.iterations : 0;
    res.finalContourVoxels = r.contourVoxels;
    res.phi = VolumeF32(g, 0.0f, ev->clampValue());
    res.phi.voxels() = std::move(ev->phi());
  }
  res.mask = Mask(g, 0, 0.0);
  const float* ph = res.phi.data();
  uint8_t* m = res.mask.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, res.mask.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) m[i] = ph[i] <= 0;
                    });
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}
}  // namespace

}  // namespace vellum::segmentation
