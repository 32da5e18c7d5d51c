// The pose request: `vellum pose`'s run (see pose_pipeline.hpp).
#include "vellum/app/pose_pipeline.hpp"

#include <chrono>
#include <cmath>
#include <sstream>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/twist_frames.hpp"
#include "vellum/deformation/twist_map.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::app {
using namespace vellum::deformation;
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

nlohmann::json vec(const Vec3& v) { return {v.x, v.y, v.z}; }
// NaN (not measured) as null.
nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json jointsJson(const Pose& pose, const std::vector<double>& angles, const std::vector<JointMeasure>& m) {
  nlohmann::json out = nlohmann::json::array();
  for (size_t j = 0; j < pose.joints.size(); ++j) {
    const Joint& joint = pose.joints[j];
    nlohmann::json o = {{"name", joint.name},
                        {"parent", joint.parent},
                        {"child", joint.child},
                        {"axis_mm", {vec(joint.axisA), vec(joint.axisB)}},
                        {"axis_estimated", joint.estimateAxis},
                        {"proximal", joint.proximal < 0 ? nlohmann::json() : nlohmann::json(pose.joints[joint.proximal].name)},
                        {"requested_deg", angles[j]}};
    if (joint.estimateAxis) {  // how the axis was estimated, and how well the surface fits
      const AxisFit& f = joint.fit;
      nlohmann::json contact = nlohmann::json::object();
      for (const auto& [id, voxels] : f.contactVoxels) contact[std::to_string(id)] = voxels;
      nlohmann::json fit = {{"method", f.method},
                            {"surface_voxels", f.surfacePoints},
                            {"partner", f.partner},
                            {"contact_voxels", std::move(contact)},
                            {"confidence", f.confidence},
                            {"refusals", f.refusals}};
      fit["surface_method"] = f.surfaceMethod.empty() ? nlohmann::json() : nlohmann::json(f.surfaceMethod);
      if (!f.surfaceMethod.empty())
        fit.update({{"surface", f.surface},
                    {"radius_mm", f.radiusMm},
                    {"rms_mm", f.rmsMm},
                    {"inlier_fraction", f.inlierFraction},
                    {"axis_gap_mm", f.axisGapMm < 0 ? nlohmann::json() : nlohmann::json(f.axisGapMm)}});
      if (f.surfaceMethod == "cylinder") fit["arc_deg"] = f.arcDeg;
      if (f.motion.searched) {
        const MotionFit& m = f.motion;
        fit["motion"] = {{"hint_mm", {vec(joint.hintA), vec(joint.hintB)}},
                         {"cone_deg", m.coneDeg},
                         {"reach_mm", m.reachMm},
                         {"angles_deg", m.anglesDeg},
                         {"score_rms_mm", {{"hint", m.startRmsMm}, {"found", m.rmsMm}}},
                         {"inside_fraction", {{"hint", m.startInsideFraction}, {"found", m.insideFraction}}},
                         {"shift_mm", m.shiftMm},
                         {"turn_deg", m.turnDeg},
                         {"contact_voxels", m.contactPoints},
                         {"near_voxels", m.nearPoints}};
      }
      fit["warning"] = f.warning.empty() ? nlohmann::json() : nlohmann::json(f.warning);
      o["axis_fit"] = std::move(fit);
    }
    if (j < m.size()) {
      o["achieved_deg"] = num(m[j].achievedDeg);
      o["error_deg"] = num(m[j].achievedDeg - angles[j]);
      o["child_rotation_error_deg"] = num(m[j].childRotationErrorDeg);
      o["child_position_error_mm"] = num(m[j].childPositionErrorMm);
      o["parent_rotation_deg"] = num(m[j].parentRotationDeg);
      o["child_samples"] = m[j].childSamples;
      o["parent_samples"] = m[j].parentSamples;
      if (!std::isfinite(m[j].achievedDeg))
        o["not_measured"] = "fewer than 4 voxels of the parent or child bone in the output";
    }
    out.push_back(std::move(o));
  }
  return out;
}

nlohmann::json twistJson(const TwistMap& m, const TwistParams& p) {
  nlohmann::json joints = nlohmann::json::array();
  for (const TwistJointStats& s : m.joints)
    joints.push_back({{"name", s.name},
                      {"angle_deg", s.angleDeg},
                      {"still_voxels", s.stillVoxels},
                      {"moving_voxels", s.movingVoxels},
                      {"overlap_voxels", s.overlapVoxels},
                      {"joined_voxels", s.joinedVoxels},
                      {"slope_violations_before", s.violationsBefore},
                      {"max_slope_before", s.maxSlopeBefore},
                      {"relax_rounds", s.rounds},
                      {"relaxed_voxels", s.relaxedVoxels},
                      {"slope_violations_after", s.violationsAfter},
                      {"collision_voxels", s.collisionVoxels},
                      {"max_slope_after", s.maxSlopeAfter},
                      {"softened_bone_voxels", s.softenedVoxels}});
  return {{"power", p.power}, {"margin", p.margin}, {"joints", std::move(joints)},
          {"unsnapped_voxels", m.unsnappedVoxels}};
}

}  // namespace

DeformEngine poseEngine(const Pose& pose, DeformEngine engine) {
  engine.rigidIds.clear();
  engine.rigidGroups.clear();
  for (uint16_t id : pose.boneIds())
    if (std::find(pose.fixed.ids.begin(), pose.fixed.ids.end(), id) == pose.fixed.ids.end())
      engine.rigidIds.push_back(id);
  engine.fixedIds = pose.fixed.ids;
  engine.fixedBoxMm.clear();
  for (const auto& b : pose.fixed.boxesMm) engine.fixedBoxMm.insert(engine.fixedBoxMm.end(), b.begin(), b.end());
  engine.powerGiven = true;  // no point file: the engine's power stands
  return engine;
}

std::shared_ptr<const TwistFrames> poseTwistFrames(const Pose& pose, const LabelVolume& labels,
                                                   const DeformEngine& engine, const PoseOptions& options,
                                                   const Geometry& grid) {
  const int scale = engine.params.controlScale;
  const LabelVolume onGrid = labelsOnGrid(labels, grid);
  return std::make_shared<const TwistFrames>(
      pose, nodeBodiesOf(labelsAtNodes(onGrid, scale), engine.bodyGroups(), scale, pose.fixed), grid, scale,
      twistParamsOf(options));
}

decltype(animation::MovieSpec::frameMaps) twistFrameMaps(std::shared_ptr<const TwistFrames> frames) {
  return [f = std::move(frames)](double timeS, const RigidBodies* bodies) {
    if (!bodies) throw Error("the twist map's movie needs the pose's rigid bodies");
    return f->atTime(timeS, *bodies);
  };
}

const params::Table<PoseRequest>& poseRequestTable() {
  using R = PoseRequest;
  static const params::Table<R> t{
      params::real<R>("frame_time", &R::frameTimeS,
                      {"Pose time", "the time (s) in the pose file's keyframes whose angles --out gets; "
                       "negative: the last keyframe", "s", -1, 1e6}),
      params::flag<R>("exact_bones", &R::exactBones,
                      {"Exact bones", "each bone takes its joints' transform (still bones the identity) instead of "
                       "the best rigid fit of the MLS map over it", ""}),
      params::choice<R>("map", &R::map, {"auto", "twist", "mls"},
                        {"Pose map", "twist: each joint turns the tissue about its axis by a blended angle "
                         "(det J = 1 - angle * dw/dalpha: fold-free but where still and moving bones collide; bones and "
                         "fixed regions exact); mls: the control-point "
                         "engine with the rigid blend and the fold repair; auto: the pose file's \"map\", else "
                         "twist", ""}),
      // deform's --pad-mm, described once (deformRequestTable()).
      params::real<R>("pad_mm", &R::padMm, params::findField(deformRequestTable(), "pad_mm")->info),
  };
  return t;
}

std::string poseArguments(const PoseRequest& r) {
  std::ostringstream c;
  c.precision(10);
  c << singleQuoted(r.input) << " --labels " << singleQuoted(r.labels) << " --pose " << singleQuoted(r.pose);
  if (!r.output.empty()) c << " --out " << singleQuoted(r.output);
  if (!r.movie.empty())  // the movie's frames: size, render settings, fps, orbit, titles (its pad is pad_mm's)
    c << " --movie " << singleQuoted(r.movie) << movieArguments(r.movieSettings, {"loop", "pad_mm"});
  c << params::cliArguments(poseRequestTable(), r) << params::cliArguments(poseOptionsTable(), r.options)
    << params::cliArguments(deformParamsTable(), r.engine.params)
    << params::cliArguments(deformEngineTable(), r.engine, {"labels"});
  return c.str();
}

PoseResult runPose(const PoseRequest& request, Progress& progress) {
  const auto t0 = Clock::now();
  if (request.output.empty() && request.movie.empty() && request.gltf.empty())
    throw Error("vellum pose needs --out (the volume at a pose), --movie (all keyframes) or --gltf (posed meshes)");
  const AnimateRequest& ms = request.movieSettings;
  animation::MovieSpec movieSpecOut;
  if (!request.movie.empty()) {
    AnimateRequest probe = ms;
    probe.output = request.movie;
    movieSpecOut = movieSpec(probe);
  }
  io::OutputPlan()
      .input(request.input)
      .input(request.labels, "the --labels map")
      .input(request.pose, "the --pose file")
      .output(request.output, "--out")
      .output(movieSpecOut.moviePath, "--movie")
      .folder(movieSpecOut.framesDir, io::FolderKind::Frames, "--movie")
      .json(request.report, "--report")
      .json(request.pointsOut, "--points-out")
      .json(request.keyframesOut, "--keyframes-out")
      .output(request.gltf, "--gltf")
      .force(request.force)
      .check();
  params::validate(poseRequestTable(), request);
  params::validate(poseOptionsTable(), request.options);
  params::validate(poseGltfOptionsTable(), request.gltfOptions);
  params::validate(deformEngineTable(), request.engine);
  nlohmann::json timings;

  // The pose and the points it generates.
  PoseResult result;
  result.pose = loadPose(request.pose);
  Pose& pose = result.pose;
  auto t = Clock::now();
  io::LoadOptions lo;
  lo.region = request.load.region;
  lo.allowOutsideData = request.load.allowOutsideData;
  const LabelVolume labels = io::loadLabels(request.labels, lo);
  timings["labels"] = msSince(t);
  t = Clock::now();
  try {
    estimateAxes(pose, labels, request.options.contactMm, progress);
  } catch (const FileError&) {
    throw;
  } catch (const Cancelled&) {
    throw;
  } catch (const Error& e) {
    throw FileError(request.pose, e.what());
  }
  PoseSamples samples;
  try {
    samples = poseSamples(pose, labels, request.options);
  } catch (const Error& e) {  // a bone id the label map lacks
    throw FileError(request.pose, std::string(e.what()) + " (" + request.labels.string() + ")");
  }
  timings["points"] = msSince(t);
  const double time = request.frameTimeS < 0 ? pose.lastKeyframeTimeS() : request.frameTimeS;
  result.anglesDeg = pose.anglesAt(time);

  DeformEngine engine = poseEngine(pose, request.engine);
  engine.labels = request.labels.string();

  nlohmann::json& report = result.report;
  report["pose"] = request.pose.string();
  report["time_s"] = time;
  nlohmann::json angles = nlohmann::json::object();
  for (size_t j = 0; j < pose.joints.size(); ++j) angles[pose.joints[j].name] = result.anglesDeg[j];
  report["angles_deg"] = angles;
  report["points"] = {{"total", samples.sources.size()},
                      {"bones", samples.bonePoints},
                      {"fixed", samples.fixedPoints},
                      {"anchors", samples.anchorPoints}};
  report["params"] = params::toJson(poseOptionsTable(), request.options);
  report["exact_bones"] = request.exactBones;
  report["rigid_labels"] = engine.rigidIds;
  report["fixed_labels"] = engine.fixedIds;
  // A fixed box over a moving bone cuts it (the box wins): said, not silently absorbed.
  nlohmann::json cuts = nlohmann::json::array();
  for (const FixedBoxCut& c : fixedBoxCuts(pose, labels)) {
    const std::optional<Label> label = labels.label(c.id);
    const std::string name = label ? label->name : std::string();
    cuts.push_back({{"box", c.box}, {"box_mm", pose.fixed.boxesMm[c.box]}, {"id", c.id}, {"name", name}, {"voxels", c.voxels}});
  }
  report["fixed_box_cuts"] = std::move(cuts);

  RunOutputs written;  // a failure later takes the earlier outputs with it
  PointFile points;
  points.points = posedPoints(samples, pose, result.anglesDeg);
  points.power = engine.params.mls.power;
  if (!request.pointsOut.empty()) {
    ensureParentFolder(request.pointsOut);
    saveControlPoints(points, request.pointsOut);
    written.wrote(request.pointsOut);
  }
  // The map: the request's, else the pose file's, else twist (docs/benchmarks-deformation.md, "s18").
  const bool twist = twistChosen(request.map, pose);
  report["map"] = twist ? "twist" : "mls";
  const TwistParams tp = twistParamsOf(request.options);
  // The twist map of the glTF skin's keys on the label map's grid (the movie's are made on its
  // own, grown grid: runAnimate asks for them); made when needed.
  std::shared_ptr<const TwistFrames> frames;
  auto twistFrames = [&] {
    if (!frames) frames = poseTwistFrames(pose, labels, engine, request.options, labels.geometry());
    return frames;
  };
  if (!request.output.empty()) {
    DeformRequest d;
    d.input = request.input;
    d.pointSet = points;
    d.output = request.output;
    d.keepMap = true;
    d.padMm = request.padMm;
    if (request.exactBones) {
      const std::vector<RigidTransform> jt = jointTransforms(pose, result.anglesDeg);
      for (uint16_t id : engine.rigidIds) {
        const int j = pose.jointMoving(id);
        d.boneTransforms.push_back({id, j < 0 ? RigidTransform{} : jt[static_cast<size_t>(j)]});
      }
    }
    if (twist) {
      const std::vector<double> anglesDeg = result.anglesDeg;
      d.mapMaker = [&pose, anglesDeg, tp](const Geometry& g, const RigidBodies& bodies, nlohmann::json& rep,
                                          Progress& p) {
        TwistMap m = twistMap(pose, anglesDeg, bodies, g, tp, p);
        rep = twistJson(m, tp);
        return std::move(m.mapMm);
      };
    }
    d.force = request.force;
    d.engine = engine;
    d.load = request.load;
    d.commandLine = request.commandLine;
    DeformResult dr = runDeform(d, progress);
    written.wrote(request.output);
    t = Clock::now();
    result.joints = measureJoints(dr.map, geometryOf(dr.output), labels, pose, result.anglesDeg,
                                  request.options.measureStride);
    timings["joint_measures"] = msSince(t);
    report["deform"] = std::move(dr.report);
    result.warnings = std::move(dr.warnings);
  }
  report["joints"] = jointsJson(pose, result.anglesDeg, result.joints);

  KeyframeTrack track;
  if (!request.movie.empty() || !request.keyframesOut.empty()) {
    t = Clock::now();
    track = poseTrack(samples, pose, request.options.maxStepDeg);
    timings["track"] = msSince(t);
    report["movie_keyframes"] = track.keyframes.size();
  }
  if (!request.keyframesOut.empty()) {
    ensureParentFolder(request.keyframesOut);
    saveKeyframes(track, request.keyframesOut);
    written.wrote(request.keyframesOut);
  }
  if (!request.movie.empty()) {
    AnimateRequest a = ms;
    a.input = request.input;
    a.output = request.movie;
    a.track = std::move(track);
    a.loop = pose.angles.loop;
    a.report.clear();
    a.frames.clear();
    a.force = request.force;
    a.engine = engine;
    a.load = request.load;
    a.commandLine = request.commandLine;
    a.padMm = request.padMm;  // the movie's box grows over all its frames (--out's over its one pose)
    if (twist)  // each frame's map is the twist map at the pose's angles at that time, as --out's
      a.frameMapsOn = [&](const Geometry& movieGrid) {
        return twistFrameMaps(poseTwistFrames(pose, labels, engine, request.options, movieGrid));
      };
    else if (request.exactBones)  // each frame's bones at the pose's angles at that time
      a.knownBodyTransforms = [pose](double timeS, const RigidBodies& bodies) {
        return knownBodyTransforms(pose, bodies, pose.anglesAt(timeS));
      };
    AnimateResult ar = runAnimate(a, progress);
    written.wrote(request.movie);
    report["movie"] = std::move(ar.report);
    report["movie"]["path"] = request.movie.string();
    report["movie"]["map"] = twist ? "twist" : "mls";
    if (twist) report["movie"]["map_scale"] = engine.params.controlScale;  // the frames' twist map: every s-th voxel, bones snapped
    if (result.warnings.empty()) result.warnings = std::move(ar.warnings);
  }
  if (!request.gltf.empty()) {
    t = Clock::now();
    ensureParentFolder(request.gltf);
    // The twist map's skin snaps to the full-resolution bones (the movie's are its own).
    std::optional<RigidBodies> bodies;
    PoseSkinMap skin;
    if (twist) {
      bodies = engine.rigidBodies(labels.geometry(), request.load);
      skin = {twistFrames().get(), &*bodies};
    }
    const PoseGltfSummary g = writePoseGltf(pose, samples, labels, engine.params.mls, request.gltfOptions,
                                            request.gltf, skin, progress);
    written.wrote(request.gltf);
    timings["gltf"] = msSince(t);
    report["gltf"] = {{"path", request.gltf.string()}, {"bones", g.bones}, {"keys", g.keys}, {"faces", g.faces},
                      {"skin_max_move_mm", g.skinMaxMoveMm}, {"skin_map", g.skinMap}};
    if (twist) report["gltf"]["skin_uninverted"] = g.skinUninverted;  // vertex-keys left at the MLS estimate
  }
  timings["total"] = msSince(t0);
  report["timings_ms"] = timings;
  if (!request.report.empty()) {
    RunReport shared(request.commandLine, t0);
    shared.input(request.input, "volume");
    shared.input(request.labels, "label map");
    shared.input(request.pose, "pose");
    shared.outputVolume(request.output);
    shared.outputVolume(request.movie);
    if (!request.gltf.empty()) shared.output(request.gltf);
    shared.stamp(report);
    writeJsonFile(report, request.report);
  }
  written.commit();
  return result;
}

}  // namespace vellum::app
