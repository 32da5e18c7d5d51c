#pragma once
// A keyframed deformation movie as a request: what `vellum animate` does beyond parsing its
// flags (load the volume, keyframes and rigid bones, remove the CT table, render every frame
// through animation::MovieRenderer, write the MP4 and/or PNG frames, report). The studio's
// export fills the same request: its frames come from movieSpec() and MovieRenderer, and the
// `vellum animate` line it writes beside them is animateArguments() of that request.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "vellum/animation/movie.hpp"
#include "vellum/app/deform_pipeline.hpp"
#include "vellum/app/grown_box.hpp"
#include "vellum/core/params.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/render/render_settings.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::app {

struct AnimateRequest {
  std::filesystem::path input;      ///< volume file or DICOM folder
  std::filesystem::path keyframes;  ///< keyframe JSON (mm)
  std::optional<deformation::KeyframeTrack> track;
  /// Known rigid-body transforms per frame (animation::MovieSpec::knownBodyTransforms; `vellum pose`).
  decltype(animation::MovieSpec::knownBodyTransforms) knownBodyTransforms;  ///< a track made in memory (`vellum pose`): used instead of `keyframes`
  /// Each frame's map made elsewhere (animation::MovieSpec::frameMaps; `vellum pose --map twist`),
  /// made for the movie's grid (the input's, grown by padMm): called once, after the volume loads.
  std::function<decltype(animation::MovieSpec::frameMaps)(const Geometry& movieGrid)> frameMapsOn;
  /// The movie's box grown so that nothing its frames move is cut (deform's --pad-mm, described
  /// once): 0 the input's box, > 0 that margin, -1 automatic over every keyframe of the track
  /// (grownBox). One grid for the whole movie; a grown movie is framed on its content.
  double padMm = 0;
  /// movie.mp4, or a folder (a path ending in '/' or without an extension) for PNG frames.
  std::filesystem::path output;
  std::filesystem::path frames;  ///< also PNG frames into this folder; empty: no
  std::filesystem::path report;  ///< report JSON; empty: not written (still returned)
  bool force = false;  ///< a frames folder may replace a Vellum folder of another kind
  double fps = 30;
  double orbitDeg = 0;  ///< camera azimuth turn over the whole animation
  bool loop = false;    ///< seamless loop: back to the first keyframe (overrides the file's "loop")
  render::RenderSettings settings;  ///< the frame size is settings.width x settings.height
  DeformEngine engine;              ///< the rigid-bone measures run every `rigidityStride` voxels
  io::LoadOptions load;             ///< series, raw layout, region (the label map gets the same region)
  std::optional<segmentation::BodyMaskParams> removeTable;  ///< remove the CT table first
  /// Figure annotations in every frame; labels need engine.labels (the structures' names).
  render::AnnotationOptions annotations;
  std::vector<uint16_t> labelIds;  ///< structures to name (empty: every id of the table)
  /// Title card and caption (animation::MovieSpec): --title, --subtitle, --title-seconds, --caption.
  std::string title, subtitle, caption;
  double titleSeconds = 2.0;
  std::string commandLine;         ///< for the report's shared keys (run_report.hpp)
};

/// fps, camera_orbit, loop, title, subtitle, title_seconds, caption, pad_mm (deform's row) (the
/// size, the render settings and the engine have their own).
const params::Table<AnimateRequest>& animateRequestTable();

/// A movie's volume on its grown box: the volume padded with its background (air) so that every
/// keyframe of the track keeps what it moves (grownBox over the keyframes' points: for a pose
/// track, at most max_step_deg apart), one grid for every frame, and the camera framed on the
/// content over all frames (framedOnContent) when the box grew (--pad-mm not 0).
struct MovieBox {
  GrownBox box;
  AnyVolume volume;       ///< padded (the input itself when padMm is 0)
  render::Camera camera;  ///< the asked camera, framed on the content when padded
};
MovieBox movieBox(AnyVolume volume, const deformation::KeyframeTrack& track, double padMm, int controlScale,
                  const render::Camera& asked);
/// The movie's grid and padding as the reports write them: grid {dims, origin_mm, spacing_mm},
/// pad_voxels {low, high} (per axis), camera {zoom, pan_mm} as framed.
nlohmann::json toJson(const MovieBox& m);

/// The movie outputs, frame rate, camera and upsampling of `request`: what MovieRenderer
/// needs beyond the volume, the track and the engine.
animation::MovieSpec movieSpec(const AnimateRequest& request);

/// The `vellum animate` arguments that reproduce `request`'s frames (after "vellum animate"):
/// paths single-quoted, every setting that differs from its default.
std::string animateArguments(const AnimateRequest& request);
/// The frame settings of a movie's arguments (`vellum animate` and `vellum pose --movie`): --size,
/// the request's table (but `skip`), the render settings, titles, --pan.
std::string movieArguments(const AnimateRequest& request, const std::vector<std::string>& skip = {});
/// A path in single quotes, as the written command lines quote them.
std::string singleQuoted(const std::filesystem::path& p);

struct AnimateResult {
  animation::MovieResult movie;
  std::vector<std::string> warnings;  ///< the loader's
  std::string tableRemoval;  ///< --remove-table's one-line summary (app::tableRemovalSummary); empty without it
  /// frames, fps, timings_ms (deform_per_frame, render_per_frame, total), frames_cpu_ms (per
  /// stage), rigidity_worst (over the frames rigidity_voxel_frames names), rigidity_per_frame
  /// (voxels_as_rendered null where a frame was measured at its nodes only): what
  /// request.report holds.
  nlohmann::json report;
};

/// Renders the request on a headless GL context. FileError naming a bad file, Error for a bad
/// request, Cancelled through `progress`.
AnimateResult runAnimate(const AnimateRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
