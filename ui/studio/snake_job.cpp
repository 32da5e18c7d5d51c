#include "snake_job.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <vector>

#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace seg = vellum::segmentation;

namespace {
/// Thrown by the observer when the user accepts the contour shown: unwinds the evolution.
struct AcceptNow {
  bool settled = false;  ///< the stop was kSnakeSettleFraction's, not the user's
};

/// `m` (any grid over the same space) on grid `g`, nearest voxel: a coarse level's contour or
/// the box's result on the scan's grid. Voxels of `g` outside m's grid are 0.
seg::Mask resampleNearest(const seg::Mask& m, const Geometry& g) {
  seg::Mask out(g, 0, 0.0);
  const Geometry& mg = m.geometry();
  const Geometry::ToIndex toM = mg.physicalToIndexMap();
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, g.dims.z), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t k = r.begin(); k < r.end(); ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i)
          out(i, j, k) = m.sampleNearest(toM(g.indexToPhysical({double(i), double(j), double(k)}))) != 0;
  });
  return out;
}

/// `m` on box `b`'s voxels pasted into a mask of the scan's grid `g` (0 elsewhere).
seg::Mask paste(const seg::Mask& m, const VoxelBox& b, const Geometry& g) {
  seg::Mask out(g, 0, 0.0);
  const Dims d = m.dims();
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, d.z), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t k = r.begin(); k < r.end(); ++k)
      for (int64_t j = 0; j < d.y; ++j) std::copy_n(&m(0, j, k), d.x, &out(b.lo[0], b.lo[1] + j, b.lo[2] + k));
  });
  return out;
}

/// True when the mask has a voxel on a face of its grid that is not a face of the scan (box
/// `b` of the scan's `dims`): the contour was stopped by the box, not by the anatomy.
bool touchesCutFace(const seg::Mask& m, const VoxelBox& b, const Dims& dims) {
  const Dims d = m.dims();
  const int64_t full[3] = {dims.x, dims.y, dims.z}, n[3] = {d.x, d.y, d.z};
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      if (side == 0 ? b.lo[size_t(axis)] == 0 : b.hi[size_t(axis)] == full[axis] - 1) continue;  // the scan's own face
      const int64_t at = side == 0 ? 0 : n[axis] - 1;
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      for (int64_t u = 0; u < n[a1]; ++u)
        for (int64_t v = 0; v < n[a2]; ++v) {
          int64_t ijk[3];
          ijk[axis] = at;
          ijk[a1] = u;
          ijk[a2] = v;
          if (m(ijk[0], ijk[1], ijk[2])) return true;
        }
    }
  return false;
}
}  // namespace

VoxelBox snakeBox(const Geometry& g, const Vec3& seedMm, double halfMm) {
  // The index box of the mm cube about the seed (any direction: the cube's 8 corners).
  const int64_t dims[3] = {g.dims.x, g.dims.y, g.dims.z};
  VoxelBox b;
  b.lo = {dims[0], dims[1], dims[2]};
  b.hi = {-1, -1, -1};
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner = seedMm + Vec3{(c & 1) ? halfMm : -halfMm, (c & 2) ? halfMm : -halfMm, (c & 4) ? halfMm : -halfMm};
    const Vec3 ijk = g.physicalToIndex(corner);
    const double v[3] = {ijk.x, ijk.y, ijk.z};
    for (size_t a = 0; a < 3; ++a) {
      b.lo[a] = std::min(b.lo[a], int64_t(std::floor(v[a])));
      b.hi[a] = std::max(b.hi[a], int64_t(std::ceil(v[a])));
    }
  }
  for (size_t a = 0; a < 3; ++a) {
    b.lo[a] = std::clamp<int64_t>(b.lo[a], 0, dims[a] - 1);
    b.hi[a] = std::clamp<int64_t>(b.hi[a], b.lo[a], dims[a] - 1);
  }
  return b;
}

std::string snakeFoundNothingReason(const VolumeI16& ct, const app::SegmentSettings& a) {
  std::ostringstream r;
  r.precision(4);
  const Geometry& g = ct.geometry();
  const double minSpacing = std::min({g.spacing.x, g.spacing.y, g.spacing.z});
  const Vec3 seed = a.seedsMm.empty() ? g.center() : a.seedsMm.front();
  const double hu = ct.sampleLinear(g.physicalToIndex(seed));
  if (a.bubbleRadiusMm < 0.5 * minSpacing) {
    r << "the snake found nothing: its bubble (radius " << a.bubbleRadiusMm << " mm, the brush radius) holds no voxel of "
      << minSpacing << " mm; use a larger brush";
    return r.str();
  }
  if (a.speed != "edge") {
    const double lo = a.lower.value_or(-500), hi = a.upper.value_or(300);
    if (hu < lo || hu > hi) {
      r << "the snake found nothing: the seed's HU (" << std::lround(hu) << ") is outside its range [" << lo << ", " << hi
        << "], so the bubble shrank away; seed inside the structure or set the range (threshold presets)";
      return r.str();
    }
  }
  r << "the snake found nothing: the contour shrank away although the seed's HU (" << std::lround(hu)
    << ") is in range; the structure about the seed is thinner than the bubble (radius " << a.bubbleRadiusMm
    << " mm) or the curvature weight (" << a.curvature << " mm) is too high for it";
  return r.str();
}

std::pair<std::shared_ptr<const seg::Mask>, uint64_t> SnakeJob::live() const {
  std::lock_guard lock(liveMutex_);
  return {busy() ? live_ : nullptr, liveRevision_};
}

bool SnakeJob::start(SnakeRequest request) {
  if (job_.busy()) return false;
  generation_ = request.volumeGeneration;
  {
    std::lock_guard lock(liveMutex_);
    live_.reset();
    coarse_.reset();
    liveIteration_ = liveFactor_ = 0;
  }
  paused_ = parked_ = accept_ = false;
  return job_.start(
      [this, request = std::move(request)](Progress& progress) {
        const VolumeI16& ct = request.ct;
        const Geometry& g = ct.geometry();
        // The box about the (first) seed; every seed must lie in it (evolveSnake checks).
        const VoxelBox box = snakeBox(g, request.segment.seedsMm.front(), kSnakeRoiHalfMm);
        const bool whole = box.dims().voxelCount() == g.dims.voxelCount();
        const VolumeI16 crop = whole ? VolumeI16() : std::get<VolumeI16>(cropVolume(AnyVolume(ct), box));
        const VolumeI16& region = whole ? ct : crop;
        const Dims rd = region.dims();
        std::vector<std::pair<int, int64_t>> fullCounts;  // (iteration, inside voxels) at full resolution
        // Every few iterations the contour so far goes to the slices (live evolution); here
        // the worker parks while paused and unwinds when the user accepts.
        const auto publish = [&](const seg::Mask& inside, int iteration) {
          auto copy = std::make_shared<const seg::Mask>(inside);
          const int factor = std::max<int>(1, int(std::lround(double(rd.x) / std::max<int64_t>(1, inside.dims().x))));
          {
            std::lock_guard lock(liveMutex_);
            if (factor == 1 && liveFactor_ > 1) coarse_ = live_;  // the coarse levels' last contour
            live_ = std::move(copy);
            liveIteration_ = iteration;
            liveFactor_ = factor;
            ++liveRevision_;
          }
          std::unique_lock lock(wakeMutex_);
          while (paused_ && !accept_ && !progress.cancelled()) {
            parked_ = true;
            wake_.wait_for(lock, std::chrono::milliseconds(50));
          }
          parked_ = false;
          if (accept_) throw AcceptNow{};
          if (factor == 1) {
            const int64_t n = seg::countVoxels(inside);
            fullCounts.emplace_back(iteration, n);
            int64_t lo = n, hi = n;
            for (auto it = fullCounts.rbegin(); it != fullCounts.rend(); ++it) {
              lo = std::min(lo, it->second);
              hi = std::max(hi, it->second);
              if (iteration - it->first >= kSnakeSettleIterations) {
                if (double(hi - lo) <= kSnakeSettleFraction * double(n) && n > 0) throw AcceptNow{true};
                break;
              }
            }
          }
        };
        // What the UI shows for a contour kept before the end: on the scan's grid.
        const auto kept = [&](const seg::Mask& m, std::string note) {
          SnakeJobResult out;
          out.mask = paste(m.dims() == rd ? m : resampleNearest(m, region.geometry()), box, g);
          out.note = std::move(note);
          std::lock_guard lock(liveMutex_);
          out.iterations = liveIteration_;
          return out;
        };
        SnakeJobResult out;
        try {
          app::SegmentationResult r = app::runSegmentation(region, request.segment, progress, publish);
          out.iterations = r.info["snake"]["iterations"].get<int>();
          out.converged = r.info["snake"]["converged"].get<bool>();
          out.mask = whole ? std::move(r.mask) : paste(r.mask, box, g);
          if (!whole && touchesCutFace(r.mask, box, g.dims)) {
            std::ostringstream n;
            n << "the contour reached the edge of its " << std::lround(2 * kSnakeRoiHalfMm)
              << " mm box about the seed: seed again beyond it to extend";
            out.note = n.str();
          }
        } catch (const AcceptNow& stop) {
          std::shared_ptr<const seg::Mask> m;
          int factor = 1;
          {
            std::lock_guard lock(liveMutex_);
            m = live_;
            factor = liveFactor_;
          }
          if (!m) throw Cancelled();
          std::ostringstream n;
          if (stop.settled)
            n << "settled at iteration " << liveIteration().first << " (the inside changed by under "
              << 100 * kSnakeSettleFraction << " % over " << kSnakeSettleIterations << " iterations)";
          else
            n << "accepted the contour at iteration " << liveIteration().first
              << (factor > 1 ? " of the 1/" + std::to_string(factor) + " resolution level" : " at full resolution");
          if (!whole && factor == 1 && touchesCutFace(*m, box, g.dims))
            n << "; the contour reached the edge of its " << std::lround(2 * kSnakeRoiHalfMm)
              << " mm box about the seed: seed again beyond it to extend";
          out = kept(*m, n.str());
          out.converged = stop.settled;
        } catch (const Cancelled&) {
          std::shared_ptr<const seg::Mask> m;
          {
            std::lock_guard lock(liveMutex_);
            m = coarse_;
          }
          if (!m) throw;  // cancelled before the coarse levels were done: nothing kept
          out = kept(*m, "cancelled at full resolution: kept the coarse contour (Ctrl+Z drops it)");
        }
        if (seg::countVoxels(out.mask) == 0) out.error = snakeFoundNothingReason(ct, request.segment);
        return out;
      },
      "snake");
}

}  // namespace vellum::studio
