#pragma once
// The 3D snake (segmentation::evolveSnake) from a seed clicked in a slice, on a worker
// thread with progress and cancel, like loading. The result is adopted by the UI thread as
// one label edit (one undo step).
//
// At real size (512² x 350) the snake runs on a box of kSnakeRoiHalfMm about the seed, not the
// whole scan: the speed image, the coarse levels and each live contour cost in proportion to
// the box (a limb), not to the table and the other leg. Where the coarse contour reaches a
// face of the box the box grows and the snake goes on from that contour (a foot is longer than
// the box). As in ITK-SNAP the user can pause it and accept the contour as it is; a cancel
// after the coarse levels keeps their contour.
#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "background_job.hpp"
#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/region.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/snake.hpp"

namespace vellum::studio {

struct SnakeRequest {
  VolumeI16 ct;  ///< a copy: the scene may change while the snake runs
  /// What `vellum segment --method snake` takes: seed, bubble radius, HU range, speed, weights.
  app::SegmentSettings segment;
  uint64_t volumeGeneration = 0;  ///< Scene::volumeGeneration when started
};

/// Half the side of the snake's box about the seed (mm): a limb's cross-section (a knee or a
/// thigh is 100-180 mm across) with room; clipped to the scan.
inline constexpr double kSnakeRoiHalfMm = 90;
/// Where the contour (at any level) reaches a face of the box that is not the scan's, the box
/// grows by this much on that side and the snake goes on from the contour it had: a foot is
/// longer than the box, a region may reach past it (at most kSnakeRoiGrowths times).
inline constexpr double kSnakeRoiGrowMm = 90;
inline constexpr int kSnakeRoiGrowths = 6;
/// (The snake stops as settled when its inside's volume no longer changes:
/// segmentation::SnakeParams::settleFraction, at every level.)

struct SnakeJobResult {
  /// "snake cancelled", the segmentation module's message, or why the snake found nothing
  std::string error;
  segmentation::Mask mask;  ///< on the scan's grid
  int iterations = 0;
  bool converged = false;
  uint64_t volumeGeneration = 0;
  /// What else the user should know: accepted before the end, the coarse contour kept on
  /// cancel, the contour reached the box's edge.
  std::string note;
};

/// The voxel box of half-side `halfMm` about `seedMm` on `g`, clipped to the grid.
VoxelBox snakeBox(const Geometry& g, const Vec3& seedMm, double halfMm);

/// `box` (on a scan of grid `g`) grown by `growMm` on the faces `m` reaches (a mask on the
/// box's voxels or a coarser grid over the same box) that are not faces of the scan; `box`
/// itself when there is none.
VoxelBox growSnakeBox(const VoxelBox& box, const segmentation::Mask& m, const Geometry& g, double growMm);

/// Why a snake from `request` found nothing, in the user's terms (the seed's HU against the
/// range, a bubble smaller than a voxel, a region thinner than the bubble).
std::string snakeFoundNothingReason(const VolumeI16& ct, const app::SegmentSettings& request);

/// The snake on a worker thread (BackgroundJob).
class SnakeJob {
 public:
  /// Starts the snake; false if one is already running.
  bool start(SnakeRequest request);
  bool busy() const { return job_.busy(); }
  /// Running, or finished with a result not taken yet.
  bool pending() const { return job_.busy() || job_.ready(); }
  std::pair<std::string, double> progress() const { return job_.progress(); }
  /// Cancel: stops; after the coarse levels their contour is the result (note says so).
  void cancel() {
    job_.cancel();
    wake_.notify_all();
  }
  /// Pause / resume the evolution (the worker parks at its next live contour).
  void setPaused(bool paused) {
    paused_ = paused;
    wake_.notify_all();
  }
  bool pauseRequested() const { return paused_; }
  /// True while the worker is parked by setPaused(true).
  bool parked() const { return parked_; }
  /// Stops and makes the contour shown now the result (resampled to the scan's grid).
  void acceptCurrent() {
    accept_ = true;
    wake_.notify_all();
  }
  /// The iteration (within its level) and the level's factor (1 = full resolution) of the
  /// newest live contour.
  std::pair<int, int> liveIteration() const {
    std::lock_guard lock(liveMutex_);
    return {liveIteration_, liveFactor_};
  }
  /// While the snake runs: its inside so far (on the grid of the level being evolved) and a
  /// counter that changes with each new contour; null when no snake runs.
  std::pair<std::shared_ptr<const segmentation::Mask>, uint64_t> live() const;
  /// The finished snake (or its error), once, stamped with the volume it ran on.
  std::optional<SnakeJobResult> take() {
    auto outcome = job_.take();
    if (outcome) outcome->volumeGeneration = generation_;
    return outcome;
  }

 private:
  uint64_t generation_ = 0;  ///< volumeGeneration of the running or last snake
  mutable std::mutex liveMutex_;
  std::shared_ptr<const segmentation::Mask> live_;
  uint64_t liveRevision_ = 0;
  int liveIteration_ = 0, liveFactor_ = 0;
  std::shared_ptr<const segmentation::Mask> coarse_;  ///< the last contour of a coarse level
  std::atomic<bool> paused_{false}, parked_{false}, accept_{false};
  std::mutex wakeMutex_;
  std::condition_variable wake_;
  BackgroundJob<SnakeJobResult> job_{"snake", [](const std::string& error) {
                                     SnakeJobResult o;
                                     o.error = error;
                                     return o;
                                   }};
};

}  // namespace vellum::studio
