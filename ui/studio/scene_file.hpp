#pragma once
// Scene files: versioned JSON describing where the data is and how it is viewed.
// Documented in docs/studio.md ("Scene file"). Paths are stored relative to the scene
// file's folder when the data lies below it or beside it, absolute otherwise.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "scene.hpp"

namespace vellum::studio {

/// 2 adds "deformation"; 3 writes the view as "view" and "render" objects whose keys are those
/// of the parameter tables (the CLI flags of `vellum render`), plus "pan" and "camera_bookmarks";
/// 4 adds "joints". Versions 1 to 3 are read as before.
inline constexpr int kSceneFormatVersion = 4;

/// The authored deformation: the keyframes live in a `vellum animate` keyframe file beside
/// the scene (`<scene>.keyframes.json`), so the CLI can render them as they are.
struct SceneDeformation {
  std::filesystem::path keyframesPath;  ///< absolute once read
  deformation::KeyframeTrack track;
  int keyframe = 0;
  std::vector<uint16_t> rigidLabels;
  double falloffMm = 10;
  deformation::DeformParams engine = studioDeformParams();
};

/// The joint tool's pose: a `vellum pose --pose` file beside the scene (`<scene>.pose.json`,
/// deformation::savePose / loadPose: one schema, one parser), so the CLI poses it as it is.
struct ScenePose {
  std::filesystem::path posePath;  ///< absolute once read
  deformation::Pose pose;
};

/// The saved part of a Scene: data paths (absolute once read) and the view state.
struct SceneFile {
  std::filesystem::path volume;
  std::filesystem::path labels;  ///< empty: no label map
  std::string seriesUid;         ///< DICOM: the series to load (empty: the largest CT series)
  std::filesystem::path shapes;  ///< a `vellum shape` folder shown by the illustration (empty: none)
  ViewState view;  ///< layout, windows, opacity, the 3D view's settings and camera bookmarks
  Vec3 crosshairMm;
  std::set<uint16_t> hiddenLabels;
  std::set<uint16_t> lockedLabels;
  std::optional<SceneDeformation> deformation;  ///< none: no control points
  std::optional<ScenePose> pose;                ///< none: no joints
};

/// Reads and validates a scene file; relative paths are resolved against its folder.
/// Throws vellum::FileError naming the scene for bad JSON or an unknown version, and naming
/// the missing file ("... referenced by scene.json does not exist") for missing data.
SceneFile readSceneFile(const std::filesystem::path& path);
/// Writes `file` to `path` atomically, with paths made relative to path's folder, and the
/// deformation's keyframes to `<path stem>.keyframes.json` and the pose to
/// `<path stem>.pose.json` beside it.
void writeSceneFile(const SceneFile& file, const std::filesystem::path& path);

/// The view part of a scene file (everything but the paths and the deformation): what
/// writeSceneFile writes under "view", "render", "pan", "camera_bookmarks", "crosshair",
/// "hidden_labels" and "locked_labels". Autosave compares it to skip unchanged scenes.
nlohmann::json sceneViewJson(const SceneFile& file);

/// The saved part of a scene.
SceneFile describeScene(const Scene& scene);
/// Copies the view state (not the data) of `file` into `scene`.
void applySceneView(const SceneFile& file, Scene& scene);

}  // namespace vellum::studio
