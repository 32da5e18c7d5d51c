#include "export_job.hpp"

#include "vellum/core/error.hpp"
#include "vellum/render/gl_context.hpp"

namespace vellum::studio {

ExportJob::ExportJob(AnyVolume volume, deformation::KeyframeTrack track, deformation::DeformParams params,
                     std::shared_ptr<const deformation::RigidBodies> bodies, double falloffMm,
                     animation::MovieSpec spec) {
  work_ = std::async(std::launch::async, [this, volume = std::move(volume), track = std::move(track),
                                          params, bodies = std::move(bodies), falloffMm, spec = std::move(spec)] {
    // Everything GL lives and dies on this thread, in its own context.
    auto context = render::GlContext::createHeadless();
    context->makeCurrent();
    animation::MovieRenderer movie(*context, volume, track, params,
                                   animation::MovieRigidity{bodies.get(), falloffMm, 0}, spec);
    count_ = movie.frameCount();
    while (!movie.done()) {
      if (cancel_) throw Error("export cancelled");
      movie.renderNext();
      done_ = movie.framesDone();
    }
    return movie.finish();
  });
}

ExportJob::~ExportJob() {
  cancel_ = true;
  if (work_.valid()) work_.wait();
}

bool ExportJob::step() {
  if (finished_) return true;
  if (!work_.valid() || work_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return false;
  result_ = work_.get();  // rethrows the worker's error
  finished_ = true;
  return true;
}

}  // namespace vellum::studio
