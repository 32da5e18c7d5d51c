// The joint tool (see joint_tool.hpp): the pose, its preparation on a worker, the authoring
// state it makes, picking bones and axis points in the views, drawing the axes.
#include "joint_tool.hpp"

#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "app.hpp"
#include "deform_controller.hpp"
#include "deform_session.hpp"
#include "view3d.hpp"
#include "vellum/app/pose_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/io/output_policy.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
using namespace vellum::deformation;

namespace {
template <class T>
bool finished(const std::future<T>& f) {
  return f.valid() && f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

int clampKeyframe(const Pose& pose, int k) {
  return std::clamp(k, 0, std::max(0, int(pose.angles.keyframes.size()) - 1));
}
}  // namespace

JointTool::~JointTool() {
  cancel();
  if (work_.valid()) work_.wait();
}

void JointTool::cancel() {
  if (progress_) progress_->cancel();
}

double JointTool::keyframeTime(const StudioApp& app) const {
  return keyframeStartS(pose.angles, clampKeyframe(pose, const_cast<StudioApp&>(app).scene().authoring.keyframe));
}

void JointTool::prepare(StudioApp& app) {
  cancel();
  if (work_.valid()) work_.wait(), work_ = {};
  error_.clear();
  samples_.reset();
  Scene& scene = app.scene();
  publish(app);
  if (pose.joints.empty()) {  // nothing posed: the authoring state is the user's again
    scene.authoring.pose.reset();
    scene.authoring.fixed = {};
    scene.authoring.touch();
    return;
  }
  if (!scene.hasVolume() || scene.labels.ids().empty() || !(scene.labels.geometry().dims == scene.ct.geometry().dims))
    throw Error("the joint tool needs a label map on the volume's grid (the bones' ids)");
  progress_ = std::make_shared<Progress>();
  started_ = std::chrono::steady_clock::now();
  generation_ = scene.volumeGeneration;
  // A copy of the labels: painting may go on while the axes and points are made. The copy
  // (the size of the CT) is made on the task queue's worker, not on the UI thread; the pose
  // code's own functions (`vellum pose` runs the same), one stage each; cancel between them.
  using Copy = std::shared_ptr<const LabelVolume>;
  auto promise = std::make_shared<std::promise<Copy>>();
  std::future<Copy> copy = promise->get_future();
  if (!app.readSceneOnWorker("copying the labels for the joint tool", [promise](const Scene& s) {
        promise->set_value(std::make_shared<const LabelVolume>(s.labels));
      }))
    promise->set_value(std::make_shared<const LabelVolume>(scene.labels));  // a stroke runs: here
  work_ = std::async(std::launch::async, [p = pose, copy = std::move(copy), o = options, progress = progress_]() mutable {
    Copy held;
    try {
      held = copy.get();
    } catch (const std::future_error&) {  // the copy's task was dropped (cancelled)
      throw Cancelled();
    }
    const LabelVolume& labels = *held;
    Prepared r{p, nullptr};
    progress->begin("joint axes", 2);
    estimateAxes(r.pose, labels, o.contactMm, *progress);  // cancellable within its stages
    progress->advance();
    progress->checkCancelled();
    r.samples = std::make_shared<const PoseSamples>(poseSamples(r.pose, labels, o));
    progress->advance();
    progress->end();
    return r;
  });
}

void JointTool::poll(StudioApp& app) {
  if (samples_ && app.scene().volumeGeneration != generation_ && !busy()) {
    // Another volume was opened: the samples belong to the old label map; the pose (ids,
    // axes, angles) stays and is prepared again on the new one.
    samples_.reset();
    try {
      prepare(app);
    } catch (const std::exception& e) {
      error_ = e.what();
      generation_ = app.scene().volumeGeneration;  // asked once per volume
    }
  }
  if (!finished(work_)) return;
  try {
    Prepared r = work_.get();
    // The angles may have changed meanwhile: only the axes and the samples are taken.
    for (size_t j = 0; j < pose.joints.size() && j < r.pose.joints.size(); ++j) {
      pose.joints[j].axisA = r.pose.joints[j].axisA;
      pose.joints[j].axisB = r.pose.joints[j].axisB;
    }
    samples_ = std::move(r.samples);
    apply(app);
    std::cout << "joint tool: " << pose.joints.size() << " joints, " << samples_->sources.size() << " points in "
              << std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started_).count()
              << " ms (axes and points, on a worker)" << std::endl;
  } catch (const Cancelled&) {
    error_ = "cancelled";
  } catch (const std::exception& e) {
    error_ = e.what();
    app.notify(std::string("joint tool: ") + e.what());
  }
  work_ = {};
}

void JointTool::publish(StudioApp& app) const {
  app.scene().authoring.joints = pose.joints.empty() ? nullptr : std::make_shared<const Pose>(pose);
}

void JointTool::apply(StudioApp& app) const {
  publish(app);
  if (!samples_) return;
  Authoring& a = app.scene().authoring;
  KeyframeTrack t;
  t.interpolation = pose.angles.interpolation;
  t.loop = pose.angles.loop;
  for (const Keyframe& k : pose.angles.keyframes) {
    std::vector<double> angles;
    for (const ControlPoint& p : k.points) angles.push_back(p.source.x);
    Keyframe kf;
    kf.durationS = k.durationS;
    kf.points = posedPoints(*samples_, pose, angles);
    t.keyframes.push_back(std::move(kf));
  }
  a.track = std::move(t);
  a.keyframe = clampKeyframe(pose, a.keyframe);
  a.selected = -1;
  // Every bone of the pose is one rigid body per id (`vellum pose`'s engine), the fixed
  // regions stay, and the bones take their joints' transforms (exact bones).
  a.rigidLabels.clear();
  for (uint16_t id : pose.boneIds())
    if (!std::binary_search(pose.fixed.ids.begin(), pose.fixed.ids.end(), id)) a.rigidLabels.push_back(id);
  a.fixed = pose.fixed;
  // The pose's generated points are hundreds (a lattice on every bone): with density-aware
  // weights each casts rays for its own rho field (minutes on a real scan, measured: 979
  // points on the cropped feet). `vellum pose`'s engine has them off; so does the tool when
  // it takes over the track (the written `vellum pose` line names the engine either way).
  if (!a.pose) a.engine.density.enabled = false;
  // The map in effect travels with the pose the session reads ("twist": DeformSession solves
  // the exact map as the twist map; anything else: the MLS engine).
  Pose shown = pose;
  shown.map = twist() ? "twist" : "mls";
  a.pose = std::make_shared<const Pose>(std::move(shown));
  a.touch();
}

void JointTool::setMap(StudioApp& app, app::PoseMap choice) {
  map = choice;
  apply(app);
}

void JointTool::addDraftJoint(StudioApp& app) {
  if (draftParent.empty() || draftChild.empty()) throw Error("pick the parent and the child bone first");
  for (const Joint& j : pose.joints)
    if (j.name == draftName) throw Error("a joint is already named \"" + draftName + "\"");
  Pose next = pose;
  Joint joint;
  joint.name = draftName;
  joint.parent = draftParent;
  joint.child = draftChild;
  std::sort(joint.parent.begin(), joint.parent.end());
  std::sort(joint.child.begin(), joint.child.end());
  if (draftAxisA && draftAxisB && draftAxisIsHint) {
    joint.estimateAxis = joint.hasAxisHint = true;  // estimateAxes() places it on the worker
    joint.hintA = joint.axisA = *draftAxisA;
    joint.hintB = joint.axisB = *draftAxisB;        // also the placeholder linkJoints() checks
  } else if (draftAxisA && draftAxisB) {
    joint.axisA = *draftAxisA;
    joint.axisB = *draftAxisB;
  } else {
    joint.estimateAxis = true;  // estimateAxes() fills it on the worker
    joint.axisA = {0, 0, 0};
    joint.axisB = {1, 0, 0};  // linkJoints() checks axes: a placeholder until estimated
  }
  next.joints.push_back(joint);
  if (next.angles.keyframes.empty()) next.angles.keyframes.push_back(Keyframe{});
  for (Keyframe& k : next.angles.keyframes) k.points.push_back({{0, 0, 0}, {0, 0, 0}, {}});
  linkJoints(next);  // Error: a bone moved twice, a cycle, a child fixed, a degenerate axis
  const Pose before = std::exchange(pose, std::move(next));
  app.deform().pushPoseEdit("add joint " + joint.name, before, app.scene().authoring.keyframe);
  selected = int(pose.joints.size()) - 1;
  draftParent.clear();
  draftChild.clear();
  draftAxisA.reset();
  draftAxisB.reset();
  draftName = "joint" + std::to_string(pose.joints.size() + 1);
  prepare(app);
}

void JointTool::removeJoint(StudioApp& app, int index) {
  if (index < 0 || index >= int(pose.joints.size())) throw Error("no joint " + std::to_string(index));
  const Pose before = pose;
  pose.joints.erase(pose.joints.begin() + index);
  for (Keyframe& k : pose.angles.keyframes)
    if (index < int(k.points.size())) k.points.erase(k.points.begin() + index);
  if (pose.joints.empty()) pose.angles.keyframes.clear();
  for (Joint& j : pose.joints) j.proximal = -1;
  linkJoints(pose);
  selected = std::clamp(selected, 0, std::max(0, int(pose.joints.size()) - 1));
  app.deform().pushPoseEdit("remove joint " + before.joints[size_t(index)].name, before, app.scene().authoring.keyframe);
  prepare(app);
}

void JointTool::setFixed(StudioApp& app, FixedRegions fixed) {
  std::sort(fixed.ids.begin(), fixed.ids.end());
  fixed.ids.erase(std::unique(fixed.ids.begin(), fixed.ids.end()), fixed.ids.end());
  Pose next = pose;
  next.fixed = std::move(fixed);
  for (Joint& j : next.joints) j.proximal = -1;
  linkJoints(next);  // a child bone fixed is refused
  const Pose before = std::exchange(pose, std::move(next));
  app.deform().pushPoseEdit("fixed regions", before, app.scene().authoring.keyframe);
  prepare(app);
}

double JointTool::angle(const StudioApp& app, int index) const {
  if (index < 0 || index >= int(pose.joints.size()) || pose.angles.keyframes.empty()) return 0;
  const int k = clampKeyframe(pose, const_cast<StudioApp&>(app).scene().authoring.keyframe);
  return pose.angles.keyframes[size_t(k)].points[size_t(index)].source.x;
}

void JointTool::setAngle(StudioApp& app, int index, double deg) {
  if (index < 0 || index >= int(pose.joints.size())) throw Error("no joint " + std::to_string(index));
  if (!(std::abs(deg) <= 360)) throw Error("a joint angle must be in -360..360 degrees");
  Authoring& a = app.scene().authoring;
  const int k = clampKeyframe(pose, a.keyframe);
  const Pose before = pose;
  ControlPoint& p = pose.angles.keyframes[size_t(k)].points[size_t(index)];
  p.source.x = p.target.x = deg;
  a.timeS.reset();  // the edited keyframe is shown
  a.playing = false;
  // One undo step per call; during a slider drag the drag's end makes the one step.
  if (!angleDragBefore_) app.deform().pushPoseEdit("angle " + pose.joints[size_t(index)].name, before, a.keyframe);
  apply(app);
}

void JointTool::addKeyframe(StudioApp& app) {
  if (pose.angles.keyframes.empty()) throw Error("add a joint first");
  Authoring& a = app.scene().authoring;
  const int k = clampKeyframe(pose, a.keyframe);
  const Pose before = pose;
  const int keyframeBefore = a.keyframe;
  pose.angles.keyframes.insert(pose.angles.keyframes.begin() + k + 1, pose.angles.keyframes[size_t(k)]);
  a.keyframe = k + 1;
  a.timeS.reset();
  app.deform().pushPoseEdit("add pose keyframe", before, keyframeBefore);
  apply(app);
}

const char* JointTool::generatedPointsNote() {
  return "the control points come from the joints: they follow the bones, so they are not placed, added, "
         "deleted or moved here; turn a joint's angle in the Joints panel, or remove the joints to place "
         "points by hand";
}

void JointTool::editTrack(StudioApp& app, const std::string& description, const std::function<void(Authoring&)>& fn) {
  if (pose.angles.keyframes.empty()) throw Error("add a joint first");
  Authoring& a = app.scene().authoring;
  // The same edit on a stand-in whose track is the pose's angles: a keyframe copied, deleted,
  // moved or retimed there is the same keyframe of the posed track (apply() makes one from the
  // other keyframe for keyframe).
  Authoring probe;
  probe.track = pose.angles;
  probe.keyframe = clampKeyframe(pose, a.keyframe);
  probe.timeS = a.timeS;  // "add keyframe" while scrubbing copies the angles in between
  fn(probe);
  if (probe.track.keyframes.empty()) throw Error("a pose keeps at least one keyframe");
  for (const Keyframe& k : probe.track.keyframes) {
    if (k.points.size() != pose.joints.size()) throw Error(generatedPointsNote());
    if (k.camera) throw Error("a keyframe camera is not part of a pose file: set the view instead while joints exist");
  }
  const Pose before = pose;
  const int keyframeBefore = a.keyframe;
  pose.angles = std::move(probe.track);
  a.keyframe = clampKeyframe(pose, probe.keyframe);
  a.timeS.reset();
  a.playing = false;
  app.deform().pushPoseEdit(description, before, keyframeBefore);
  apply(app);
}

void JointTool::selectKeyframe(StudioApp& app, int k) {
  if (k < 0 || k >= int(pose.angles.keyframes.size())) throw Error("no keyframe " + std::to_string(k));
  Authoring& a = app.scene().authoring;
  a.keyframe = k;
  a.timeS.reset();
  a.playing = false;
  a.touch();
}

void JointTool::setDuration(StudioApp& app, double seconds) {
  if (pose.angles.keyframes.empty()) throw Error("add a joint first");
  if (!(seconds > 0 && seconds <= kMaxKeyframeDurationS)) throw Error("a keyframe's duration must be in (0, 3600] s");
  const Pose before = pose;
  pose.angles.keyframes[size_t(clampKeyframe(pose, app.scene().authoring.keyframe))].durationS = seconds;
  app.deform().pushPoseEdit("pose keyframe duration", before, app.scene().authoring.keyframe);
  apply(app);
}

void JointTool::load(StudioApp& app, const std::filesystem::path& path) {
  Pose loaded = loadPose(path);  // FileError naming the file and the field
  const int keyframeBefore = app.scene().authoring.keyframe;
  const Pose before = std::exchange(pose, std::move(loaded));
  selected = 0;
  app.scene().authoring.keyframe = int(pose.angles.keyframes.size()) - 1;  // `vellum pose`'s default pose
  app.scene().authoring.timeS.reset();
  app.deform().pushPoseEdit("load pose", before, keyframeBefore);
  prepare(app);
}

void JointTool::beginAngleDrag(const StudioApp& app) {
  angleDragBefore_ = std::pair{pose, const_cast<StudioApp&>(app).scene().authoring.keyframe};
}

void JointTool::endAngleDrag(StudioApp& app) {
  if (!angleDragBefore_) return;
  auto [before, keyframe] = std::move(*angleDragBefore_);
  angleDragBefore_.reset();
  app.deform().pushPoseEdit("angle", std::move(before), keyframe);
}

void JointTool::restore(StudioApp& app, Pose p, int keyframe) {
  angleDragBefore_.reset();
  Authoring& a = app.scene().authoring;
  a.keyframe = keyframe;
  a.timeS.reset();
  a.playing = false;
  if (sameJoints(pose, p) && (busy() || ready()) && generation_ == app.scene().volumeGeneration) {
    // Only the angles (or keyframes) differ: the joints' axes and samples stay; cheap.
    pose.angles = std::move(p.angles);
    apply(app);
    return;
  }
  pose = std::move(p);
  selected = std::clamp(selected, 0, std::max(0, int(pose.joints.size()) - 1));
  prepare(app);
}

std::string JointTool::poseArguments(const StudioApp& capp, const std::filesystem::path& poseFile,
                                     const std::filesystem::path& out) const {
  StudioApp& app = const_cast<StudioApp&>(capp);
  const Scene& scene = app.scene();
  app::PoseRequest r;
  r.input = scene.volumePath;
  r.labels = scene.labelsPath;
  r.pose = poseFile;
  r.output = out;
  r.frameTimeS = keyframeTime(app);
  r.options = options;
  r.map = map;
  r.engine.params = scene.authoring.engine;  // the live view's engine and map kernel
  r.engine.upsampling = scene.view.deformedUpsampling;
  r.engine.rigidFalloffMm = scene.authoring.falloffMm;
  return app::poseArguments(r);
}

void JointTool::save(const StudioApp& app, const std::filesystem::path& path, const std::filesystem::path& command,
                     const std::filesystem::path& out) const {
  if (pose.joints.empty()) throw Error("no joints to save");
  io::OutputPlan()
      .input(const_cast<StudioApp&>(app).scene().volumePath)
      .input(const_cast<StudioApp&>(app).scene().labelsPath, "the label map")
      .json(path, "the pose file")
      .check();
  savePose(pose, path);
  if (!command.empty()) {
    std::ofstream f(command);
    f << "vellum pose " << poseArguments(app, path, out) << "\n";
    if (!f) throw FileError(command, "cannot write the command");
  }
}

namespace {
std::vector<uint16_t> idsOf(const nlohmann::json& v) {
  if (v.is_number_integer()) return {v.get<uint16_t>()};
  return v.get<std::vector<uint16_t>>();
}
Vec3 pointOf(const nlohmann::json& v) { return {v.at(0).get<double>(), v.at(1).get<double>(), v.at(2).get<double>()}; }
}  // namespace

void jointScriptAction(StudioApp& app, const nlohmann::json& v) {
  JointTool& jt = app.deform().joints();
  if (!v.is_object() || v.size() != 1) throw Error("\"joint\" takes an object with one key");
  const std::string op = v.begin().key();
  const nlohmann::json& x = v.begin().value();
  if (op == "add") {
    jt.draftName = x.at("name").get<std::string>();
    jt.draftParent = idsOf(x.at("parent"));
    jt.draftChild = idsOf(x.at("child"));
    jt.draftAxisA.reset();
    jt.draftAxisB.reset();
    jt.draftAxisIsHint = x.contains("axis_hint");
    const char* axisKey = jt.draftAxisIsHint ? "axis_hint" : "axis";
    if (x.contains(axisKey) && x[axisKey].is_array())
      jt.draftAxisA = pointOf(x[axisKey].at(0)), jt.draftAxisB = pointOf(x[axisKey].at(1));
    jt.addDraftJoint(app);
  } else if (op == "pick") {
    const std::string w = x.get<std::string>();
    jt.pick = w == "parent" ? JointPick::Parent : w == "child" ? JointPick::Child : w == "axis1" ? JointPick::AxisA
            : w == "axis2" ? JointPick::AxisB : throw Error("pick: \"parent\", \"child\", \"axis1\" or \"axis2\"");
  } else if (op == "hint") {  // the Joints panel's "Place by motion" box: the clicked axis is a hint
    jt.draftAxisIsHint = x.get<bool>();
  } else if (op == "add_picked") {
    jt.draftName = x.get<std::string>();
    jt.addDraftJoint(app);
  } else if (op == "angle") {
    int index = -1;
    if (x.at("joint").is_number_integer()) index = x["joint"].get<int>();
    for (size_t j = 0; j < jt.pose.joints.size() && index < 0; ++j)
      if (x["joint"].is_string() && jt.pose.joints[j].name == x["joint"].get<std::string>()) index = int(j);
    if (!jt.ready()) throw Error("the joint tool is not ready (add a joint and wait for it)");
    jt.setAngle(app, index, x.at("deg").get<double>());
  } else if (op == "keyframe") {
    if (x.is_string() && x.get<std::string>() == "add") {
      jt.addKeyframe(app);
    } else {
      if (x.contains("select")) jt.selectKeyframe(app, x["select"].get<int>());
      if (x.contains("duration")) jt.setDuration(app, x["duration"].get<double>());
    }
  } else if (op == "fixed") {
    deformation::FixedRegions f;
    if (x.contains("labels")) f.ids = idsOf(x["labels"]);
    if (x.contains("boxes"))
      for (const auto& b : x["boxes"]) f.boxesMm.push_back(b.get<std::array<double, 6>>());
    jt.setFixed(app, std::move(f));
  } else if (op == "save") {
    jt.save(app, x.at("path").get<std::string>(), x.value("command", ""), x.value("out", ""));
  } else if (op == "load") {
    jt.load(app, x.get<std::string>());
  } else if (op == "remove") {
    jt.removeJoint(app, x.get<int>());
  } else if (op == "map") {  // `vellum pose --map`'s choices (the Joints panel's combo)
    const auto* row = params::findField(app::poseRequestTable(), "map");
    const auto& c = row->choices;
    const auto it = std::find(c.begin(), c.end(), x.is_string() ? x.get<std::string>() : "");
    if (it == c.end()) throw Error("joint map: one of auto, twist, mls");
    app::PoseRequest r;
    row->set(r, double(it - c.begin()));
    jt.setMap(app, r.map);
  } else {
    throw Error("unknown joint action \"" + op +
                "\" (add, pick, hint, add_picked, angle, keyframe, fixed, map, save, load, remove)");
  }
}

void saveShownVolume(StudioApp& app, const std::filesystem::path& path) {
  const Scene& scene = app.scene();
  const deformation::MapSampler* map = app.deform().session().sampler();
  if (!map) throw Error("no deformation is shown");
  io::OutputPlan().input(scene.volumePath).output(path, "the shown volume").check();
  const VolumeI16& ct = scene.ct;
  VolumeI16 out(ct.geometry(), int16_t(std::lround(ct.background())), ct.background());
  const Geometry& g = ct.geometry();
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i)
          if (const auto u = map->sourceMm(g.indexToPhysical({double(i), double(j), double(k)})))
            out(i, j, k) = int16_t(std::lround(std::clamp(ct.sampleLinearMm(*u), -32768.0, 32767.0)));
  });
  io::saveVolume(AnyVolume(std::move(out)), path);
}

}  // namespace vellum::studio
