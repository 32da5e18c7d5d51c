#include "snake_job.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace seg = vellum::segmentation;

namespace {
/// Thrown by the observer when the user accepts the contour shown: unwinds the evolution.
struct AcceptNow {};
/// Thrown by the observer when the contour reached a face of its box that can grow.
struct GrowBox {
  VoxelBox box;  ///< the grown box
  std::shared_ptr<const segmentation::Mask> contour;
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

/// Per face of box `b` of the scan's `dims` (axis * 2 + side): true when the mask (on the
/// box's voxels or a coarser grid over the box) has a voxel on it and it is not a face of the
/// scan: the contour was stopped by the box, not by the anatomy.
std::array<bool, 6> cutFacesReached(const seg::Mask& m, const VoxelBox& b, const Dims& dims) {
  std::array<bool, 6> out{};
  const Dims d = m.dims();
  const int64_t full[3] = {dims.x, dims.y, dims.z}, n[3] = {d.x, d.y, d.z};
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      if (side == 0 ? b.lo[size_t(axis)] == 0 : b.hi[size_t(axis)] == full[axis] - 1) continue;  // the scan's own face
      const int64_t at = side == 0 ? 0 : n[axis] - 1;
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      for (int64_t u = 0; u < n[a1] && !out[size_t(axis * 2 + side)]; ++u)
        for (int64_t v = 0; v < n[a2]; ++v) {
          int64_t ijk[3];
          ijk[axis] = at;
          ijk[a1] = u;
          ijk[a2] = v;
          if (m(ijk[0], ijk[1], ijk[2])) {
            out[size_t(axis * 2 + side)] = true;
            break;
          }
        }
    }
  return out;
}

bool touchesCutFace(const seg::Mask& m, const VoxelBox& b, const Dims& dims) {
  const auto f = cutFacesReached(m, b, dims);
  return std::any_of(f.begin(), f.end(), [](bool x) { return x; });
}

std::string boxSize(const VoxelBox& b, const Geometry& g) {
  const Dims d = b.dims();
  std::ostringstream s;
  s << std::lround(double(d.x) * g.spacing.x) << " x " << std::lround(double(d.y) * g.spacing.y) << " x "
    << std::lround(double(d.z) * g.spacing.z) << " mm";
  return s.str();
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

VoxelBox growSnakeBox(const VoxelBox& box, const seg::Mask& m, const Geometry& g, double growMm) {
  const auto faces = cutFacesReached(m, box, g.dims);
  const int64_t full[3] = {g.dims.x, g.dims.y, g.dims.z};
  const double spacing[3] = {g.spacing.x, g.spacing.y, g.spacing.z};
  VoxelBox out = box;
  for (size_t a = 0; a < 3; ++a) {
    const int64_t by = std::max<int64_t>(1, std::lround(growMm / spacing[a]));
    if (faces[a * 2]) out.lo[a] = std::max<int64_t>(0, box.lo[a] - by);
    if (faces[a * 2 + 1]) out.hi[a] = std::min<int64_t>(full[a] - 1, box.hi[a] + by);
  }
  return out;
}

std::string snakeFoundNothingReason(const VolumeI16& ct, const app::SegmentSettings& a) {
  std::ostringstream r;
  r.precision(4);
  const Geometry& g = ct.geometry();
  const double minSpacing = g.minSpacing();
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
        // The box about the (first) seed; every seed must lie in it (evolveSnake checks). It
        // grows where the contour reaches one of its faces (GrowBox below).
        VoxelBox box = snakeBox(g, request.segment.seedsMm.front(), kSnakeRoiHalfMm);
        VolumeI16 crop;
        bool whole = false;
        Dims rd;
        const auto setBox = [&](const VoxelBox& b) {
          box = b;
          whole = box.dims().voxelCount() == g.dims.voxelCount();
          crop = whole ? VolumeI16() : std::get<VolumeI16>(cropVolume(AnyVolume(ct), box));
          rd = box.dims();
        };
        setBox(box);
        const auto region = [&]() -> const VolumeI16& { return whole ? ct : crop; };
        int growths = 0;
        bool sawCoarse = false;  ///< this box's evolution had a coarse level
        // Every few iterations the contour so far goes to the slices (live evolution); here
        // the worker parks while paused, unwinds when the user accepts, and grows the box
        // when the contour reached one of its cut faces.
        const auto publish = [&](const seg::Mask& inside, int iteration) {
          auto copy = std::make_shared<const seg::Mask>(inside);
          const int factor = std::max<int>(1, int(std::lround(double(rd.x) / std::max<int64_t>(1, inside.dims().x))));
          {
            std::lock_guard lock(liveMutex_);
            if (factor == 1 && liveFactor_ > 1) coarse_ = live_;  // the coarse levels' last contour
            live_ = copy;
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
          // Grown from the coarse levels' contours (a restart is cheap there); at full
          // resolution only when there was no coarse level (a small box).
          sawCoarse = sawCoarse || factor > 1;
          if (!whole && growths < kSnakeRoiGrowths && (factor > 1 || !sawCoarse)) {
            const VoxelBox grown = growSnakeBox(box, inside, g, kSnakeRoiGrowMm);
            if (grown.lo != box.lo || grown.hi != box.hi) throw GrowBox{grown, copy};
          }
        };
        // What the UI shows for a contour kept before the end: on the scan's grid.
        const auto kept = [&](const seg::Mask& m, std::string note) {
          SnakeJobResult out;
          out.mask = paste(m.dims() == rd ? m : resampleNearest(m, region().geometry()), box, g);
          out.note = std::move(note);
          std::lock_guard lock(liveMutex_);
          out.iterations = liveIteration_;
          return out;
        };
        const auto boxNote = [&](const seg::Mask& m) {
          std::ostringstream n;
          if (growths > 0) n << "the box about the seed grew " << growths << (growths == 1 ? " time" : " times") << " (to " << boxSize(box, g) << ")";
          if (!whole && touchesCutFace(m, box, g.dims))
            n << (growths > 0 ? "; " : "") << "the contour reached the edge of its " << boxSize(box, g)
              << " box about the seed: seed again beyond it to extend";
          return n.str();
        };
        SnakeJobResult out;
        app::SegmentSettings settings = request.segment;
        for (;;) {
          try {
            app::SegmentationResult r = app::runSegmentation(region(), settings, progress, publish);
            out.iterations = r.info["snake"]["iterations"].get<int>();
            out.converged = r.info["snake"]["converged"].get<bool>();
            const bool settled = r.info["snake"].value("settled", false);
            std::ostringstream n;
            if (settled)
              n << "settled at iteration " << out.iterations << " (the inside changed by under "
                << 100 * seg::SnakeParams{}.settleFraction << " % over " << seg::SnakeParams{}.settleWindow << " iterations)";
            const std::string b = boxNote(r.mask);
            if (!b.empty()) n << (settled ? "; " : "") << b;
            out.note = n.str();
            out.mask = whole ? std::move(r.mask) : paste(r.mask, box, g);
          } catch (const GrowBox& grow) {
            // Go on from the contour reached, on the grown box (its coarse levels first).
            setBox(grow.box);
            ++growths;
            sawCoarse = false;
            std::printf("snake: box grown to %s at iteration %d of the 1/%d level\n", boxSize(box, g).c_str(),
                        liveIteration().first, liveIteration().second);
            std::fflush(stdout);
            auto start = std::make_shared<seg::Mask>(resampleNearest(*grow.contour, region().geometry()));
            {
              std::lock_guard lock(liveMutex_);
              coarse_ = grow.contour;  // what a cancel keeps until this box's coarse levels are done
            }
            settings.snakeStart = std::move(start);
            continue;
          } catch (const AcceptNow&) {
            std::shared_ptr<const seg::Mask> m;
            int factor = 1;
            {
              std::lock_guard lock(liveMutex_);
              m = live_;
              factor = liveFactor_;
            }
            if (!m) throw Cancelled();
            std::ostringstream n;
            n << "accepted the contour at iteration " << liveIteration().first
              << (factor > 1 ? " of the 1/" + std::to_string(factor) + " resolution level" : " at full resolution");
            const std::string b = factor == 1 ? boxNote(*m) : std::string();
            if (!b.empty()) n << "; " << b;
            out = kept(*m, n.str());
          } catch (const Cancelled&) {
            std::shared_ptr<const seg::Mask> m;
            {
              std::lock_guard lock(liveMutex_);
              m = coarse_;
            }
            if (!m) throw;  // cancelled before the coarse levels were done: nothing kept
            out = kept(*m, "cancelled at full resolution: kept the coarse contour (Ctrl+Z drops it)");
          }
          break;
        }
        if (seg::countVoxels(out.mask) == 0) out.error = snakeFoundNothingReason(ct, request.segment);
        return out;
      },
      "snake");
}

}  // namespace vellum::studio
