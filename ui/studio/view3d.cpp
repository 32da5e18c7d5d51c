#include "view3d.hpp"
#include "thread_priority.hpp"
#include "vellum/core/box_corners.hpp"

#include <GL/glcorearb.h>
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <future>
#include <thread>
#include <sstream>

namespace vellum::studio {

render::RenderSettings renderSettingsFor(const Scene& scene, int width, int height) {
  render::RenderSettings s = scene.render;
  s.width = std::clamp(width, 1, 4096);
  s.height = std::clamp(height, 1, 4096);
  return s;
}

illustration::IllustrationSettings illustrationSettingsFor(const Scene& scene, int width, int height) {
  illustration::IllustrationSettings s;
  const render::RenderSettings r = renderSettingsFor(scene, width, height);
  s.render.width = r.width;
  s.render.height = r.height;
  s.render.camera = r.camera;
  s.render.jitter = r.jitter;
  const auto& bg = scene.illustration.style.background;
  s.render.background = {bg[0], bg[1], bg[2], 1.f};
  return s;
}

CameraBasis cameraBasis(const render::Camera& cam) {
  // As modules/render/src/render_common.cpp builds its frame.
  const double az = cam.azimuthDeg * M_PI / 180.0, el = cam.elevationDeg * M_PI / 180.0;
  CameraBasis b;
  b.forward = -Vec3{std::cos(el) * std::sin(az), -std::cos(el) * std::cos(az), std::sin(el)};
  b.right = {std::cos(az), std::sin(az), 0};
  b.up = cross(b.right, b.forward);
  return b;
}

std::optional<std::pair<double, double>> projectToView(const Scene& scene, int width, int height, const Vec3& p) {
  // The orbit camera of render::RenderSettings (modules/render/src/render_common.cpp).
  const Geometry& g = scene.ct.geometry();
  const Vec3 centre = g.center();
  const double radius = voxelBoxRadius(g, centre);
  const render::Camera& cam = scene.render.camera;
  const Vec3 lookAt = centre + cam.panMm;
  const auto [right, up, forward] = cameraBasis(cam);
  const double aspect = double(width) / height;
  const double sx = aspect >= 1 ? aspect : 1.0, sy = aspect >= 1 ? 1.0 : 1.0 / aspect;
  double x, y, halfW, halfH;
  if (cam.fieldOfViewDeg > 0) {
    const double half = cam.fieldOfViewDeg * M_PI / 360.0;
    const Vec3 eye = lookAt - forward * (radius / std::sin(half));
    const Vec3 d = p - eye;
    const double z = dot(d, forward);
    if (z <= 1e-6) return std::nullopt;
    x = dot(d, right) / z;
    y = dot(d, up) / z;
    halfW = std::tan(half) / cam.zoom * sx;
    halfH = std::tan(half) / cam.zoom * sy;
  } else {
    x = dot(p - lookAt, right);
    y = dot(p - lookAt, up);
    halfW = radius / cam.zoom * sx;
    halfH = radius / cam.zoom * sy;
  }
  return std::pair{(x / halfW + 1) / 2 * width, (1 - y / halfH) / 2 * height};
}

namespace {
/// Bounding-sphere radius of the volume's voxel box about its centre (the renderer's).
double boundingRadius(const Geometry& g) { return voxelBoxRadius(g, g.center()); }
}  // namespace

namespace {
/// Marches the ray origin + t dir, 0 <= t < stop, through the volume as the 3D view draws it
/// (through `map` when given: the volume is background where the map has no source), and
/// returns the first t where the preset's opacity (shifted by the render window as the
/// renderer does) has stopped half the light; for MIP, the t of the maximum when it is above
/// the window's floor.
std::optional<double> firstVisible(const Scene& scene, const deformation::MapSampler* map, const Vec3& origin,
                                   const Vec3& dir, double stop) {
  const Geometry& g = scene.ct.geometry();
  const Vec3& sp = g.spacing;
  const double step = 0.5 * std::min({sp.x, sp.y, sp.z});
  const bool mip = scene.render.preset == render::Preset::Mip;
  const render::TransferFunction tf = render::TransferFunction::forPreset(scene.render.preset);
  const double w = scene.render.windowWidth > 0 ? scene.render.windowWidth : 2000.0;
  double transmitted = 1, best = -1e300;
  std::optional<double> bestT;
  for (double t = 0; t < stop; t += step) {
    const Vec3 v = origin + dir * t;
    const std::optional<Vec3> u = map ? map->sourceMm(v) : std::optional<Vec3>(v);
    const double hu = u ? scene.ct.sampleLinearMm(*u) : scene.ct.background();
    if (mip) {
      if (hu > best) best = hu, bestT = t;
      continue;
    }
    const double alphaPerMm = tf.evaluate(400.0 + (hu - scene.render.windowCenter) * 2000.0 / w)[3];
    transmitted *= std::pow(1.0 - std::clamp(alphaPerMm, 0.0, 0.999999), step);
    if (transmitted <= 0.5) return t;
  }
  if (mip && best > scene.render.windowCenter - 0.5 * w) return bestT;
  return std::nullopt;
}
}  // namespace

std::optional<Vec3> pickSurface(const Scene& scene, int width, int height, double px, double py,
                                const deformation::MapSampler* map) {
  if (!scene.hasVolume() || width < 1 || height < 1) return std::nullopt;
  const Geometry& g = scene.ct.geometry();
  const render::Camera& cam = scene.render.camera;
  const double radius = boundingRadius(g);
  const Vec3 lookAt = g.center() + cam.panMm;
  const CameraBasis b = cameraBasis(cam);
  const double aspect = double(width) / height;
  const double sx = aspect >= 1 ? aspect : 1.0, sy = aspect >= 1 ? 1.0 : 1.0 / aspect;
  const double ndcX = px / width * 2 - 1, ndcY = 1 - py / height * 2;
  Vec3 origin, dir;
  if (cam.fieldOfViewDeg > 0) {  // the renderer's pixelRay()
    const double half = cam.fieldOfViewDeg * M_PI / 360.0;
    origin = lookAt - b.forward * (radius / std::sin(half));
    const double t = std::tan(half) / cam.zoom;
    dir = normalized(b.forward + b.right * (ndcX * t * sx) + b.up * (ndcY * t * sy));
  } else {
    origin = lookAt - b.forward * (2 * radius + norm(cam.panMm) + 1.0) +
             b.right * (ndcX * radius / cam.zoom * sx) + b.up * (ndcY * radius / cam.zoom * sy);
    dir = b.forward;
  }
  const auto t = firstVisible(scene, map, origin, dir, norm(origin - g.center()) + 2 * radius);
  if (!t) return std::nullopt;
  return origin + dir * *t;
}

bool occludedInView(const Scene& scene, const deformation::MapSampler* map, const Vec3& mm) {
  if (!scene.hasVolume() || scene.render.preset == render::Preset::Mip) return false;
  const Geometry& g = scene.ct.geometry();
  const render::Camera& cam = scene.render.camera;
  const double radius = boundingRadius(g);
  const CameraBasis b = cameraBasis(cam);
  Vec3 origin, dir;
  if (cam.fieldOfViewDeg > 0) {
    const double half = cam.fieldOfViewDeg * M_PI / 360.0;
    origin = g.center() + cam.panMm - b.forward * (radius / std::sin(half));
    dir = normalized(mm - origin);
  } else {
    dir = b.forward;
    origin = mm - dir * (2 * radius + norm(cam.panMm) + 1.0);
  }
  const Vec3& sp = g.spacing;
  const double voxel = std::min({sp.x, sp.y, sp.z});
  return firstVisible(scene, map, origin, dir, norm(mm - origin) - voxel).has_value();
}

namespace {
/// What a frame depends on; a change means "render again".
std::string viewKey(const Scene& s, int w, int h) {
  // Every render-table field, so a new setting cannot be forgotten here.
  std::ostringstream k;
  k.precision(17);
  const auto& pan = s.render.camera.panMm;
  k << w << ' ' << h << params::cliArguments(render::renderSettingsTable(), s.render, renderKeysNotInScene()) << ' '
    << pan.x << ' ' << pan.y << ' ' << pan.z;
  return k.str();
}
}  // namespace

View3D::View3D(render::GlContext& context)
    : context_(context), renderer_(std::make_unique<render::VolumeRenderer>(context)), coarse_(context), full_(context),
      meshLayer_(context) {
  // GLFW windows are made on the thread that made the window's (this one); the worker only
  // makes the hidden one's context current. The window hints (GL version, profile) are the
  // window's, still set. Without GLFW (headless tests) glfwGetCurrentContext() gives null.
  if (GLFWwindow* window = glfwGetCurrentContext()) {
    glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
    uploadWindow_ = glfwCreateWindow(16, 16, "vellum upload", nullptr, window);
    glfwWindowHint(GLFW_VISIBLE, GLFW_TRUE);
    glfwMakeContextCurrent(window);
  }
}

View3D::~View3D() {
  if (volumeJob_.valid()) {  // its textures go with the context
    try {
      renderer_->discardVolumeTextures(volumeJob_.get());
    } catch (const std::exception&) {
    }
  }
  if (uploadWindow_) glfwDestroyWindow(static_cast<GLFWwindow*>(uploadWindow_));
  context_.makeCurrent();
}

void View3D::warmUp(const Scene& scene) {
  if (warmed_ || hasVolume_) return;
  warmed_ = true;
  context_.makeCurrent();
  // llvmpipe keys the code it generates on the textures' formats and on whether each axis is a
  // power of two: the tiny volume is a 512x512xN CT's pattern (x, y powers of two, z not; its
  // 8-voxel blocks the same), the CT's voxel type.
  Geometry g;
  g.dims = {16, 16, 24};
  VolumeI16 tiny(g, int16_t(-1000), -1000.0);
  for (int64_t k = 4; k < 20; ++k)
    for (int64_t j = 4; j < 12; ++j)
      for (int64_t i = 4; i < 12; ++i) tiny(i, j, k) = 1200;  // bone: every preset draws it
  renderer_->setVolume(AnyVolume(tiny));
  render::FramebufferTarget target(context_);
  target.resize(8, 8);
  render::RenderSettings s = renderSettingsFor(scene, 8, 8);
  renderer_->renderInto(s, target.volumeTarget(false));
  // The deformed variant the studio draws: an identity map with an output box and a rigid snap.
  // Its grid as a control grid is (no axis a power of two), over the tiny volume.
  Geometry nodes = g;
  nodes.dims = {9, 9, 13};
  nodes.spacing = {2, 2, 2};
  render::BackwardMap map = render::identityBackwardMap(nodes, {}, g);
  map.upsampling = scene.view.deformedUpsampling;
  renderer_->setBackwardMap(&map);  // without rigid labels
  renderer_->renderInto(s, target.volumeTarget(false));
  auto snap = std::make_shared<RigidSnap>();
  snap->classes = std::make_shared<const std::vector<uint16_t>>(size_t(g.dims.voxelCount()), uint16_t(2));
  snap->classGrid = g;
  snap->fits = {{1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0}};
  snap->valid = {1};
  snap->maxSnapMm = 1;
  map.rigidSnap = snap;
  renderer_->setBackwardMap(&map);
  renderer_->renderInto(s, target.volumeTarget(false));
  renderer_->setBackwardMap(nullptr);
  {
    // What a refinement does first: the coarse frame scaled up into the full-size target (a
    // linear blit: Mesa makes its blit shader on first use, 0.1-0.2 s under load), then a tile.
    // llvmpipe keys the blit's code on whether the sizes are powers of two: a pane's are not.
    render::FramebufferTarget small(context_), big(context_);
    small.resize(7, 5);
    renderer_->renderInto(renderSettingsFor(scene, 7, 5), small.volumeTarget(false));
    big.resize(15, 13);
    big.copyColourScaled(small);
    renderer_->renderIntoTile(renderSettingsFor(scene, 15, 13), big.volumeTarget(false), 0, 8, 0, 8);
  }
  glFinish();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void View3D::startScales(const Dims& dims) {
  // A coarse ray's cost grows with the volume: at 1/4 of a 474x399 pane the first frame of
  // 512^2 x 350 took 0.6 s under load (about 50 us a pixel), so big volumes start coarser and
  // the adaptation (renderCoarse) refines the scale from the frames' own times.
  const double voxels = double(dims.voxelCount());
  scale_ = voxels > double(1 << 26) ? 16 : voxels > double(1 << 24) ? 8 : 4;
  stepFactor_ = otherStepFactor_ = 1;
  otherScale_ = 16;  // the deformed view's (see otherScale_)
  coarseDeformed_ = false;
}

void View3D::setVolume(const VolumeI16& ct) {
  startScales(ct.dims());
  context_.makeCurrent();
  dropPendingMaps();
  volumePrepared_.reset();
  renderer_->setVolume(AnyVolume(ct));  // drops the label tint
  labelsKey_.clear();
  hasVolume_ = true;
  invalidate();
}

namespace {
// On the upload worker: 8 MB a call, a pause between calls: the window's draws wait for Mesa's
// lock on shared objects while a call copies (350 MB of normals, no longer made, in one call:
// a 0.9 s frame under load).
template <class V>
std::shared_ptr<render::VolumeRenderer::VolumeTextures> fillVolumeTextures(const V& volume,
                                                                         const render::VolumeRenderer::Prepared& p) {
  return render::VolumeRenderer::makeVolumeTextures(volume, p, size_t(8) << 20,
                                                    [] { std::this_thread::sleep_for(std::chrono::milliseconds(2)); });
}
}  // namespace

bool View3D::uploadVolumeStep(const VolumeI16& ct, std::shared_ptr<const render::VolumeRenderer::Prepared> prepared,
                              size_t maxBytes) {
  if (uploadWindow_) {
    const VolumeI16* volume = &ct;  // the caller keeps it until this returns true
    auto make = [volume, p = prepared] { return fillVolumeTextures(*volume, *p); };  // before prepared moves
    return uploadOnWorker(std::move(make), ct.geometry().dims, std::move(prepared));
  }
  if (!stepSource_ || volumePrepared_ != prepared) stepSource_ = std::make_shared<const AnyVolume>(ct);
  if (!uploadVolumeStep(stepSource_, std::move(prepared), maxBytes)) return false;
  stepSource_.reset();
  return true;
}

bool View3D::uploadVolumeStep(std::shared_ptr<const AnyVolume> ct,
                              std::shared_ptr<const render::VolumeRenderer::Prepared> prepared, size_t maxBytes) {
  if (uploadWindow_) {
    const Dims dims = geometryOf(*ct).dims;
    auto make = [ct, p = prepared] { return fillVolumeTextures(*ct, *p); };  // before prepared moves
    return uploadOnWorker(std::move(make), dims, std::move(prepared));
  }
  context_.makeCurrent();
  hasVolume_ = false;  // the renderer has dropped the previous volume
  if (volumePrepared_ != prepared) dropPendingMaps();  // made for the previous volume
  volumePrepared_ = prepared;
  const Dims dims = geometryOf(*ct).dims;
  if (!renderer_->uploadVolumeStep(std::move(ct), std::move(prepared), maxBytes)) return false;
  startScales(dims);
  labelsKey_.clear();
  hasVolume_ = true;
  invalidate();
  return true;
}

bool View3D::uploadOnWorker(std::function<VolumeTextures()> make, Dims dims,
                            std::shared_ptr<const render::VolumeRenderer::Prepared> prepared) {
  if (volumePrepared_ != prepared) {  // a new volume: nothing drawn until it is complete
    dropPendingMaps();  // made for the previous volume
    volumePrepared_ = prepared;
    hasVolume_ = false;
  }
  if (volumeJob_.valid()) {
    if (volumeJob_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return false;
    VolumeTextures textures = volumeJob_.get();  // rethrows the worker's error
    if (jobFor_ == prepared) {
      context_.makeCurrent();
      renderer_->adoptVolumeTextures(textures, *prepared);
      startScales(jobDims_);
      jobFor_.reset();
      labelsKey_.clear();
      hasVolume_ = true;
      invalidate();
      return true;
    }
    renderer_->discardVolumeTextures(textures);  // made for a volume since replaced
  }
  // One job at a time: the hidden context is current on one thread at most.
  jobFor_ = prepared;
  jobDims_ = dims;
  volumeJob_ = std::async(std::launch::async, [window = static_cast<GLFWwindow*>(uploadWindow_), make = std::move(make)] {
    lowerThreadPriority();
    glfwMakeContextCurrent(window);
    struct Release {  // the context is free again for the next job, whatever happens
      ~Release() { glfwMakeContextCurrent(nullptr); }
    } release;
    return make();  // fillVolumeTextures
  });
  return false;
}

bool View3D::wantsLight(const Scene& scene) const {
  return !illustrating(scene) && render::VolumeRenderer::usesLightSource(renderSettingsFor(scene, 8, 8));
}

void View3D::stepLight(const Scene& scene) {
  if (lightJob_.valid()) {
    if (lightJob_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    auto light = lightJob_.get();  // rethrows the worker's error
    // Dropped when the volume changed meanwhile (the studio adopts none while this runs).
    if (hasVolume_ && lightFor_ == volumePrepared_ && !renderer_->hasLightSource()) {
      context_.makeCurrent();
      renderer_->setLightSource(std::move(light));
      invalidate();  // drawn again, lit
    }
    lightFor_.reset();
  }
  if (!hasVolume_ || renderer_->hasLightSource() || !wantsLight(scene)) return;
  lightFor_ = volumePrepared_;
  lightJob_ = std::async(std::launch::async, [&ct = scene.ct] {
    lowerThreadPriority();
    return inWorkerArena([&] { return render::VolumeRenderer::makeLightSource(ct); });
  });
}

void View3D::lightNow(const Scene& scene) {
  if (!hasVolume_ || renderer_->hasLightSource() || !wantsLight(scene)) return;
  if (lightJob_.valid()) lightJob_.wait();
  stepLight(scene);  // adopts a finished job
  if (renderer_->hasLightSource()) return;
  if (lightJob_.valid()) lightJob_.wait(), stepLight(scene);  // one started for this volume
  if (renderer_->hasLightSource()) return;
  context_.makeCurrent();
  renderer_->setLightSource(render::VolumeRenderer::makeLightSource(scene.ct));
  invalidate();
}

void View3D::setBackwardMap(std::shared_ptr<const render::BackwardMap> map, uint64_t revision) {
  if (map && volumePrepared_) {
    nextMap_ = MapRequest{std::move(map), revision};  // replaces one the worker has not started
    stepMap(0);                                        // starts the worker when it is free
    return;
  }
  dropPendingMaps();
  context_.makeCurrent();
  renderer_->setBackwardMap(map.get());
  hasMap_ = map != nullptr;
  mapRevision_ = revision;
}

void View3D::dropPendingMaps() {
  nextMap_.reset();
  preparingStale_ = preparing_.valid();  // its result is dropped when it lands (no wait here)
  uploading_.reset();
}

bool View3D::stepMap(size_t maxBytes) {
  using Future = decltype(preparing_);
  if (preparing_.valid() && preparing_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    auto prepared = preparing_.get();
    if (!preparingStale_) {
      uploading_ = std::move(prepared);  // a newer map replaces one still uploading
      uploadingRevision_ = preparingRevision_;
    }
    preparingStale_ = false;
  }
  if (!preparing_.valid() && nextMap_) {
    preparingRevision_ = nextMap_->revision;
    preparing_ = Future(std::async(std::launch::async, [map = std::move(nextMap_->map), volume = volumePrepared_] {
      lowerThreadPriority();
      return inWorkerArena([&] { return render::VolumeRenderer::prepareBackwardMap(map, *volume); });
    }));
    nextMap_.reset();
  }
  if (!uploading_ || maxBytes == 0 || !hasVolume_) return false;  // after the volume's own upload
  context_.makeCurrent();
  if (!renderer_->uploadBackwardMapStep(uploading_, maxBytes)) return false;
  uploading_.reset();
  hasMap_ = true;
  mapRevision_ = uploadingRevision_;
  return true;
}

void View3D::setLabels(const LabelVolume& labels, const std::set<uint16_t>& hidden, uint64_t revision, bool wanted) {
  if (!hasVolume_ || !wanted || labels.ids().empty()) return;  // the tint is made when first wanted
  std::string key = std::to_string(revision);
  for (uint16_t id : hidden) {
    key += ' ';  // not " " + a temporary: GCC 12's false -Wrestrict at -O3 (panel_deformation.cpp)
    key += std::to_string(id);
  }
  if (key == labelsKey_) return;
  context_.makeCurrent();
  const render::LabelTint tint = render::makeLabelTint(labels, hidden);
  renderer_->setLabelTint(&tint);
  labelsKey_ = key;
  invalidate();
}

void View3D::setShapes(std::shared_ptr<const illustration::ShapeScene> shapes, uint64_t revision) {
  if (shapes == shapes_ && revision == shapesRevision_) return;
  context_.makeCurrent();
  if (shapes) {
    if (!illustrator_) illustrator_ = std::make_unique<illustration::IllustrationRenderer>(context_);
    illustrator_->setScene(*shapes);
  }
  shapes_ = std::move(shapes);
  shapesRevision_ = revision;
  invalidate();
}

void View3D::setMeshes(std::shared_ptr<const SegmentMeshes> meshes, const std::set<uint16_t>& hidden, uint64_t revision) {
  if (meshes != meshes_ || revision != meshesRevision_) {
    meshes_ = std::move(meshes);
    meshesRevision_ = revision;
    if (meshes_ && !meshes_->empty()) {
      context_.makeCurrent();
      if (!meshRenderer_) meshRenderer_ = std::make_unique<render::MeshRenderer>(context_);
      meshRenderer_->setMeshes(toSurfaceMeshes(*meshes_));
    }
    invalidate();
  }
  // Which meshes show is part of the view key (update()), so hiding a label re-renders only
  // when the meshes are drawn.
  meshVisible_ = meshes_ ? visibleMeshes(*meshes_, hidden) : std::vector<bool>{};
}

namespace {
/// Rays stop this many voxels short of a mesh: a mesh made from a segment coincides with the
/// segment's blurred boundary in the CT, whose first opaque samples (jittered) otherwise
/// speckle over it. 1 voxel still speckled at silhouettes on the phantom; 2 did not.
constexpr double kMeshDepthBiasVoxels = 2.0;

double meshDepthBiasMm(const Scene& scene) {
  const Vec3& sp = scene.ct.geometry().spacing;
  return kMeshDepthBiasVoxels * std::min({sp.x, sp.y, sp.z});
}
}  // namespace

bool View3D::drawingMeshes(const Scene& scene) const {
  // Meshes live in the source's space: through a deformation they would not match the volume.
  return scene.view.meshesIn3d && !illustrating(scene) && !hasMap_ && meshRenderer_ && meshes_ &&
         std::find(meshVisible_.begin(), meshVisible_.end(), true) != meshVisible_.end();
}

void View3D::drawFrame(const Scene& scene, render::FramebufferTarget& target, int stepFactor) {
  render::RenderSettings s = renderSettingsFor(scene, target.width(), target.height());
  s.stepVoxels *= stepFactor;
  const bool meshes = drawingMeshes(scene);
  if (meshes) {
    target.clear({0, 0, 0, 0});
    meshRenderer_->draw(render::Projection(scene.ct.geometry(), s), target, meshVisible_, meshDepthBiasMm(scene));
  }
  renderer_->renderInto(s, target.volumeTarget(meshes));
}

RgbaImage View3D::renderImage(const Scene& scene, int width, int height) {
  context_.makeCurrent();
  if (illustrating(scene)) {
    RgbaImage img = illustrator_->render(scene.illustration.style, illustrationSettingsFor(scene, width, height));
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    return img;
  }
  lightNow(scene);
  const render::RenderSettings s = renderSettingsFor(scene, width, height);
  if (!drawingMeshes(scene)) {  // `vellum render`'s pixels
    RgbaImage img = renderer_->render(s);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);  // the renderer leaves its FBO bound
    return img;
  }
  render::FramebufferTarget target(context_);
  target.resize(s.width, s.height);
  drawFrame(scene, target);
  return target.readColour();
}

RgbaImage View3D::readShown() {
  if (cinematic_ && shown_ != 0 && shown_ == texture_.id()) return cinematicImage_;
  context_.makeCurrent();
  if (shown_ != 0 && shown_ == full_.colourTexture()) return full_.readColour();
  if (shown_ != 0 && shown_ == coarse_.colourTexture()) return coarse_.readColour();
  return {};
}

std::vector<double> View3D::predictRowCosts(const RgbaImage& coarse, int height) const {
  // Rays that hit something cost far more than rays through empty space or past the volume:
  // weight each full-resolution row by the object pixels of the matching coarse row.
  std::vector<double> cost(static_cast<size_t>(height), 1.0);
  if (coarse.width == 0 || coarse.height == 0) return cost;
  const uint8_t* bg = coarse.at(0, 0);  // a corner: the background colour
  for (int y = 0; y < height; ++y) {
    const int cy = std::min(coarse.height - 1, y * coarse.height / height);
    int hits = 0;
    for (int x = 0; x < coarse.width; ++x) {
      const uint8_t* p = coarse.at(x, cy);
      hits += p[0] != bg[0] || p[1] != bg[1] || p[2] != bg[2];
    }
    cost[static_cast<size_t>(y)] += 10.0 * hits * (double(scale_) * scale_);
  }
  return cost;
}

std::vector<double> View3D::columnCosts(int row0, int row1, int width) const {
  // The row model spread over the row: 1 per row for the background, 10 * scale² per coarse
  // hit pixel (scale full-resolution pixels wide), as predictRowCosts.
  std::vector<double> cost(static_cast<size_t>(width), double(row1 - row0) / width);
  const int cw = coarseImage_.width, ch = coarseImage_.height;
  if (cw == 0 || ch == 0 || hit_.size() != size_t(cw) * ch) return cost;
  const double perHit = 10.0 * scale_;
  for (int y = row0; y < row1; ++y) {
    const int cy = std::min(ch - 1, y * ch / refineHeight_);
    for (int x = 0; x < width; ++x)
      if (hit_[size_t(cy) * cw + std::min(cw - 1, x * cw / width)]) cost[size_t(x)] += perHit;
  }
  return cost;
}

void View3D::renderCoarse(const Scene& scene, int paneWidth, int paneHeight, const std::string& key) {
  const auto t0 = std::chrono::steady_clock::now();
  if (hasMap_ != coarseDeformed_) {  // the other kind of view: its own learnt resolution
    std::swap(scale_, otherScale_);
    std::swap(stepFactor_, otherStepFactor_);
    coarseDeformed_ = hasMap_;
  }
  const int w = std::max(1, paneWidth / scale_), h = std::max(1, paneHeight / scale_);
  if (illustrating(scene)) {  // the illustration renderer reads back: upload its image
    coarseImage_ = renderImage(scene, w, h);
    texture_.upload(coarseImage_);
    shown_ = texture_.id();
    shownBottomUp_ = false;
    lastMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  } else {  // drawn in place: nothing read back or uploaded
    context_.makeCurrent();
    coarse_.resize(w, h);
    drawFrame(scene, coarse_, stepFactor_);
    // Pacing needs the frame's real cost: llvmpipe's timer queries miss deferred rasterisation
    // (docs/benchmarks-render.md), so wait for the draw (the swap would wait for it anyway).
    glFinish();
    shown_ = coarse_.colourTexture();
    shownBottomUp_ = true;
    lastMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  lastScale_ = scale_;
  lastStepFactor_ = stepFactor_;
  lastKey_ = key;
  refined_ = cinematic_ = false;  // a changed view: the path-traced picture starts again
  // Cost scales with pixels: halve the resolution when over budget; double it only when 4x
  // the pixels are predicted to fit (hysteresis: no oscillation between two factors).
  // Up to 1/16: a deformed 512²×350 volume on llvmpipe is over budget even at 1/8. Beyond
  // that the ray step grows (2x, 4x: the deformed rays' cost is per sample, and 1/32 of the
  // pane would be a few hundred pixels); the step comes back first. The refined picture
  // always has the scene's step.
  if (lastMs_ > kInteractiveBudgetMs) {
    if (scale_ < 16) scale_ *= 2;
    else if (stepFactor_ < 4) stepFactor_ *= 2;
  } else if (stepFactor_ > 1) {
    if (lastMs_ * 2 < kInteractiveBudgetMs * 0.9) stepFactor_ /= 2;
  } else if (lastMs_ * 4 < kInteractiveBudgetMs * 0.9 && scale_ > 2) {
    scale_ /= 2;
  }
}

void View3D::startRefinement(const Scene& scene, int paneWidth, int paneHeight) {
  refining_ = true;
  refineRow_ = 0;
  refineHeight_ = paneHeight;
  refineMs_ = 0;
  context_.makeCurrent();
  // Start from the coarse frame scaled up, so each band can be shown as it lands.
  full_.resize(paneWidth, paneHeight);
  if (coarse_.width() > 0) full_.copyColourScaled(coarse_);
  if (drawingMeshes(scene)) {  // the meshes once at full resolution; each band copies its rows
    meshLayer_.resize(paneWidth, paneHeight);
    meshLayer_.clear({0, 0, 0, 0});
    meshRenderer_->draw(render::Projection(scene.ct.geometry(), renderSettingsFor(scene, paneWidth, paneHeight)),
                        meshLayer_, meshVisible_, meshDepthBiasMm(scene));
  }
  coarseImage_ = coarse_.width() > 0 ? coarse_.readColour() : RgbaImage();  // small, finished frames ago
  rowCost_ = predictRowCosts(coarseImage_, paneHeight);
  hit_.assign(size_t(coarseImage_.width) * coarseImage_.height, 0);
  if (!hit_.empty()) {
    const uint8_t* bg = coarseImage_.at(0, 0);
    for (int y = 0; y < coarseImage_.height; ++y)
      for (int x = 0; x < coarseImage_.width; ++x) {
        const uint8_t* p = coarseImage_.at(x, y);
        hit_[size_t(y) * coarseImage_.width + x] = p[0] != bg[0] || p[1] != bg[1] || p[2] != bg[2];
      }
  }
  refineCol_ = bandRows_ = refineTiles_ = 0;
  if (rateDeformed_ != hasMap_) probe_ = true;
  rateDeformed_ = hasMap_;
  shown_ = full_.colourTexture();
  shownBottomUp_ = true;
}

bool View3D::update(const Scene& scene, int paneWidth, int paneHeight, bool interacting) {
  if (!hasVolume_ || paneWidth < 2 || paneHeight < 2) return false;
  std::string key = viewKey(scene, paneWidth, paneHeight) + " map " + std::to_string(mapRevision_);
  if (illustrating(scene))  // the style is small: its JSON is the key
    key += " shapes " + std::to_string(shapesRevision_) + illustration::styleToJson(scene.illustration.style);
  if (drawingMeshes(scene)) {
    key += " meshes " + std::to_string(meshesRevision_) + ' ';
    for (bool v : meshVisible_) key += v ? '1' : '0';
  }
  if (interacting) {  // coarse frames only, each a complete picture
    refining_ = false;
    if (key == lastKey_) return false;
    renderCoarse(scene, paneWidth, paneHeight, key);
    return true;
  }
  if (key == lastKey_ && refined_) return false;
  if (key != lastKey_) {
    // Changed without a drag (preset, layout, a panel value): show a coarse frame at once.
    renderCoarse(scene, paneWidth, paneHeight, key);
    refining_ = false;
    return true;
  }
  if (illustrating(scene)) {  // the illustration renderer draws whole frames: one full render
    const auto t0 = std::chrono::steady_clock::now();
    coarseImage_ = renderImage(scene, paneWidth, paneHeight);
    texture_.upload(coarseImage_);
    shown_ = texture_.id();
    shownBottomUp_ = false;
    lastMs_ = refineMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    lastScale_ = 1;
    refined_ = true;
    return true;
  }
  if (cinematic(scene)) return refineCinematic(scene, paneWidth, paneHeight);
  // Idle: refine to full resolution a band of rows per frame, each band sized to the
  // interactive budget, so that no frame blocks for a whole full-resolution render.
  if (!refining_) startRefinement(scene, paneWidth, paneHeight);
  if (refineCol_ == 0) {
    // The band: as many rows as the predicted cost allows within the budget.
    int rows = 0;
    double cost = 0;
    for (; refineRow_ + rows < paneHeight; ++rows) {
      const double next = cost + rowCost_[static_cast<size_t>(refineRow_ + rows)];
      if (rows >= 1 && next * msPerCost_ > budgetMs_) break;
      cost = next;
    }
    // One row already over the budget (a deformed real-size volume on llvmpipe: 0.2-0.5 s per
    // row under load): a band of kTileRows rows drawn as column tiles, a few per frame.
    if (probe_ || (rows == 1 && cost * msPerCost_ > budgetMs_)) rows = std::min(kTileRows, paneHeight - refineRow_);
    bandRows_ = rows;
  }
  const int row0 = refineRow_, row1 = refineRow_ + bandRows_;
  int col1 = paneWidth;
  double tileCost = 0;
  if (refineCol_ > 0 || bandRows_ > 1) {
    // Columns while the predicted cost fits (at least kMinTileCols); a whole-width band when
    // it all fits.
    const std::vector<double> cols = columnCosts(row0, row1, paneWidth);
    double all = 0;
    for (int x = refineCol_; x < paneWidth; ++x) all += cols[size_t(x)];
    if (refineCol_ == 0 && !probe_ && all * msPerCost_ <= budgetMs_) {
      tileCost = all;
    } else {
      col1 = refineCol_;
      while (col1 < paneWidth) {
        const double next = tileCost + cols[size_t(col1)];
        if (col1 - refineCol_ >= kMinTileCols && (probe_ || next * msPerCost_ > budgetMs_)) break;
        tileCost = next;
        ++col1;
      }
      if (paneWidth - col1 < kMinTileCols) {  // no sliver left for its own frame
        for (; col1 < paneWidth; ++col1) tileCost += cols[size_t(col1)];
      }
    }
  } else {
    tileCost = rowCost_[static_cast<size_t>(row0)];
  }
  const auto t0 = std::chrono::steady_clock::now();
  context_.makeCurrent();
  render::RenderTarget target = full_.volumeTarget(false);
  if (drawingMeshes(scene)) {  // the meshes' rows under the band, rays stopped at their depth
    if (refineCol_ == 0) full_.copyColourRows(meshLayer_, row0, row1);  // once per band
    target.opaqueDepth = meshLayer_.depthTexture();
  }
  renderer_->renderIntoTile(renderSettingsFor(scene, paneWidth, paneHeight), target, refineCol_, col1, row0, row1);
  glFinish();  // the tile's real cost teaches the cost per row (see renderCoarse)
  lastMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  // The rate rises at once and falls slowly: learnt from one tile alone it swung from a cheap
  // tile (4 ms) to a next tile 20x over the budget on the deformed real CT.
  const double observed = std::max(1e-6, lastMs_ / std::max(tileCost, 1e-9));
  msPerCost_ = observed > msPerCost_ || probe_ ? observed : 0.75 * msPerCost_ + 0.25 * observed;
  probe_ = false;
  refineMs_ += lastMs_;
  ++refineTiles_;
  lastScale_ = 1;
  refineCol_ = col1 >= paneWidth ? 0 : col1;
  if (refineCol_ == 0) refineRow_ += bandRows_;
  if (refineRow_ >= paneHeight) {
    refined_ = true;
    refining_ = false;
  }
  return true;
}

bool View3D::cinematic(const Scene& scene) const {
  return scene.render.quality == render::Quality::Cinematic && scene.render.preset != render::Preset::Mip &&
         !illustrating(scene) && !drawingMeshes(scene);  // the path tracer has no opaque-depth layer
}

bool View3D::refineCinematic(const Scene& scene, int paneWidth, int paneHeight) {
  const auto t0 = std::chrono::steady_clock::now();
  auto since = [](auto t) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
  };
  context_.makeCurrent();
  const render::RenderSettings s = renderSettingsFor(scene, paneWidth, paneHeight);
  const int rows = s.height;
  if (!cinematic_) {
    renderer_->beginCinematic(s, true);
    cinematic_ = true;
    cinematicBatch_ = 1;
    cinematicRow_ = 0;
    cinematicMs_ = 0;
    refineTiles_ = 0;
    guideRow_ = 0;
    guideRowsLeft_ = renderer_->addCinematicGuideRows(0, 0);
  }
  const auto t1 = std::chrono::steady_clock::now();
  if (guideRowsLeft_ > 0) {
    // The denoise guide, a ray cast of the whole pane (1.8 s on the feet under load), in bands
    // of rows sized to the budget as the plain refinement's; the first band a probe. The
    // coarse frame stays shown meanwhile.
    const int band = msPerGuideRow_ > 0 ? std::clamp(int(budgetMs_ / msPerGuideRow_), 1, rows - guideRow_)
                                        : std::min(rows - guideRow_, std::max(1, rows / 16));
    guideRowsLeft_ = renderer_->addCinematicGuideRows(guideRow_, guideRow_ + band);
    glFinish();  // the band's real cost sizes the next one
    msPerGuideRow_ = since(t1) / band;
    guideRow_ += band;
    ++refineTiles_;
    lastMs_ = since(t0);
    cinematicMs_ += lastMs_;
    refineMs_ = cinematicMs_;
    lastScale_ = 1;
    return true;
  }
  int total = renderer_->cinematicSamples();
  // One sample of the whole pane over budget (llvmpipe: seconds at pane size), or its cost not
  // known yet: the sample in bands of rows sized to the budget, one band per frame, shown once
  // every row has it (a pane with half its rows one sample ahead would show a seam).
  if (cinematicRow_ > 0 || msPerRow_ <= 0 || msPerRow_ * rows > budgetMs_) {
    const int band = msPerRow_ > 0 ? std::clamp(int(budgetMs_ / msPerRow_), 1, rows - cinematicRow_)
                                   : std::min(rows - cinematicRow_, std::max(1, rows / 16));  // a probe
    total = renderer_->addCinematicRows(cinematicRow_, cinematicRow_ + band);
    glFinish();  // the band's real cost sizes the next one (see renderCoarse)
    msPerRow_ = since(t1) / band;
    cinematicRow_ = (cinematicRow_ + band) % rows;
  } else {
    const int n = std::clamp(cinematicBatch_, 1, std::max(1, s.cinematic.samples - total));
    total = renderer_->addCinematicSamples(n);
    glFinish();
    const double batchMs = since(t1);
    msPerRow_ = batchMs / n / rows;
    // The next batch: what fits in the budget beside this frame's resolve (read-back, tone
    // map, denoise, upload), at this batch's cost per sample; at most doubling, at least one.
    const double fixedMs = std::max(0.0, lastResolveMs_);
    cinematicBatch_ = std::clamp(int((budgetMs_ - fixedMs) / std::max(1e-3, batchMs / n)), 1, std::max(1, 2 * n));
  }
  ++refineTiles_;
  if (cinematicRow_ == 0) {  // a whole sample (or batch) more: show the running picture
    const auto t2 = std::chrono::steady_clock::now();
    cinematicImage_ = renderer_->resolveCinematic();
    texture_.upload(cinematicImage_);
    shown_ = texture_.id();
    shownBottomUp_ = false;
    lastResolveMs_ = since(t2);
  }
  lastMs_ = since(t0);
  cinematicMs_ += lastMs_;
  lastScale_ = 1;
  refineMs_ = cinematicMs_;
  const double limitMs = 1000.0 * s.cinematic.timeLimitS;
  refined_ = cinematicRow_ == 0 && (total >= s.cinematic.samples || (limitMs > 0 && cinematicMs_ >= limitMs));
  return true;
}

}  // namespace vellum::studio
