#pragma once
// The studio's document: what a scene file saves and what every view draws from.
// Plain data, no GL and no ImGui, so that tests and the scene file can use it directly.
#include <filesystem>
#include <optional>
#include <set>
#include <string>

#include "authoring.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::studio {

enum class Layout { ThreeD, TwoByTwo, OneByThree };
/// "3d", "2x2", "1x3".
const char* layoutName(Layout l);
/// Parses the names above; throws vellum::Error listing them.
Layout parseLayout(const std::string& name);

/// Window/level in HU (centre, width).
struct WindowLevel {
  double center = 40;
  double width = 400;
  bool operator==(const WindowLevel&) const = default;
};

struct Scene {
  // Data. The CT is held as int16 HU: what slices, thresholds and the renderer read.
  VolumeI16 ct;
  LabelVolume labels;  ///< same geometry as ct once a volume is loaded
  std::filesystem::path volumePath;
  std::filesystem::path labelsPath;   ///< empty until loaded or saved
  std::filesystem::path scenePath;    ///< empty until opened from or saved to a scene file
  bool labelsModified = false;
  uint64_t labelsRevision = 0;  ///< bumped by every label change (autosave compares it)
  uint64_t volumeGeneration = 0;  ///< bumped by every load: results of older jobs are dropped
  /// DICOM: every series found in the folder, and the one shown (empty for other formats).
  std::vector<io::SeriesInfo> series;
  std::string seriesUid;

  // View state.
  Layout layout = Layout::TwoByTwo;
  render::Preset preset = render::Preset::SoftTissueBone;
  render::Camera camera;
  WindowLevel sliceWindow{40, 400};
  /// The renderer's window (RenderSettings defaults), kept apart from the slices' one.
  WindowLevel renderWindow{400, 2000};
  Vec3 crosshairMm{0, 0, 0};
  float labelOpacity = 0.4f;
  std::set<uint16_t> hiddenLabels;
  std::set<uint16_t> lockedLabels;  ///< segments no edit may change
  Authoring authoring;  ///< control points and keyframes (deformation authoring)

  bool hasVolume() const { return !ct.empty(); }
  /// Marks the label map (voxels or table) as changed.
  void touchLabels() {
    labelsModified = true;
    ++labelsRevision;
  }
  /// Centres the crosshair and resets the camera (new volume).
  void resetView();
};

}  // namespace vellum::studio
