#include "export_job.hpp"

#include "vellum/core/error.hpp"
#include "vellum/render/gl_context.hpp"

namespace vellum::studio {

ExportJob::ExportJob(std::function<ExportInputs()> prepare) {
  work_ = std::async(std::launch::async, [this, prepare = std::move(prepare)] {
    const ExportInputs in = prepare();
    if (cancel_) throw Error("export cancelled");
    // Everything GL lives and dies on this thread, in its own context.
    auto context = render::GlContext::createHeadless();
    context->makeCurrent();
    animation::MovieRenderer movie(*context, in.volume, in.track, in.params,
                                   animation::MovieRigidity{in.bodies.get(), in.falloffMm, 0}, in.spec);
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
