#pragma once
// Keyframed deformation movies through the GL renderer. `vellum animate`, the demo and the
// studio's export all render through MovieRenderer, so their frames are the same pixels.
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <vector>

#include "vellum/core/image.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/keyframes.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/label_tint.hpp"
#include "vellum/render/gl_context.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::animation {

struct MovieSpec {
  std::filesystem::path moviePath;  ///< empty: no movie
  std::filesystem::path framesDir;  ///< empty: no PNG frames (frame-00000.png, ...)
  double fps = 30;
  render::RenderSettings settings;
  double orbitDeg = 0;  ///< camera azimuth turn over the whole animation
  /// Map upsampling of the frames (and of the voxel-level rigidity measures), as --upsampling.
  deformation::Upsampling upsampling = deformation::Upsampling::Trilinear;
  /// Figure annotations drawn into every frame (scale bar, orientation letters, labels).
  render::AnnotationOptions annotations;
  /// With annotations.labels: the label map on the volume's grid. Each frame names the
  /// structures where the frame's deformation has moved them: which show, from the labels
  /// pulled through the map; each leader line ends on the structure's centre where the frame
  /// draws it (render::deformedPositions), framed as the renderer frames the map's grid.
  const LabelVolume* labels = nullptr;
  /// Label colours (settings.labelBlend > 0): the volume tinted by them, through each frame's map.
  const render::LabelTint* tint = nullptr;
  std::vector<uint16_t> labelIds;  ///< structures to name (empty: every id of the table)
  /// A title card before the first frame (title centred, subtitle beneath it, on the
  /// settings' background), shown for titleSeconds; none when the title is empty.
  std::string title, subtitle;
  double titleSeconds = 2.0;
  /// Text at the bottom of every frame; a keyframe's own caption (KeyframeTrack::captionAt)
  /// replaces it while that keyframe's segment plays.
  std::string caption;
  /// Known transforms of the rigid bodies at a frame's time (backward, bodies() order: what
  /// applyRigidity takes as `prescribed`): `vellum pose` gives each bone its joints' exact
  /// transform. Empty: every body is fitted.
  std::function<std::vector<std::optional<RigidTransform>>(double timeS, const deformation::RigidBodies&)>
      knownBodyTransforms;
  /// Each frame's map made elsewhere, from the frame's time and the rigid bodies (null without
  /// them): `vellum pose --map twist` gives the twist map at the frame's angles
  /// (deformation::TwistFrames), so its movie draws the still pose's map. Empty: the track's
  /// control points through the MLS engine with the rigid blend (knownBodyTransforms). Shared,
  /// not copied: a held frame's map is the frame before's (a 512^2 x 350 frame's is 138 MB).
  std::function<std::shared_ptr<const deformation::ControlVolume>(double timeS, const deformation::RigidBodies*)>
      frameMaps;
  /// Each frame's map (MLS, rigid blend, fold repair: CPU) is made on another thread while the
  /// frame before it renders (GL). The frames are the same either way.
  bool overlapFrames = true;
};

/// Rigid bones: the bodies and the blend band; measureStride 0 skips the per-frame measures.
struct MovieRigidity {
  const deformation::RigidBodies* bodies = nullptr;
  double falloffMm = 10;
  int measureStride = 1;
  /// Voxel-level stride of the frames between keyframes (0: measureStride). The frames nearest
  /// each keyframe's time and the last frame are measured at measureStride; each frame's
  /// report carries the stride it was measured at. A movie of a large volume measures its
  /// in-between frames coarser: the measure is a large part of a frame's CPU.
  int inBetweenStride = 0;
  /// False: the frames between keyframes are measured at the node level only (their
  /// voxelsAsRendered is left unmeasured: voxelLevel false, stride 0). On a 512^2 x 350 CT the
  /// voxel-level measure upsamples the whole map (1.1 GB) per frame; the snap keeps the voxels
  /// that land in a bone on its fit whatever the frame, and the keyframe poses are measured in full.
  bool inBetweenVoxels = true;
};

struct FrameRigidity {
  deformation::RigidityReport voxelsAsRendered, nodes;  ///< voxelsAsRendered.voxelLevel: measured
};

struct MovieResult {
  int frames = 0;
  double deformMs = 0, renderMs = 0;
  /// CPU time of the whole process (all threads, the GL driver's included) per stage of the
  /// frames, summed over them: "map" (the control volume with the rigid blend and fold repair,
  /// or waiting for it), "upload" (the map prepared for and sent to the renderer), "render",
  /// "write" (annotations, encoding, PNGs), "measure" (the per-frame rigidity measures). With
  /// overlapFrames the next frame's map is made during "upload" and "render" and counts there.
  std::map<std::string, double> cpuMs;
  deformation::RigidityReport worst;  ///< largest bone residual / fold fraction over the frames
  std::vector<FrameRigidity> perFrame;
  /// With labelled annotations: per frame, where each structure's leader line ends.
  std::vector<std::vector<render::StructureAnchor>> anchors;
};

/// Renders a track one frame per call (so a window can show progress and cancel between
/// frames); renderTrack() is the loop over it.
class MovieRenderer {
 public:
  /// Renders with `context` (headless for the CLI, the studio's window context); the volume is
  /// uploaded and copied into the Deformer here and not referenced later.
  MovieRenderer(render::GlContext& context, const AnyVolume& volume, deformation::KeyframeTrack track,
                const deformation::DeformParams& params, MovieRigidity rigidity, MovieSpec spec);
  ~MovieRenderer();
  /// Title-card frames plus the track's frames.
  int frameCount() const;
  int framesDone() const;
  bool done() const { return framesDone() >= frameCount(); }
  /// Renders and writes the next frame; returns it.
  RgbaImage renderNext();
  /// Closes the movie file; the timings and measures so far.
  MovieResult finish();
  /// The timings and measures so far (without closing anything).
  const MovieResult& result() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Every frame of `track` (validated first) in order, with progress.
MovieResult renderTrack(render::GlContext& context, const AnyVolume& volume, const deformation::KeyframeTrack& track,
                        const deformation::DeformParams& params, const MovieRigidity& rigidity, const MovieSpec& spec,
                        Progress& progress = Progress::none());

}  // namespace vellum::animation
