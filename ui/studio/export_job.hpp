#pragma once
// The studio's movie export: animation::MovieRenderer (the code `vellum animate` runs) driven
// one frame per window frame, so the window shows progress and can cancel.
#include <memory>
#include <string>

#include "vellum/animation/movie.hpp"

namespace vellum::studio {

class ExportJob {
 public:
  ExportJob(render::GlContext& context, const AnyVolume& volume, const deformation::KeyframeTrack& track,
            const deformation::DeformParams& params, animation::MovieRigidity rigidity, animation::MovieSpec spec)
      : movie_(context, volume, track, params, rigidity, std::move(spec)) {}
  /// Renders the next frame; true when the export has finished (then the movie is closed).
  bool step() {
    if (!movie_.done()) movie_.renderNext();
    if (movie_.done() && !finished_) {
      result_ = movie_.finish();
      finished_ = true;
    }
    return finished_;
  }
  int framesDone() const { return movie_.framesDone(); }
  int frameCount() const { return movie_.frameCount(); }
  const animation::MovieResult& result() const { return result_; }

 private:
  animation::MovieRenderer movie_;
  animation::MovieResult result_;
  bool finished_ = false;
};

}  // namespace vellum::studio
