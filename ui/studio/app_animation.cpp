// StudioApp: keyframe playback and the movie export: an app::AnimateRequest, rendered through
// animation::MovieRenderer with app::movieSpec (what `vellum animate` runs), and written beside
// the output as the equivalent `vellum animate` command (app::animateArguments).
#include <GLFW/glfw3.h>

#include <chrono>
#include <cmath>
#include <iostream>

#include "app.hpp"
#include "deform_session.hpp"
#include "export_job.hpp"
#include "view3d.hpp"
#include "vellum/app/animate_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/output_policy.hpp"
#include "vellum/deformation/point_files.hpp"
#include "window_context.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

void StudioApp::play(bool on) {
  Authoring& a = scene_.authoring;
  if (on && !a.active()) throw Error("nothing to play: place control points first");
  if (on && !a.timeS) a.timeS = keyframeStartS(a.track, a.keyframe);
  a.playing = on;
  a.touch();
}

void StudioApp::tickAnimation(double dtS) {
  if (export_) {
    try {
      export_->await(std::chrono::milliseconds(50));  // the frame waits: the export has the cores
      if (export_->step()) {
        const auto& r = export_->result();
        std::cout << "export: " << r.frames << " frames, deform " << r.deformMs / std::max(1, r.frames)
                  << " ms/frame, render " << r.renderMs / std::max(1, r.frames) << " ms/frame" << std::endl;
        export_.reset();
        view3d_->invalidate();
      }
    } catch (const std::exception& e) {
      export_.reset();
      exportError_ = e.what();
      showError(exportError_);
    }
  }
  Authoring& a = scene_.authoring;
  if (!a.playing || !a.active()) return;
  const double total = a.track.totalDurationS();
  double t = a.timeS.value_or(0) + dtS;
  if (t >= total) {
    if (a.track.loop && total > 0) {
      t = std::fmod(t, total);
    } else {
      t = total;
      a.playing = false;
    }
  }
  a.timeS = t;
  a.touch();
}

void StudioApp::followKeyframeCamera() {
  const Authoring& a = scene_.authoring;
  if (!a.active() || !a.timeS) return;  // only while playing or scrubbing
  if (const auto c = a.track.cameraAt(*a.timeS)) {
    render::Camera& cam = scene_.render.camera;
    cam.azimuthDeg = c->azimuthDeg;
    cam.elevationDeg = c->elevationDeg;
    cam.zoom = c->zoom;
    cam.panMm = c->panMm;
    if (c->fieldOfViewDeg) cam.fieldOfViewDeg = *c->fieldOfViewDeg;
  }
}

void StudioApp::startExport(const fs::path& out, double fps, int width, int height, double orbitDeg) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  if (export_) throw Error("an export is running; cancel it first");
  Authoring& a = scene_.authoring;
  if (!a.active()) throw Error("nothing to export: place control points first");
  a.track.validate();
  if (!(fps > 0 && fps <= 240)) throw Error("fps must be in (0, 240]");
  if (width < 16 || height < 16 || width > 4096 || height > 4096) throw Error("export size must be 16..4096");
  exportError_.clear();
  // The request `vellum animate` would run: its movie spec drives the export, and its
  // arguments are the command line written beside the output.
  app::AnimateRequest request;
  request.input = scene_.volumePath;
  request.output = out;
  request.fps = fps;
  request.orbitDeg = orbitDeg;
  request.settings = renderSettingsFor(scene_, width, height);
  request.engine.params = a.engine;
  request.engine.upsampling = scene_.view.deformedUpsampling;  // the live view's map kernel
  const deformation::RigidBodies* bodies = deform_.session().bodies();
  if (bodies) {
    request.engine.labels = scene_.labelsPath.string();
    request.engine.rigidIds = a.rigidLabels;
    request.engine.rigidFalloffMm = a.falloffMm;
    request.engine.fixedIds = a.fixed.ids;  // the joint tool's fixed regions (the bodies hold them)
    for (const auto& b : a.fixed.boxesMm) request.engine.fixedBoxMm.insert(request.engine.fixedBoxMm.end(), b.begin(), b.end());
  }
  const animation::MovieSpec spec = app::movieSpec(request);
  // The keyframes beside the output.
  const bool isDir = !spec.framesDir.empty();
  request.keyframes = isDir ? spec.framesDir / "keyframes.json" : fs::path(out.string() + ".keyframes.json");
  // The output policy, as `vellum animate` follows it: never an input, never a folder Vellum
  // did not write. The frames are written into their (marked) folder as they are made.
  io::OutputPlan()
      .input(scene_.volumePath)
      .input(request.engine.labels, "the label map")
      .output(spec.moviePath, "the movie")
      .json(isDir ? fs::path() : request.keyframes, "the keyframes file")
      .check();
  if (isDir) io::prepareFolderInPlace(spec.framesDir, io::FolderKind::Frames);
  else if (out.has_parent_path()) fs::create_directories(out.parent_path());
  deformation::saveKeyframes(a.track, request.keyframes);
  animateCommand_ = "vellum animate " + app::animateArguments(request);
  a.playing = false;
  export_ = std::make_unique<ExportJob>(AnyVolume(scene_.ct), a.track, a.engine, deform_.session().sharedBodies(), a.falloffMm,
                                        spec);
}

void StudioApp::cancelExport() { export_.reset(); }
bool StudioApp::exporting() const { return export_ != nullptr; }
std::pair<int, int> StudioApp::exportProgress() const {
  return export_ ? std::pair{export_->framesDone(), export_->frameCount()} : std::pair{0, 0};
}

}  // namespace vellum::studio
