#pragma once
// The studio's movie export: animation::MovieRenderer (the code `vellum animate` and `vellum
// pose --movie` run) on a worker thread with its own headless GL context, as the command line
// renders, so the window stays interactive, shows the progress and can cancel between frames.
#include <atomic>
#include <chrono>
#include <functional>
#include <future>
#include <memory>

#include "vellum/animation/movie.hpp"

namespace vellum::studio {

/// What an export renders: MovieRenderer's inputs, made on the worker (the movie's grown box
/// pads the CT and builds its bodies there: seconds on a real scan).
struct ExportInputs {
  AnyVolume volume;
  deformation::KeyframeTrack track;
  deformation::DeformParams params;
  std::shared_ptr<const deformation::RigidBodies> bodies;  ///< may be null
  double falloffMm = 10;
  animation::MovieSpec spec;
  std::shared_ptr<const void> keep;  ///< what spec's callbacks read (the twist frames), kept alive
};

class ExportJob {
 public:
  /// Starts at once: `prepare` on the worker, then the frames.
  explicit ExportJob(std::function<ExportInputs()> prepare);
  /// Cancels (the frame being rendered finishes first) and waits; an unfinished movie is
  /// abandoned (nothing is left at its path).
  ~ExportJob();
  ExportJob(const ExportJob&) = delete;
  ExportJob& operator=(const ExportJob&) = delete;

  /// True when the export has finished (then the movie is closed); rethrows its error.
  bool step();
  /// Blocks up to `timeout` for the export to finish (the window's frames wait here so the
  /// export has the cores).
  void await(std::chrono::milliseconds timeout) const {
    if (work_.valid()) work_.wait_for(timeout);
  }
  int framesDone() const { return done_; }
  int frameCount() const { return count_; }  ///< 0 while the inputs are prepared
  const animation::MovieResult& result() const { return result_; }

 private:
  std::atomic<bool> cancel_{false};
  std::atomic<int> done_{0}, count_{0};
  std::future<animation::MovieResult> work_;
  animation::MovieResult result_;
  bool finished_ = false;
};

}  // namespace vellum::studio
