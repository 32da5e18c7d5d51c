#pragma once
// Scene files: versioned JSON describing where the data is and how it is viewed.
// Documented in docs/studio.md ("Scene file"). Paths are stored relative to the scene
// file's folder when the data lies below it or beside it, absolute otherwise.
#include <filesystem>
#include <optional>
#include <vector>

#include "scene.hpp"

namespace vellum::studio {

/// 2 adds "deformation" (version 1 files are read as before).
inline constexpr int kSceneFormatVersion = 2;

/// The authored deformation: the keyframes live in a `vellum animate` keyframe file beside
/// the scene (`<scene>.keyframes.json`), so the CLI can render them as they are.
struct SceneDeformation {
  std::filesystem::path keyframesPath;  ///< absolute once read
  deformation::KeyframeTrack track;
  int keyframe = 0;
  std::vector<uint16_t> rigidLabels;
  double falloffMm = 10;
};

/// The saved part of a Scene: data paths (absolute once read) and the view state.
struct SceneFile {
  std::filesystem::path volume;
  std::filesystem::path labels;  ///< empty: no label map
  std::string seriesUid;         ///< DICOM: the series to load (empty: the largest CT series)
  Layout layout = Layout::TwoByTwo;
  render::Preset preset = render::Preset::SoftTissueBone;
  render::Camera camera;
  WindowLevel sliceWindow, renderWindow{400, 2000};
  Vec3 crosshairMm;
  float labelOpacity = 0.4f;
  std::set<uint16_t> hiddenLabels;
  std::set<uint16_t> lockedLabels;
  std::optional<SceneDeformation> deformation;  ///< none: no control points
};

/// Reads and validates a scene file; relative paths are resolved against its folder.
/// Throws vellum::FileError naming the scene for bad JSON or an unknown version, and naming
/// the missing file ("... referenced by scene.json does not exist") for missing data.
SceneFile readSceneFile(const std::filesystem::path& path);
/// Writes `file` to `path` atomically, with paths made relative to path's folder, and the
/// deformation's keyframes to `<path stem>.keyframes.json` beside it.
void writeSceneFile(const SceneFile& file, const std::filesystem::path& path);

/// The saved part of a scene.
SceneFile describeScene(const Scene& scene);
/// Copies the view state (not the data) of `file` into `scene`.
void applySceneView(const SceneFile& file, Scene& scene);

}  // namespace vellum::studio
