// StudioApp: keyframe playback and the movie export (through animation::MovieRenderer, the
// code `vellum animate` runs; the export also writes the equivalent `vellum animate` command).
#include <GLFW/glfw3.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "app.hpp"
#include "deform_session.hpp"
#include "export_job.hpp"
#include "view3d.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/params.hpp"
#include "vellum/deformation/deform_params.hpp"
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
  animation::MovieSpec spec;
  const std::string o = out.string();
  const bool isDir = !o.empty() && (o.back() == '/' || out.extension().empty());
  (isDir ? spec.framesDir : spec.moviePath) = out;
  spec.fps = fps;
  spec.orbitDeg = orbitDeg;
  spec.settings = renderSettingsFor(scene_, width, height);
  // The keyframes beside the output, and the `vellum animate` line that renders the same frames.
  const fs::path keys = isDir ? out / "keyframes.json" : fs::path(o + ".keyframes.json");
  if (isDir) fs::create_directories(out);
  else if (out.has_parent_path()) fs::create_directories(out.parent_path());
  deformation::saveKeyframes(a.track, keys);
  std::ostringstream c;
  c.precision(10);
  auto q = [](const std::string& t) { return "'" + t + "'"; };
  c << "vellum animate " << q(scene_.volumePath.string()) << " --keyframes " << q(keys.string()) << " --out "
    << q(o) << " --fps " << fps << " --size " << width << "x" << height
    << params::cliArguments(render::renderSettingsTable(), spec.settings, {"width", "height"})
    << params::cliArguments(deformation::deformParamsTable(), a.engine);
  if (orbitDeg != 0) c << " --camera-orbit " << orbitDeg;
  const deformation::RigidBodies* bodies = deform_->bodies();
  if (bodies) {
    c << " --labels " << q(scene_.labelsPath.string()) << " --rigid-labels ";
    for (size_t i = 0; i < a.rigidLabels.size(); ++i) c << (i ? "," : "") << a.rigidLabels[i];
    c << " --rigid-falloff " << a.falloffMm;
  }
  animateCommand_ = c.str();
  a.playing = false;
  export_ = std::make_unique<ExportJob>(*context_, AnyVolume(scene_.ct), a.track, a.engine,
                                        animation::MovieRigidity{bodies, a.falloffMm, 0}, spec);
}

void StudioApp::cancelExport() { export_.reset(); }
bool StudioApp::exporting() const { return export_ != nullptr; }
std::pair<int, int> StudioApp::exportProgress() const {
  return export_ ? std::pair{export_->framesDone(), export_->frameCount()} : std::pair{0, 0};
}

}  // namespace vellum::studio
