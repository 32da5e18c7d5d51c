// StudioApp: drawing the panes (slice textures, 3D view, crosshairs, HUD) and screenshots.
#include <GL/glcorearb.h>
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <tuple>

#include "app.hpp"
#include "studio_tools.hpp"
#include "deform_session.hpp"
#include "export_figure.hpp"
#include "gl_texture.hpp"
#include "view3d.hpp"
#include "vellum/core/box_corners.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/image_io.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

namespace {

ImU32 planeColour(const Vec3& normal) {
  // 3D Slicer's convention: axial red, coronal green, sagittal yellow.
  if (std::abs(normal.z) > 0.5) return IM_COL32(230, 60, 60, 255);
  if (std::abs(normal.y) > 0.5) return IM_COL32(80, 200, 80, 255);
  return IM_COL32(230, 210, 60, 255);
}

}  // namespace

// ---- slices ----------------------------------------------------------------------------

const deformation::MapSampler* StudioApp::sliceMap() const {
  const deformation::MapSampler* map = scene_.view.deformedSlices ? deform_.session().sampler() : nullptr;
  // A map solved for the previous volume is not drawn over a new one (renderSlice refuses it).
  return map && map->output().dims == scene_.ct.geometry().dims && map->output().approxEqual(scene_.ct.geometry())
             ? map
             : nullptr;
}

std::optional<Vec3> StudioApp::sliceSourceMm(const Vec3& mm) const {
  const deformation::MapSampler* map = sliceMap();
  return map ? map->sourceMm(mm) : std::optional<Vec3>(mm);
}

namespace {
// The 3D view's orientation marker (Slicer's habit): the patient's R, A and S axes as seen by
// the camera, from `centre` (pane pixels), the farther axes drawn first and dimmer.
void drawOrientationMarker(ImDrawList* dl, ImVec2 centre, float length, const render::Camera& camera) {
  const CameraBasis basis = cameraBasis(camera);
  struct Axis {
    Vec3 lps;
    const char* letter;
    ImU32 colour;
  };
  // LPS: right is -x, anterior -y, superior +z.
  std::array<Axis, 3> axes{{{{-1, 0, 0}, "R", IM_COL32(230, 80, 80, 255)},
                            {{0, -1, 0}, "A", IM_COL32(90, 210, 90, 255)},
                            {{0, 0, 1}, "S", IM_COL32(100, 140, 255, 255)}}};
  std::sort(axes.begin(), axes.end(), [&](const Axis& u, const Axis& v) {
    return dot(u.lps, basis.forward) > dot(v.lps, basis.forward);  // away from the viewer first
  });
  for (const Axis& ax : axes) {
    const ImVec2 tip{centre.x + length * float(dot(ax.lps, basis.right)),
                     centre.y - length * float(dot(ax.lps, basis.up))};
    const bool away = dot(ax.lps, basis.forward) > 0.2;
    const ImU32 c = away ? (ax.colour & 0x00ffffffu) | 0x90000000u : ax.colour;
    dl->AddLine(centre, tip, c, 2.5f);
    dl->AddText({tip.x - 3, tip.y - 7}, c, ax.letter);
  }
}
}  // namespace

void StudioApp::updateSliceTextures() {
  const deformation::MapSampler* map = sliceMap();
  std::ostringstream key;
  key.precision(10);
  key << scene_.crosshairMm.x << ' ' << scene_.crosshairMm.y << ' ' << scene_.crosshairMm.z << ' '
      << scene_.view.sliceWindow.center << ' ' << scene_.view.sliceWindow.width << ' ' << scene_.view.labelOpacity << ' '
      << segmentation_.tools().thresholdPreview << ' ' << segmentation_.tools().threshold.lower << ' ' << segmentation_.tools().threshold.upper << ' '
      << scene_.hiddenLabels.size();
  // Deformed slices follow the map (every move of a drag); undeformed ones ignore it.
  key << " map " << (map ? deform_.session().mapRevision() : 0);
  // While a control point is dragged the deformed slices are resampled every frame through a
  // new map, and while a slice pane is dragged (the crosshair moves) all three every frame:
  // at reduced resolution (1/2, or 1/4 when 1/2 took over kSliceDragBudgetMs), full again when
  // the drag ends. (A crosshair drag at full resolution took 0.2 s of deformed slices a frame
  // at 512^2 x 350 under load.)
  const int reduce = map && (points_.dragging() || dragPane_) ? sliceDragReduce_ : 1;
  key << " reduce " << reduce;
  const auto [snakeLive, snakeRevision] = segmentation_.snake().live();
  if (snakeLive) key << " snake " << snakeRevision;
  if (slicesDirty_) paneSliceKeys_ = {};
  const auto t0 = std::chrono::steady_clock::now();
  SliceStyle style;
  style.window = scene_.view.sliceWindow;
  style.labels = &scene_.labels;
  style.labelOpacity = scene_.view.labelOpacity;
  style.hidden = &scene_.hiddenLabels;
  if (segmentation_.tools().thresholdPreview) style.thresholdPreview = segmentation_.tools().threshold;
  style.snakePreview = snakeLive.get();
  style.map = map;
  int rendered = 0;
  for (const Pane& p : panes_) {
    if (p.is3d()) continue;
    const auto axis = static_cast<size_t>(*p.slice);
    std::ostringstream paneKey;
    paneKey << key.str() << ' ' << p.rect.w << 'x' << p.rect.h << ' ' << sliceNav_[axis].zoom << ' '
            << sliceNav_[axis].panU << ' ' << sliceNav_[axis].panV;
    if (paneKey.str() == paneSliceKeys_[axis]) continue;
    // Full-resolution deformed slices once nothing is dragged (after a point drag: ~0.1 s each
    // at 512^2 on a loaded machine) come one pane per frame, so that no frame waits for all
    // three; a crosshair drag keeps the three in step.
    if (map && reduce == 1 && !dragPane_ && rendered > 0) break;
    SlicePlane plane = planeOf(p);
    if (reduce > 1) {  // the same field of view (within a pixel), drawn scaled up
      plane.width = (plane.width + reduce - 1) / reduce;
      plane.height = (plane.height + reduce - 1) / reduce;
      plane.mmPerPixel *= reduce;
    }
    sliceScale_[axis] = reduce;
    sliceImages_[axis] = renderSlice(scene_.ct, plane, style);
    sliceTextures_[axis]->upload(sliceImages_[axis]);
    paneSliceKeys_[axis] = paneKey.str();
    ++rendered;
  }
  slicesDirty_ = false;
  if (rendered == 0) return;
  slicesRendered_ = true;
  lastSlicesMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (reduce > 1) {  // adapt the drag's reduction (hysteresis: 1/2 again only when 4x fits)
    if (lastSlicesMs_ > kSliceDragBudgetMs) sliceDragReduce_ = 4;
    else if (lastSlicesMs_ * 4 < 0.9 * kSliceDragBudgetMs) sliceDragReduce_ = 2;
  }
}

void StudioApp::saveSliceScreenshot(const fs::path& path, SliceAxis axis) const {
  const bool shown = std::any_of(panes_.begin(), panes_.end(), [&](const Pane& p) { return p.slice == axis; });
  const RgbaImage& img = sliceImages_[static_cast<size_t>(axis)];
  if (!shown || img.pixels.empty()) throw Error(std::string("the ") + sliceAxisName(axis) + " slice is not shown");
  io::saveImage(img, path);
}

void StudioApp::drawPanes() {
  // The first volume loads (no views are updated before one is shown): compile the 3D
  // shaders and Mesa's blit now, not in the first 3D frames.
  if (loader_.busy()) view3d_->warmUp(scene_);
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  for (const Pane& p : panes_) {
    const ImVec2 a{p.rect.x, p.rect.y}, b{p.rect.x + p.rect.w, p.rect.y + p.rect.h};
    dl->AddRectFilled(a, b, IM_COL32(0, 0, 0, 255));
    if (!scene_.hasVolume()) continue;
    if (p.is3d()) {
      // A framebuffer's colour (drawn in place, row 0 at the bottom) or an uploaded image.
      if (const unsigned id = view3d_->textureId())
        dl->AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(id)), a, b,
                     {0, view3d_->textureBottomUp() ? 1.f : 0.f}, {1, view3d_->textureBottomUp() ? 0.f : 1.f});
      const std::string title = view3d_->illustrating(scene_)
                                    ? "3D  illustration: " + scene_.illustration.style.name
                                    : std::string("3D  ") + render::presetName(scene_.render.preset);
      dl->AddText({a.x + 6, a.y + 4}, IM_COL32(120, 120, 200, 255), title.c_str());
      if (upload3d_) dl->AddText({a.x + 6, a.y + 22}, IM_COL32(150, 200, 255, 255), "uploading the volume ...");
      else if (view3d_->unlit(scene_))
        dl->AddText({a.x + 6, a.y + 22}, IM_COL32(150, 200, 255, 255), "unlit until the light is made ...");
      if (panes_.size() > 1) drawPlanesIn3d(p);
      drawOrientationMarker(dl, {b.x - 44, b.y - 44}, 30, scene_.render.camera);
      points_.draw(p);
      deform_.draw(p);
      curves_.draw(p);
      continue;
    }
    const GlTexture& t = *sliceTextures_[static_cast<size_t>(*p.slice)];
    if (t.valid()) {
      const float scale = float(sliceScale_[static_cast<size_t>(*p.slice)]);
      dl->PushClipRect(a, b, true);
      dl->AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(t.id())), a,
                   {a.x + scale * float(t.width()), a.y + scale * float(t.height())});
      dl->PopClipRect();
    }
    const SlicePlane plane = planeOf(p);
    const auto [cx, cy] = plane.toPixel(scene_.crosshairMm);
    dl->PushClipRect(a, b, true);
    // Vertical line: the plane whose normal is u; horizontal: the plane whose normal is v.
    dl->AddLine({a.x + float(cx), a.y}, {a.x + float(cx), b.y}, planeColour(plane.u));
    dl->AddLine({a.x, a.y + float(cy)}, {b.x, a.y + float(cy)}, planeColour(plane.v));
    if ((segmentation_.tools().tool == Tool::Paint || segmentation_.tools().tool == Tool::Erase) && p.rect.contains(mouseX_, mouseY_))
      dl->AddCircle({float(mouseX_), float(mouseY_)}, float(segmentation_.tools().brushRadiusMm / plane.mmPerPixel),
                    segmentation_.tools().tool == Tool::Paint ? IM_COL32(255, 255, 255, 220) : IM_COL32(255, 120, 120, 220), 32);
    dl->PopClipRect();
    studioTools_->measure.draw(plane, a.x, a.y, p.rect.w, p.rect.h,
                               p.rect.contains(mouseX_, mouseY_)
                                   ? std::optional<Vec3>(plane.toMm(mouseX_ - a.x, mouseY_ - a.y))
                                   : std::nullopt);
    points_.draw(p);
    deform_.draw(p);
    dl->AddRect(a, b, planeColour(plane.normal));
    std::string title = sliceAxisName(*p.slice);
    if (const SliceNavigation& nav = sliceNav_[static_cast<size_t>(*p.slice)]; nav.zoom != 1 || nav.panU != 0 || nav.panV != 0) {
      char z[32];
      std::snprintf(z, sizeof z, "  x%.2f (F fits)", nav.zoom);
      title += z;
    }
    dl->AddText({a.x + 6, a.y + 4}, planeColour(plane.normal), title.c_str());
    // Orientation letters at the middle of each edge (radiological: the patient's left on the right).
    const auto letters = orientationLetters(plane);
    const ImU32 letterColour = IM_COL32(255, 200, 90, 255);
    const float mx = a.x + p.rect.w * 0.5f, my = a.y + p.rect.h * 0.5f;
    const auto size = [](const std::string& t) { return ImGui::CalcTextSize(t.c_str()); };
    dl->AddText({a.x + 4, my - size(letters[0]).y * 0.5f}, letterColour, letters[0].c_str());
    dl->AddText({b.x - 4 - size(letters[1]).x, my - size(letters[1]).y * 0.5f}, letterColour, letters[1].c_str());
    dl->AddText({mx - size(letters[2]).x * 0.5f, a.y + 4}, letterColour, letters[2].c_str());
    dl->AddText({mx - size(letters[3]).x * 0.5f, b.y - 4 - size(letters[3]).y}, letterColour, letters[3].c_str());
  }
}

void StudioApp::drawPlanesIn3d(const Pane& pane) {
  // The three slice planes as outlines of their cut through the volume's bounding box, drawn
  // over the rendering (not depth-tested) in the slice colours.
  const Geometry& g = scene_.ct.geometry();
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3& p : voxelBoxCorners(g))
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  dl->PushClipRect({pane.rect.x, pane.rect.y}, {pane.rect.x + pane.rect.w, pane.rect.y + pane.rect.h}, true);
  for (int axis = 0; axis < 3; ++axis) {  // plane normal along x (sagittal), y (coronal), z (axial)
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    std::vector<ImVec2> pts;
    for (int k = 0; k < 4; ++k) {
      Vec3 p = scene_.crosshairMm;
      p[u] = (k == 1 || k == 2) ? hi[u] : lo[u];
      p[v] = (k >= 2) ? hi[v] : lo[v];
      const auto px = projectToView(scene_, int(pane.rect.w), int(pane.rect.h), p);
      if (!px) break;
      pts.push_back({pane.rect.x + float(px->first), pane.rect.y + float(px->second)});
    }
    Vec3 normal;
    normal[axis] = 1;
    if (pts.size() == 4) dl->AddPolyline(pts.data(), 4, planeColour(normal), ImDrawFlags_Closed, 1.f);
  }
  dl->PopClipRect();
}

void StudioApp::drawHud() {
  std::ostringstream hud;
  hud.setf(std::ios::fixed);
  hud.precision(1);
  hud << "frame " << lastFrameMs_ << " ms   3D " << view3d_->lastRenderMs() << " ms @1/" << view3d_->lastScale();
  if (view3d_->refineProgress() < 1) hud << "  refining " << int(100 * view3d_->refineProgress()) << "%";
  if (view3d_->cinematic(scene_)) {  // refine at rest: the path tracer's progress
    if (view3d_->cinematicGuideProgress() < 1)
      hud << "  cinematic guide " << int(100 * view3d_->cinematicGuideProgress()) << "%";
    else
      hud << "  cinematic " << view3d_->cinematicSamples() << "/" << scene_.render.cinematic.samples << " samples";
  }
  if (deform_.session().map())
    hud << "   map " << deform_.session().lastUpdateMs() << " ms"
        << (deform_.session().solving() ? " (exact map solving)" : deform_.session().preview() ? " (preview s=8)" : "");
  if (sliceMap()) hud << "   deformed slices " << lastSlicesMs_ << " ms";
  if (scene_.hasVolume()) {
    const Pane* p = paneAt(mouseX_, mouseY_);
    if (p && !p->is3d()) {
      const SlicePlane plane = planeOf(*p);
      const Vec3 mm = plane.toMm(mouseX_ - p->rect.x, mouseY_ - p->rect.y);
      hud << "\n(" << mm.x << ", " << mm.y << ", " << mm.z << ") mm  ";
      // Deformed slices: the voxel shown is the source's (what painting and seeds act on).
      const std::optional<Vec3> src = sliceSourceMm(mm);
      if (sliceMap() && src) hud << "from (" << src->x << ", " << src->y << ", " << src->z << ") mm  ";
      const Vec3 ijk = scene_.ct.geometry().physicalToIndex(src.value_or(Vec3{1e9, 1e9, 1e9}));
      const auto i = std::lround(ijk.x), j = std::lround(ijk.y), k = std::lround(ijk.z);
      if (src) hud << "[" << i << ' ' << j << ' ' << k << "]  ";
      if (src && scene_.ct.geometry().contains(i, j, k)) {
        hud << "HU " << scene_.ct(i, j, k) << "  label " << scene_.labels(i, j, k);
        if (auto l = scene_.labels.label(scene_.labels(i, j, k))) hud << " " << l->name;
      } else {
        hud << "outside";
      }
    }
  }
  if (panes_.empty()) return;
  // Bottom left of the viewport (the panes' lowest edge follows window resizes).
  float bottom = 0;
  for (const Pane& p : panes_) bottom = std::max(bottom, p.rect.y + p.rect.h);
  const float x = panes_.front().rect.x + 8, y = bottom - 44;
  const float width = std::max(520.f, ImGui::CalcTextSize(hud.str().c_str()).x + 8);  // deformed slices add a position
  ImGui::GetForegroundDrawList()->AddRectFilled({x - 4, y - 2}, {x + width, y + 36}, IM_COL32(0, 0, 0, 150));
  ImGui::GetForegroundDrawList()->AddText({x, y}, IM_COL32(255, 255, 160, 255), hud.str().c_str());
}

std::vector<std::string> StudioApp::runningWork() const {
  std::vector<std::string> r;
  const auto with = [](const std::string& what, double f) { return what + "  " + std::to_string(int(100 * f)) + "%"; };
  if (loader_.busy()) {
    const auto [stage, f] = loader_.progress();
    r.push_back(with(stage, f));
  }
  if (pendingLoad_) r.push_back("opening: waiting for the running work to finish");
  if (!tasks_.running().empty()) {
    const auto [stage, f] = tasks_.progress();
    std::string line = with(tasks_.running(), f);
    if (tasks_.waiting()) line += "  (" + std::to_string(tasks_.waiting()) + " queued)";
    r.push_back(line);
  }
  if (segmentation_.snake().busy()) {
    const auto [stage, f] = segmentation_.snake().progress();
    r.push_back(with(stage, f));
  }
  if (shapes_.busy()) {
    const auto [stage, f] = shapes_.progress();
    r.push_back(with(stage, f));
  }
  for (const std::string& d : deform_.session().running())
    if (!points_.dragging()) r.push_back(d);  // a drag's own preview is what the drag shows
  if (studioTools_->figure.job.busy()) r.push_back(with("export figure", studioTools_->figure.job.progress().second));
  if (deform_.exporting()) {
    const auto [done, count] = deform_.exportProgress();
    r.push_back("exporting frame " + std::to_string(done) + " / " + std::to_string(count));
  }
  if (curves_.busy()) r.push_back("curve analogy");
  if (upload3d_) r.push_back("uploading the volume to the 3D view");
  if (view3d_->lightPending()) r.push_back("making the 3D view's light (drawn unlit until then)");
  return r;
}

// What runs on workers (and a refused edit's notice), top right of the viewport: text only,
// it takes no input (the tool panel's Running section has the Cancel buttons).
void StudioApp::drawStatus() {
  const std::vector<std::string> work = runningWork();
  const bool notice = !notice_.empty() && glfwGetTime() < noticeUntil_;
  if ((work.empty() && !notice) || panes_.empty()) return;
  float right = 0;
  for (const Pane& p : panes_) right = std::max(right, p.rect.x + p.rect.w);
  ImGui::SetNextWindowPos({right - 8, 8}, ImGuiCond_Always, {1, 0});
  ImGui::SetNextWindowBgAlpha(0.7f);
  ImGui::Begin("##running", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoInputs |
                   ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav);
  for (const std::string& line : work) ImGui::TextColored({0.6f, 0.85f, 1.f, 1.f}, "running: %s", line.c_str());
  if (notice) ImGui::TextColored({1.f, 0.7f, 0.3f, 1.f}, "%s", notice_.c_str());
  ImGui::End();
}

// ---- screenshots -------------------------------------------------------------------------

void StudioApp::requestWindowScreenshot(const fs::path& path) { pendingScreenshot_ = path; }

void StudioApp::captureWindow() {
  const fs::path path = std::exchange(pendingScreenshot_, {});
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  RgbaImage img(w, h);
  std::vector<uint8_t> rows(img.pixels.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
  const size_t stride = static_cast<size_t>(w) * 4;
  for (int y = 0; y < h; ++y)  // GL rows are bottom-up
    std::copy_n(rows.data() + static_cast<size_t>(h - 1 - y) * stride, stride, img.pixels.data() + y * stride);
  for (size_t n = 3; n < img.pixels.size(); n += 4) img.pixels[n] = 255;
  try {
    io::saveImage(img, path);
    screenshotError_.reset();
  } catch (const std::exception& e) {
    screenshotError_ = e.what();
  }
}

std::optional<std::string> StudioApp::takeScreenshotError() { return std::exchange(screenshotError_, std::nullopt); }

std::pair<int, int> StudioApp::pane3dSize() const {
  for (const Pane& p : panes_)
    if (p.is3d()) return {int(p.rect.w), int(p.rect.h)};
  return {512, 512};
}

std::string StudioApp::cliCommand(const std::string& out) const {
  const auto [w, h] = pane3dSize();
  return renderCommand(scene_, out, w, h);
}

void StudioApp::save3dScreenshot(const fs::path& path, int width, int height) {
  if (!scene_.hasVolume()) throw Error("no volume is open");
  if (width <= 0 || height <= 0) std::tie(width, height) = pane3dSize();
  if (width > 4096 || height > 4096) throw Error("3D screenshots are limited to 4096x4096");
  io::saveImage(view3d_->renderImage(scene_, width, height), path);
}


}  // namespace vellum::studio
