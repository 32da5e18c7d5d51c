// DeformController (see deform_controller.hpp): the deformation session and the joint tool
// with the commands that configure them, playback and the movie export.
#include "deform_controller.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>

#include <imgui.h>

#include "app.hpp"
#include "deform_session.hpp"
#include "export_job.hpp"
#include "joint_tool.hpp"
#include "view3d.hpp"
#include "vellum/app/animate_pipeline.hpp"
#include "vellum/app/pose_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/io/output_policy.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

DeformController::DeformController(StudioApp& app)
    : app_(app), session_(std::make_unique<DeformSession>()), joints_(std::make_unique<JointTool>()) {}

// The members' destructors wait for their workers (the session's read the scene's CT, which
// StudioApp destroys after this controller). The export's GL objects go with cancelExport(),
// which StudioApp calls before its context goes.
DeformController::~DeformController() = default;

bool DeformController::updateMap(bool interacting, bool waitForExact) {
  const Scene& scene = app_.scene();
  interacting = interacting || joints_->dragging;
  bool updated = session_->update(scene, interacting);
  if (session_->exactSolveRunning() && waitForExact) {
    // The exact map is on the worker (just started, or still running): wait for it a little
    // (40 ms) rather than draw a frame that takes cores from it and that the map would
    // replace; short enough that the window still draws several frames a second during a
    // solve of seconds on a real scan.
    session_->awaitSolve(std::chrono::milliseconds(40));
    updated = session_->update(scene, interacting) || updated;
  }
  return updated;
}

void DeformController::poll() { joints_->poll(app_); }

bool DeformController::busy() const { return session_->busy() || joints_->busy(); }

bool DeformController::dragging() const { return joints_->dragging; }

bool DeformController::click(const Pane& pane, double x, double y) {
  JointTool& jt = *joints_;
  if (jt.pick == JointPick::None) return false;
  const Scene& scene = app_.scene();
  std::optional<Vec3> source;
  if (pane.is3d()) {  // the visible surface, back to the undeformed volume the labels live in
    const deformation::MapSampler* map = session_->sampler();
    const auto p = pickSurface(scene, int(pane.rect.w), int(pane.rect.h), x - pane.rect.x, y - pane.rect.y, map);
    if (p) source = map ? map->sourceMm(*p) : p;
  } else {
    source = app_.sliceSourceMm(app_.planeOf(pane).toMm(x - pane.rect.x, y - pane.rect.y));
  }
  if (!source) {
    app_.notify("nothing under the pointer");
    return true;
  }
  const JointPick what = jt.pick;
  jt.pick = JointPick::None;
  if (what == JointPick::AxisA || what == JointPick::AxisB) {
    (what == JointPick::AxisA ? jt.draftAxisA : jt.draftAxisB) = *source;
    return true;
  }
  const Geometry& g = scene.labels.geometry();
  const Vec3 ijk = g.physicalToIndex(*source);
  const int64_t i = std::llround(ijk.x), j = std::llround(ijk.y), k = std::llround(ijk.z);
  const uint16_t id = g.contains(i, j, k) ? scene.labels(i, j, k) : 0;
  if (id == 0) {
    app_.notify("no label under the pointer: click on a bone");
    return true;
  }
  std::vector<uint16_t>& ids = what == JointPick::Parent ? jt.draftParent : jt.draftChild;
  if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
  return true;
}

void DeformController::draw(const Pane& pane) {
  using namespace deformation;
  const JointTool& jt = *joints_;
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  dl->PushClipRect({pane.rect.x, pane.rect.y}, {pane.rect.x + pane.rect.w, pane.rect.y + pane.rect.h}, true);
  const auto at = [&](const Vec3& mm) -> std::optional<ImVec2> {
    const auto p = app_.points().pointInPane(pane, mm);
    if (!p) return std::nullopt;
    return ImVec2{float(p->first), float(p->second)};
  };
  // Axes as shown: a joint's axis moves with its proximal joint (chains), at the angles of the
  // time shown; drawn 30 mm each side of its centre.
  const Pose& pose = jt.pose;
  if (jt.ready() && !pose.angles.keyframes.empty()) {
    const Authoring& a = app_.scene().authoring;
    const double t = a.timeS.value_or(keyframeStartS(pose.angles, std::clamp(a.keyframe, 0, int(pose.angles.keyframes.size()) - 1)));
    const std::vector<RigidTransform> moved = jointTransforms(pose, pose.anglesAt(t));
    const std::vector<double> angles = pose.anglesAt(t);
    for (size_t j = 0; j < pose.joints.size(); ++j) {
      const Joint& joint = pose.joints[j];
      const RigidTransform m = joint.proximal < 0 ? RigidTransform{} : moved[size_t(joint.proximal)];
      const Vec3 c = m.apply((joint.axisA + joint.axisB) * 0.5);
      const Vec3 d = normalized(m.rotation * (joint.axisB - joint.axisA));
      const auto p0 = at(c - d * 30.0), p1 = at(c + d * 30.0), pc = at(c);
      if (!p0 || !p1 || !pc) continue;
      const bool sel = int(j) == jt.selected;
      const ImU32 col = sel ? IM_COL32(255, 220, 40, 255) : IM_COL32(255, 150, 40, 220);
      dl->AddLine(*p0, *p1, IM_COL32(0, 0, 0, 200), sel ? 5.f : 4.f);
      dl->AddLine(*p0, *p1, col, sel ? 3.f : 2.f);
      dl->AddCircleFilled(*pc, sel ? 5.f : 4.f, col);
      char text[96];
      std::snprintf(text, sizeof text, "%s %.1f deg", joint.name.c_str(), angles[j]);
      dl->AddText({pc->x + 8, pc->y - 18}, IM_COL32(0, 0, 0, 255), text);
      dl->AddText({pc->x + 7, pc->y - 19}, col, text);
    }
  }
  for (const auto& p : {jt.draftAxisA, jt.draftAxisB})
    if (p)
      if (const auto q = at(*p)) dl->AddCircle(*q, 6.f, IM_COL32(120, 220, 255, 255), 12, 2.f);
  if (jt.draftAxisA && jt.draftAxisB)
    if (const auto q0 = at(*jt.draftAxisA), q1 = at(*jt.draftAxisB); q0 && q1)
      dl->AddLine(*q0, *q1, IM_COL32(120, 220, 255, 255), 2.f);
  dl->PopClipRect();
}

void DeformController::setRigid(std::vector<uint16_t> labels, double falloffMm, const std::string& description,
                                std::optional<std::pair<std::vector<uint16_t>, double>> before) {
  Authoring& a = app_.scene().authoring;
  // With joints every bone of the pose is rigid (JointTool::apply): another choice would be
  // lost at the next angle; the falloff stays the user's.
  if (a.joints && labels != a.rigidLabels)
    throw Error("the rigid bones are the joints' bones while joints exist (Joints panel: parent, child and "
                "fixed labels)");
  TrackEdit e;
  e.description = description;
  e.before = e.after = a.track;
  e.keyframeBefore = e.keyframeAfter = a.keyframe;
  e.engineBefore = e.engineAfter = a.engine;
  e.rigidBefore = before ? TrackEdit::Rigid{before->first, before->second} : TrackEdit::Rigid{a.rigidLabels, a.falloffMm};
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  e.rigidAfter = TrackEdit::Rigid{labels, falloffMm};
  a.rigidLabels = std::move(labels);
  a.falloffMm = falloffMm;
  a.touch();
  app_.undoStack().push(std::move(e));
}

void DeformController::pushPoseEdit(const std::string& description, deformation::Pose before, int keyframeBefore) {
  PoseEdit e;
  e.description = description;
  e.before = std::move(before);
  e.after = joints_->pose;
  e.keyframeBefore = keyframeBefore;
  e.keyframeAfter = app_.scene().authoring.keyframe;
  app_.undoStack().push(std::move(e));  // an edit that changed nothing is dropped
}

void DeformController::restorePose(const deformation::Pose& pose, int keyframe) {
  joints_->restore(app_, pose, keyframe);
}

// ---- playback and the movie export: an app::AnimateRequest, rendered through
// animation::MovieRenderer with app::movieSpec (what `vellum animate` runs), and written beside
// the output as the equivalent `vellum animate` command (app::animateArguments); with the joint
// tool's twist map, the `vellum pose --movie` command (app::poseArguments) and its frames.

void DeformController::play(bool on) {
  Authoring& a = app_.scene().authoring;
  if (on && !a.active()) throw Error("nothing to play: place control points first");
  if (on && !a.timeS) a.timeS = keyframeStartS(a.track, a.keyframe);
  a.playing = on;
  a.touch();
}

void DeformController::tick(double dtS) {
  if (export_) {
    try {
      export_->await(std::chrono::milliseconds(50));  // the frame waits: the export has the cores
      if (export_->step()) {
        const auto& r = export_->result();
        std::cout << "export: " << r.frames << " frames, deform " << r.deformMs / std::max(1, r.frames)
                  << " ms/frame, render " << r.renderMs / std::max(1, r.frames) << " ms/frame" << std::endl;
        export_.reset();
        app_.invalidate3d();
      }
    } catch (const std::exception& e) {
      export_.reset();
      exportError_ = e.what();
      app_.showError(exportError_);
    }
  }
  Authoring& a = app_.scene().authoring;
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

void DeformController::followCamera() {
  Scene& scene = app_.scene();
  const Authoring& a = scene.authoring;
  if (!a.active() || !a.timeS) return;  // only while playing or scrubbing
  if (const auto c = a.track.cameraAt(*a.timeS)) {
    render::Camera& cam = scene.render.camera;
    cam.azimuthDeg = c->azimuthDeg;
    cam.elevationDeg = c->elevationDeg;
    cam.zoom = c->zoom;
    cam.panMm = c->panMm;
    if (c->fieldOfViewDeg) cam.fieldOfViewDeg = *c->fieldOfViewDeg;
  }
}

void DeformController::startExport(const fs::path& out, double fps, int width, int height, double orbitDeg,
                                   double padMm) {
  Scene& scene = app_.scene();
  if (!scene.hasVolume()) throw Error("no volume is open");
  if (export_) throw Error("an export is running; cancel it first");
  Authoring& a = scene.authoring;
  if (!a.active()) throw Error("nothing to export: place control points first");
  a.track.validate();
  if (!(fps > 0 && fps <= 240)) throw Error("fps must be in (0, 240]");
  if (width < 16 || height < 16 || width > 4096 || height > 4096) throw Error("export size must be 16..4096");
  exportError_.clear();
  // The request the command line would run: its movie spec drives the export, and its
  // arguments are the command line written beside the output.
  app::AnimateRequest request;
  request.input = scene.volumePath;
  request.output = out;
  request.fps = fps;
  request.orbitDeg = orbitDeg;
  request.padMm = padMm;
  request.settings = renderSettingsFor(scene, width, height);
  request.engine.params = a.engine;
  request.engine.upsampling = scene.view.deformedUpsampling;  // the live view's map kernel
  params::validate(app::animateRequestTable(), request);  // fps, orbit, pad_mm in their ranges
  const animation::MovieSpec spec = app::movieSpec(request);
  const bool isDir = !spec.framesDir.empty();
  const JointTool& jt = *joints_;
  // The joint tool's twist map: the movie `vellum pose --movie` makes (its twist frames on its
  // grown box); else the authored track through the MLS engine, as `vellum animate`.
  if (a.pose && jt.ready() && jt.twist()) {
    app::PoseRequest pose;
    pose.input = scene.volumePath;
    pose.labels = scene.labelsPath;
    pose.pose = isDir ? spec.framesDir / "pose.json" : fs::path(out.string() + ".pose.json");
    pose.movie = out;
    pose.movieSettings = request;
    pose.padMm = padMm;
    pose.options = jt.options;
    pose.map = jt.map;
    pose.engine.params = a.engine;
    pose.engine.upsampling = request.engine.upsampling;
    pose.engine.rigidFalloffMm = a.falloffMm;
    prepareExportFolder(out, spec, isDir ? fs::path() : pose.pose, "the pose file");
    deformation::savePose(jt.pose, pose.pose);
    exportCommand_ = "vellum pose " + app::poseArguments(pose);
    a.playing = false;
    export_ = std::make_unique<ExportJob>(
        [ct = AnyVolume(scene.ct), labels = scene.labels, p = jt.pose, samples = *jt.samples(), options = jt.options,
         engine = app::poseEngine(jt.pose, pose.engine), padMm, spec = animation::MovieSpec(spec)]() mutable {
          const deformation::KeyframeTrack track = deformation::poseTrack(samples, p, options.maxStepDeg);
          const deformation::DeformParams params = engine.resolved(std::nullopt);
          app::MovieBox box = app::movieBox(std::move(ct), track, padMm, params.controlScale, spec.settings.camera);
          auto bodies = std::make_shared<const deformation::RigidBodies>(engine.rigidBodies(labels, box.box.grid));
          auto frames = app::poseTwistFrames(p, labels, engine, options, box.box.grid);
          spec.settings.camera = box.camera;
          spec.frameMaps = app::twistFrameMaps(frames);
          return ExportInputs{std::move(box.volume), track, params, std::move(bodies), engine.rigidFalloffMm, spec, frames};
        });
    return;
  }
  const deformation::RigidBodies* bodies = session_->bodies();
  if (bodies) {
    request.engine.labels = scene.labelsPath.string();
    request.engine.rigidIds = a.rigidLabels;
    request.engine.rigidFalloffMm = a.falloffMm;
    request.engine.fixedIds = a.fixed.ids;  // the joint tool's fixed regions (the bodies hold them)
    for (const auto& b : a.fixed.boxesMm) request.engine.fixedBoxMm.insert(request.engine.fixedBoxMm.end(), b.begin(), b.end());
  }
  // The keyframes beside the output.
  request.keyframes = isDir ? spec.framesDir / "keyframes.json" : fs::path(out.string() + ".keyframes.json");
  prepareExportFolder(out, spec, isDir ? fs::path() : request.keyframes, "the keyframes file");
  deformation::saveKeyframes(a.track, request.keyframes);
  exportCommand_ = "vellum animate " + app::animateArguments(request);
  a.playing = false;
  // The live view's bodies on the input's grid; a grown box builds them again on its grid.
  std::optional<LabelVolume> labels;
  if (bodies && padMm != 0) labels = scene.labels;
  export_ = std::make_unique<ExportJob>([ct = AnyVolume(scene.ct), track = a.track, engine = request.engine,
                                         shown = session_->sharedBodies(), labels = std::move(labels), padMm,
                                         spec = animation::MovieSpec(spec)]() mutable {
    const deformation::DeformParams params = engine.resolved(std::nullopt);
    app::MovieBox box = app::movieBox(std::move(ct), track, padMm, params.controlScale, spec.settings.camera);
    std::shared_ptr<const deformation::RigidBodies> bodies = shown;
    if (shown && !box.box.pad.none())
      bodies = std::make_shared<const deformation::RigidBodies>(engine.rigidBodies(*labels, box.box.grid));
    spec.settings.camera = box.camera;
    return ExportInputs{std::move(box.volume), track, engine.params, std::move(bodies), engine.rigidFalloffMm, spec, {}};
  });
}

void DeformController::prepareExportFolder(const fs::path& out, const animation::MovieSpec& spec,
                                           const fs::path& besideJson, const char* besideWhat) {
  // The output policy, as the command line follows it: never an input, never a folder Vellum
  // did not write. The frames are written into their (marked) folder as they are made.
  const Scene& scene = app_.scene();
  io::OutputPlan()
      .input(scene.volumePath)
      .input(scene.labelsPath, "the label map")
      .output(spec.moviePath, "the movie")
      .json(besideJson, besideWhat)
      .check();
  if (!spec.framesDir.empty()) io::prepareFolderInPlace(spec.framesDir, io::FolderKind::Frames);
  else if (out.has_parent_path()) fs::create_directories(out.parent_path());
}

void DeformController::cancelExport() { export_.reset(); }
std::pair<int, int> DeformController::exportProgress() const {
  return export_ ? std::pair{export_->framesDone(), export_->frameCount()} : std::pair{0, 0};
}

}  // namespace vellum::studio
