#pragma once
// The studio's document: what a scene file saves and what every view draws from.
// Plain data, no GL and no ImGui, so that tests and the scene file can use it directly.
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "authoring.hpp"
#include "segment_meshes.hpp"
#include "view_settings.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::studio {

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

  // View state (described by parameter tables: see view_settings.hpp).
  ViewSettings view;
  render::RenderSettings render;  ///< the 3D view's preset, camera, window ...; width/height unused
  std::vector<CameraBookmark> bookmarks;
  IllustrationView illustration;
  /// Shapes for the illustration (a `vellum shape` folder, or made from the labels in the
  /// studio); null until made or opened. Replaced as a whole, never edited in place.
  std::shared_ptr<const illustration::ShapeScene> shapes;
  std::filesystem::path shapesPath;  ///< the folder they came from (empty: made from the labels)
  /// The shapes' segment meshes (ViewSettings::meshesIn3d draws them); null or empty: none.
  std::shared_ptr<const SegmentMeshes> shapeMeshes;
  uint64_t shapesRevision = 0;
  Vec3 crosshairMm{0, 0, 0};
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
  ViewState viewState() const { return {view, render, bookmarks, illustration}; }
  void setViewState(const ViewState& v) {
    view = v.view;
    render = v.render;
    bookmarks = v.bookmarks;
    illustration = v.illustration;
  }
};

/// Runs `read` later on a thread where the scene's labels do not change (the studio: a task on
/// its queue, StudioApp::readSceneOnWorker), shown as `name`; false: not now (ask again). How
/// workers get their copy of the label map without copying it on the UI thread.
using SceneReader = std::function<bool(const std::string& name, std::function<void(const Scene&)> read)>;

}  // namespace vellum::studio
