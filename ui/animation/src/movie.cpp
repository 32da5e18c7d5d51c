#include "vellum/animation/movie.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <future>
#include <optional>

#include "vellum/core/error.hpp"
#include "vellum/core/heap_reuse.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/video_io.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::animation {
namespace fs = std::filesystem;
using namespace vellum::deformation;

namespace {
// The same grid exactly (the frame's map can then be drawn as it is).
bool sameGrid(const Geometry& a, const Geometry& b) {
  return a.dims == b.dims && a.origin == b.origin && a.spacing == b.spacing && a.direction == b.direction;
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Adds the process CPU time since the last lap to `stage`.
struct CpuLap {
  std::map<std::string, double>& into;
  double last = processCpuMs();
  void operator()(const char* stage) {
    const double now = processCpuMs();
    into[stage] += now - last;
    last = now;
  }
};
}  // namespace

struct MovieRenderer::Impl {
  /// First, so that it ends last: every frame's buffers reuse the freed ones (heap_reuse.hpp).
  ReuseFreedMemory heapReuse;
  render::GlContext& context;
  render::VolumeRenderer renderer;
  Deformer deformer;
  KeyframeTrack track;
  MovieRigidity rigidity;
  MovieSpec spec;
  Geometry geometry;
  std::unique_ptr<io::VideoWriter> video;
  std::optional<std::vector<render::StructureCentre>> centres;  ///< of spec.labels, source mm
  int frames = 0, next = 0;  // frames: the track's; next counts the title card's too
  int titleFrames = 0;
  RgbaImage card;  ///< the title card (titleCard())
  MovieResult result;
  /// The next frame's map, made on another thread while this frame renders (the map and the
  /// rigid blend are CPU work; the render is the GL driver's): frame `pendingFrame`, its wall ms.
  std::future<std::pair<std::shared_ptr<const ControlVolume>, double>> pending;
  int pendingFrame = -1;

  ~Impl() {
    if (pending.valid()) pending.wait();  // it uses the deformer and the track
  }

  Impl(render::GlContext& c, const AnyVolume& volume, KeyframeTrack t, const DeformParams& params, MovieRigidity r,
       MovieSpec s)
      : context(c), renderer(c), deformer(volume, params), track(std::move(t)), rigidity(r), spec(std::move(s)),
        geometry(geometryOf(volume)) {
    track.validate();
    frames = track.frameCount(spec.fps);
    if (!spec.title.empty()) titleFrames = std::max(1, static_cast<int>(std::lround(spec.titleSeconds * spec.fps)));
    renderer.setVolume(volume);
    if (spec.tint) renderer.setLabelTint(spec.tint);
    if (!spec.moviePath.empty())
      video = std::make_unique<io::VideoWriter>(spec.moviePath, spec.settings.width, spec.settings.height, spec.fps);
    if (!spec.framesDir.empty()) fs::create_directories(spec.framesDir);
  }

  // Frame f shows a keyframe's pose (the frame nearest its time) or is the last frame.
  bool atKeyframe(int f) const {
    if (f + 1 >= frames) return true;
    double t = 0;
    for (const auto& k : track.keyframes) {
      if (std::lround(t * spec.fps) == f) return true;
      t += k.durationS;
    }
    return std::lround(t * spec.fps) == f;
  }

  void measure(const ControlVolume& cv, int f) {
    // Voxel level over the map the renderer samples: the node map upsampled with the spec's
    // kernel and the voxel snap, as the GL path applies them (deformation::rendered).
    const bool inBetween = !atKeyframe(f);
    if (inBetween && !rigidity.inBetweenVoxels) {
      RigidityReport unmeasured;
      unmeasured.stride = 0;
      result.perFrame.push_back({unmeasured, measureRigidity(cv, *rigidity.bodies)});
      return;
    }
    const int stride = rigidity.inBetweenStride > 0 && inBetween ? rigidity.inBetweenStride : rigidity.measureStride;
    const RigidityReport m = measureRigidityVoxels(cv, geometry, *rigidity.bodies, spec.upsampling, stride);
    result.perFrame.push_back({m, measureRigidity(cv, *rigidity.bodies)});
    RigidityReport& w = result.worst;
    w.boneRmsResidualMm = std::max(w.boneRmsResidualMm, m.boneRmsResidualMm);
    w.boneMaxResidualMm = std::max(w.boneMaxResidualMm, m.boneMaxResidualMm);
    w.foldFraction = std::max(w.foldFraction, m.foldFraction);
    w.softTissueMeanDisplacementMm = std::max(w.softTissueMeanDisplacementMm, m.softTissueMeanDisplacementMm);
    w.components = m.components;
    w.voxelLevel = true;
    w.stride = m.stride;
    w.nodes = m.nodes;
    w.boneNodes = std::max(w.boneNodes, m.boneNodes);
    w.softNodes = std::max(w.softNodes, m.softNodes);
  }

  // Labels follow the anatomy: each output voxel takes the label at its source position.
  LabelVolume deformedLabels(const ControlVolume& cv) const {
    const std::vector<float> u = upsampleMap(cv, geometry, spec.upsampling);
    LabelVolume out(spec.labels->ids().geometry());
    for (const Label& l : spec.labels->table()) out.setLabel(l);
    uint16_t* dst = out.ids().data();
    for (size_t v = 0; v < out.ids().size(); ++v)
      dst[v] = uint16_t(spec.labels->ids().sampleNearestMm({u[3 * v], u[3 * v + 1], u[3 * v + 2]}));
    return out;
  }

  // Each named structure's centre where this frame draws it (the forward image of its source
  // position through the map the renderer samples).
  std::vector<render::StructureCentre> drawnCentres(const render::BackwardMap& map) {
    if (!centres) centres = render::structureCentres(*spec.labels, spec.labelIds);  // source space, once
    std::vector<Vec3> sourceMm;
    for (const auto& c : *centres) sourceMm.push_back(c.mm);
    const auto drawn = render::deformedPositions(map, geometry, sourceMm);
    std::vector<render::StructureCentre> out;
    for (size_t i = 0; i < drawn.size(); ++i)
      if (drawn[i]) out.push_back({(*centres)[i].id, *drawn[i]});
    return out;
  }

  void annotate(RgbaImage& img, const render::RenderSettings& s, const ControlVolume& cv,
                const render::BackwardMap& map) {
    const auto& o = spec.annotations;
    if (!o.scaleBar && !o.orientation && !(o.labels && spec.labels)) return;
    const render::Projection projection(geometry, s, &map.grid);  // framed as the renderer frames the map
    std::vector<render::StructureAnchor> anchors;
    if (o.labels && spec.labels) {
      // Which structures show and where (occlusion), from the labels pulled through the map;
      // then each leader line ends on its structure's drawn centre when that is visible.
      std::vector<uint16_t> footprint;
      anchors = render::structureAnchors(deformedLabels(cv), spec.labelIds, projection, img, 30, &footprint);
      render::moveAnchorsToCentres(anchors, drawnCentres(map), projection, footprint);
      result.anchors.push_back(anchors);
    }
    render::annotate(img, projection, o, anchors);
  }

  void write(const RgbaImage& img) {
    if (video) video->addFrame(img);
    if (!spec.framesDir.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "frame-%05d.png", next);
      io::saveImage(img, spec.framesDir / name);
    }
  }

  // The title card, drawn once for all its frames, on the settings' background colour (an
  // opaque movie frame).
  const RgbaImage& titleCard() {
    if (card.pixels.empty()) {
      card = RgbaImage(spec.settings.width, spec.settings.height);
      const auto& b = spec.settings.background;
      auto byte = [](double v) { return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255)); };
      render::drawTitleCard(card, spec.title, spec.subtitle, {byte(b[0]), byte(b[1]), byte(b[2])});
    }
    return card;
  }

  // Frame f's map as the renderer draws it: the control volume, rigid bones blended in, with
  // the output grid and kernel set (renderedMap()'s fields, without its copy); its wall ms.
  std::pair<std::shared_ptr<const ControlVolume>, double> frameMap(int f) {
    const auto t0 = std::chrono::steady_clock::now();
    if (spec.frameMaps) {  // the map is the caller's (the twist map): no control points, no blend
      std::shared_ptr<const ControlVolume> cv = spec.frameMaps(track.frameTimeS(f, spec.fps), rigidity.bodies);
      if (!cv) throw Error("movie: a frame's map is missing");
      const Geometry& on = cv->output ? *cv->output : cv->grid;
      if (!(on.dims == geometry.dims) || !on.approxEqual(geometry, 1e-3))
        throw Error("movie: a frame's map is not on the volume's grid");
      if (!cv->output || !sameGrid(*cv->output, geometry) || cv->upsampling != spec.upsampling) {
        auto own = std::make_shared<ControlVolume>(*cv);  // drawn on the volume's grid, the spec's kernel
        own->output = geometry;
        own->upsampling = spec.upsampling;
        cv = std::move(own);
      }
      return {std::move(cv), msSince(t0)};
    }
    deformer.setPoints(track.at(track.frameTimeS(f, spec.fps)));
    auto cv = std::make_shared<ControlVolume>(deformer.update());
    if (rigidity.bodies) {
      if (spec.knownBodyTransforms)
        applyRigidity(*cv, *rigidity.bodies, {rigidity.falloffMm},
                      spec.knownBodyTransforms(track.frameTimeS(f, spec.fps), *rigidity.bodies));
      else
        applyRigidity(*cv, *rigidity.bodies, {rigidity.falloffMm});
    }
    cv->output = geometry;
    cv->upsampling = spec.upsampling;
    return {std::move(cv), msSince(t0)};
  }

  RgbaImage renderNext() {
    if (next < titleFrames) {
      const RgbaImage& card = titleCard();
      write(card);
      ++next;
      return card;
    }
    const int f = next - titleFrames;
    CpuLap lap{result.cpuMs};
    // This frame's map (made during the previous frame's render when the frames overlap), then
    // the next frame's started: it runs on the CPU while the GL driver renders this one.
    auto [cvShared, deformMs] = pendingFrame == f ? pending.get() : frameMap(f);
    pendingFrame = -1;
    result.deformMs += deformMs;
    lap("map");
    if (spec.overlapFrames && f + 1 < frames) {
      pendingFrame = f + 1;
      pending = std::async(std::launch::async, [this, f] { return frameMap(f + 1); });
    }
    const ControlVolume& cv = *cvShared;
    const render::BackwardMap& map = cv;
    renderer.setBackwardMap(std::shared_ptr<const render::BackwardMap>(cvShared));
    lap("upload");
    render::RenderSettings s = spec.settings;
    // Keyframed cameras (when the track has any) replace the settings' camera, field by field.
    if (const auto c = track.cameraAt(track.frameTimeS(f, spec.fps))) {
      s.camera.azimuthDeg = c->azimuthDeg;
      s.camera.elevationDeg = c->elevationDeg;
      s.camera.zoom = c->zoom;
      s.camera.panMm = c->panMm;
      if (c->fieldOfViewDeg) s.camera.fieldOfViewDeg = *c->fieldOfViewDeg;
    }
    // Seamless orbit: frame f of n turns f/n of the angle (the last frame does not repeat the first).
    s.camera.azimuthDeg += spec.orbitDeg * f / (track.loop ? frames : std::max(frames - 1, 1));
    const auto t1 = std::chrono::steady_clock::now();
    RgbaImage img = renderer.render(s);
    result.renderMs += msSince(t1);
    lap("render");
    annotate(img, s, cv, map);
    const std::string caption = track.captionAt(track.frameTimeS(f, spec.fps));
    render::drawCaption(img, caption.empty() ? spec.caption : caption, spec.annotations.textHeightPx);
    write(img);
    lap("write");
    if (rigidity.bodies && rigidity.measureStride > 0) measure(cv, f);
    lap("measure");
    ++next;
    return img;
  }
};

MovieRenderer::MovieRenderer(render::GlContext& context, const AnyVolume& volume, KeyframeTrack track,
                             const DeformParams& params, MovieRigidity rigidity, MovieSpec spec)
    : impl_(std::make_unique<Impl>(context, volume, std::move(track), params, rigidity, std::move(spec))) {}
MovieRenderer::~MovieRenderer() = default;
int MovieRenderer::frameCount() const { return impl_->titleFrames + impl_->frames; }
int MovieRenderer::framesDone() const { return impl_->next; }
RgbaImage MovieRenderer::renderNext() { return impl_->renderNext(); }
const MovieResult& MovieRenderer::result() const { return impl_->result; }

MovieResult MovieRenderer::finish() {
  if (impl_->video) {
    impl_->video->finish();
    impl_->video.reset();
  }
  MovieResult r = impl_->result;
  r.frames = impl_->next;
  return r;
}

MovieResult renderTrack(render::GlContext& context, const AnyVolume& volume, const KeyframeTrack& track,
                        const DeformParams& params, const MovieRigidity& rigidity, const MovieSpec& spec,
                        Progress& progress) {
  MovieRenderer movie(context, volume, track, params, rigidity, spec);
  progress.begin("frames", static_cast<uint64_t>(movie.frameCount()));
  while (!movie.done()) {
    movie.renderNext();
    progress.advance();
  }
  progress.end();
  return movie.finish();
}

}  // namespace vellum::animation
