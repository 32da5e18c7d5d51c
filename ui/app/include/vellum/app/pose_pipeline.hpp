#pragma once
// A pose as a request: what `vellum pose` does beyond parsing its flags. It reads a pose file
// (joints, angles over keyframes, fixed regions: deformation/pose.hpp), generates the control
// points from the label map, and hands them to the deformation run (runDeform: rigid bones
// per label id, fixed regions, synthesis, the rigidity report) for one pose, and/or to the
// movie run (runAnimate) over all keyframes; then measures each joint's achieved angle.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "vellum/app/animate_pipeline.hpp"
#include "vellum/app/pose_gltf.hpp"
#include "vellum/app/deform_pipeline.hpp"
#include "vellum/core/params.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/deformation/twist_frames.hpp"

namespace vellum::app {

/// The pose's map: the twist map (deformation/twist_map.hpp: fold-free by construction, bones
/// exact) or the MLS engine with the rigid blend and the fold repair; auto: the pose file's
/// "map", else the twist map.
enum class PoseMap { Auto = 0, Twist = 1, Mls = 2 };

/// Whether `choice` means the twist map for `pose` (auto: the pose file's "map", else twist since
/// s18: on the feet and the knees it folds least, 0.0001 % against mls's 0.35 %).
inline bool twistChosen(PoseMap choice, const deformation::Pose& pose) {
  return choice == PoseMap::Twist || (choice == PoseMap::Auto && pose.map != "mls");
}

struct PoseRequest {
  std::filesystem::path input;   ///< volume file or DICOM folder
  std::filesystem::path labels;  ///< label map on the volume's grid: the bones' ids
  std::filesystem::path pose;    ///< pose file (JSON)
  std::filesystem::path output;  ///< the deformed volume at the pose; empty: none (a movie only)
  std::filesystem::path movie;   ///< movie.mp4 or frames folder over all keyframes; empty: none
  std::filesystem::path report;  ///< report JSON; empty: not written (still returned)
  std::filesystem::path pointsOut;     ///< the generated control points at the pose; empty: not written
  std::filesystem::path gltf;  ///< the posed bones and skin as animated glTF (.glb); empty: none
  PoseGltfOptions gltfOptions;
  std::filesystem::path keyframesOut;  ///< the generated keyframe track (`vellum animate --keyframes`); empty: not written
  double frameTimeS = -1;  ///< the pose's time (s); < 0: the last keyframe
  /// --out's and --movie's box grown by this (mm) on every side; -1: per side, as far as the
  /// content moves (--out: at its pose; --movie: over every keyframe of the movie, one grid for
  /// all frames, framed on the content: AnimateRequest::padMm). DeformRequest::padMm: the same
  /// parameter, described once in deformRequestTable().
  double padMm = 0;
  bool force = false;
  /// Each bone's rigid transform is its joints' (the still bones' the identity) instead of the
  /// best fit of the MLS map over it (the map between bones is still MLS, blended to them).
  bool exactBones = true;
  PoseMap map = PoseMap::Auto;
  deformation::PoseOptions options;
  /// Engine settings (method, control scale, upsampling, falloff, stride); its labels, rigid
  /// and fixed ids are filled from the pose.
  DeformEngine engine;
  /// The movie: frame size, preset, camera (settings), fps and orbit (animate's own table).
  AnimateRequest movieSettings;
  io::LoadOptions load;
  std::string commandLine;
};

/// frame_time, exact_bones, pad_mm (deform's row; the options, the engine and the movie settings have their own tables).
const params::Table<PoseRequest>& poseRequestTable();

/// The engine of a pose (`vellum pose` and the studio's joint tool): `engine`'s settings, every
/// bone of the pose one rigid body per id, the fixed regions (ids and boxes) still, the engine's
/// power standing. `labels` is left as given.
DeformEngine poseEngine(const deformation::Pose& pose, DeformEngine engine);
/// The twist map's frames of `pose` on `grid` (the label map's grid, or a movie's grown box: the
/// labels placed in it, 0 around): on the engine's control grid (--control-scale), the pose's
/// bodies sampled at its nodes (deformation::TwistFrames).
std::shared_ptr<const deformation::TwistFrames> poseTwistFrames(const deformation::Pose& pose, const LabelVolume& labels,
                                                                const DeformEngine& engine,
                                                                const deformation::PoseOptions& options,
                                                                const Geometry& grid);
/// A movie's frame maps from them: each frame the twist map at the pose's angles at its time.
decltype(animation::MovieSpec::frameMaps) twistFrameMaps(std::shared_ptr<const deformation::TwistFrames> frames);

struct PoseResult {
  deformation::Pose pose;  ///< as run (estimated axes filled)
  std::vector<double> anglesDeg;
  std::vector<deformation::JointMeasure> joints;  ///< measured on the output volume's map (with `output`)
  std::vector<std::string> warnings;
  /// pose, time_s, angles_deg, joints, points, params, deform (runDeform's report), movie
  /// (runAnimate's), timings_ms: what request.report holds.
  nlohmann::json report;
};

/// The `vellum pose` arguments (after "vellum pose") that run `request`: volume, --labels,
/// --pose, --out, --movie with its frame settings (size, render settings, fps, orbit, titles,
/// pan), --frame-time, and the point generation and engine flags that differ from their
/// defaults (what the studio's joint tool writes beside a saved pose file and its movie export).
std::string poseArguments(const PoseRequest& request);

/// Runs the request; outputs through the output policy, atomically. FileError naming a bad
/// file (the pose file's problems: one line), Error for a bad request, Cancelled.
PoseResult runPose(const PoseRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
