// CPU reference of the illustration ray caster (the shader's loop, step for step), plus
// scene loading/validation.
#include <algorithm>
#include <cmath>

#include "illustration_renderer_common.hpp"
#include "image_refine.hpp"
#include "render_common.hpp"  // modules/render: camera rays, clip, jitter (shared with its shaders)
#include "vellum/core/box_corners.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/io/nrrd_reader.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::illustration {

using namespace detail;

const params::EnumTable<Interpolation>& interpolations() {
  static const params::EnumTable<Interpolation> t{"interpolation", {"eight", "nearest"}};
  return t;
}

void validateScene(const ShapeScene& scene) {
  scene.grid().validate("shape distance volume");
  if (!scene.segments.geometry().approxEqual(scene.grid()))
    throw Error("shape scene: segments grid " + scene.segments.geometry().dims.str() +
                " differs from the distance grid " + scene.grid().dims.str());
  if (scene.ct && !geometryOf(*scene.ct).approxEqual(scene.grid()))
    throw Error("shape scene: CT grid " + geometryOf(*scene.ct).dims.str() +
                " differs from the shape grid " + scene.grid().dims.str() +
                " (the shape folder must be made from this CT)");
  if (scene.segments.maxId() >= kMaxLabels)
    throw Error("shape scene: segment ids must be <= 255 (found " + std::to_string(scene.segments.maxId()) + ")");
  if (scene.fields.empty() && scene.segments.maxId() > 0)
    throw Error("shape scene: no per-segment distances (make the shape folder again with `vellum shape`)");
  for (size_t i = 0; i < scene.fields.size(); ++i) {
    const SegmentField& f = scene.fields[i];
    if (!f.distance.geometry().approxEqual(scene.grid()))
      throw Error("shape scene: the distance of segment '" + f.name + "' has grid " + f.distance.dims().str() +
                  ", not the scene's " + scene.grid().dims.str());
    if (f.id == 0 || f.id >= kMaxLabels || f.shellId >= kMaxLabels || (i > 0 && f.id <= scene.fields[i - 1].id))
      throw Error("shape scene: segment '" + f.name + "': ids must increase within 1..255");
  }
}

ShapeScene loadShapeFolder(const std::filesystem::path& dir, bool unionDistance) {
  if (!std::filesystem::is_directory(dir))
    throw FileError(dir, std::filesystem::exists(dir) ? "is not a shape folder (not a directory)"
                                                      : "no such shape folder (make one with `vellum shape`)");
  const auto dPath = dir / "distance.nrrd", sPath = dir / "segments.nrrd";
  for (const auto& p : {dPath, sPath})
    if (!std::filesystem::exists(p)) throw FileError(p, "missing from the shape folder (make it with `vellum shape`)");
  ShapeScene s;
  Geometry grid;
  if (unionDistance) {
    AnyVolume d = io::loadVolume(dPath).volume;
    if (!std::holds_alternative<VolumeF32>(d))
      throw FileError(dPath, std::string("expected float32 signed distances, got ") + voxelTypeName(voxelTypeOf(d)));
    s.distance = std::move(std::get<VolumeF32>(d));
    grid = s.distance.geometry();
  } else {
    // Only its grid: the header (the renderer draws the per-segment fields).
    const io::NrrdLayout h = io::readNrrdHeader(dPath);
    if (h.type != "float" || !h.leadingSizes.empty())
      throw FileError(dPath, "expected float32 signed distances, got " + h.type + (h.leadingSizes.empty() ? "" : " vectors"));
    grid = h.geometry;
  }
  s.segments = io::loadLabels(sPath);
  if (!s.segments.geometry().approxEqual(grid))
    throw FileError(sPath, "grid " + s.segments.geometry().dims.str() + " differs from distance.nrrd's " + grid.dims.str());
  if (s.segments.maxId() >= kMaxLabels)
    throw FileError(sPath, "segment ids must be <= 255 (found " + std::to_string(s.segments.maxId()) + ")");
  s.fields = loadSegmentFields(dir);
  for (const auto& f : s.fields)
    if (!f.distance.geometry().approxEqual(grid))
      throw FileError(dir / ("distance-" + std::to_string(f.id) + ".nrrd"),
                      "grid " + f.distance.dims().str() + " differs from distance.nrrd's " + grid.dims.str());
  return s;
}

namespace {

struct CpuContext {
  const ShapeScene& scene;
  const IllustrationSettings& settings;
  render::detail::Frame frame;
  StyleTable table;
  FieldVolume fields;
  Volume4 ct;
  bool useCt = false;
  std::optional<TextureVolume> texVol;
  SampleFrame sf;
  float skipMarginMm = 0;
};

Vec3f f3(const Vec3& v) { return {float(v.x), float(v.y), float(v.z)}; }

/// One thread's ray caster: the shader's main() for one pixel.
struct RayTracer {
  const CpuContext& cx;
  const size_t ns;
  std::vector<float> d;
  std::vector<Vec3f> gi, gp;
  std::vector<float> histA, histB;  // each slot's distance two and one samples ago
  std::vector<float> inked;         // line ink laid in the ray's current pass near each slot's surface
  std::vector<uint8_t> inPass;      // the ray is near the slot's surface
  std::vector<float> passAcc;       // what was composited when that pass began
  std::vector<uint8_t> entered;     // the ray has been inside the slot (no lines behind it)
  std::vector<float> lo, hi, skipOut, skipIn;

  explicit RayTracer(const CpuContext& c)
      : cx(c), ns(c.fields.slots.size()), d(ns + 1), gi(ns + 1), gp(ns + 1), histA(ns + 1), histB(ns + 1),
        inked(ns + 1), inPass(ns + 1), passAcc((ns + 1) * 4), entered(ns + 1) {
    gradientWindows(cx.table, cx.fields.slots, cx.sf.coverageH, lo, hi);
    skipBands(cx.table, cx.fields.slots, cx.sf.coverageH, cx.sf.inkPassMm, cx.skipMarginMm, skipOut, skipIn);
  }

  /// Pixel (px, py)'s straight RGBA (0..1, before quantising) and how near (pixels) it passed
  /// undrawn ink (image_refine.hpp); `spacing`: of the refinement level it is traced for.
  void trace(int px, int py, int spacing, float* rgba, float& near);
};

void RayTracer::trace(int px, int py, int spacing, float* rgba, float& near) {
  const auto& s = cx.settings.render;
  const auto& f = cx.frame;
  const bool central = cx.settings.interpolation == Interpolation::Eight;
  const TextureVolume* tv = cx.texVol ? &*cx.texVol : nullptr;
  const Vec3 c0{cx.sf.centre.x, cx.sf.centre.y, cx.sf.centre.z};
  constexpr float kInkNone = 1e30f;
  const auto& m = cx.sf.gradToPhys;
  near = 1e30f;
  {    // (the former per-pixel loop's body, its indentation kept so that
    {  // changes to it merge)
      const render::detail::Ray ray = render::detail::pixelRay(f, px, py);
      const auto clip = render::detail::clipRay(f, ray, s.jitter ? render::detail::pixelJitter(px, py) : 0.0);
      const Vec3f view = f3(-ray.dir);
      float acc[4] = {0, 0, 0, 0};
      std::fill(histA.begin(), histA.end(), kInkNone);
      std::fill(histB.begin(), histB.end(), kInkNone);
      std::fill(inked.begin(), inked.end(), 0.f);
      std::fill(inPass.begin(), inPass.end(), uint8_t(0));
      std::fill(entered.begin(), entered.end(), uint8_t(0));
      bool holdInk = false;
      int creaseS = -1;  // as the shader: the first slot with creases the ray entered
      float creaseT = 0.f, creaseAcc[4] = {0, 0, 0, 0};
      for (int64_t k = clip.k0; k <= clip.k1; ++k) {
        const Vec3 p = clip.o + clip.d * ((double(k) + clip.jitter) * f.stepMm);
        const double t = (double(k) + clip.jitter) * f.stepMm;
        const Vec3f pMm = f3(ray.origin + ray.dir * t);
        const float depth = float((dot(ray.origin - c0, f.forward) + t * dot(ray.dir, f.forward)) / (2.0 * cx.sf.radius) + 0.5);
        cx.fields.sample(float(p.x), float(p.y), float(p.z), central, lo.data(), hi.data(), d.data(), gi.data());
        for (size_t i = 0; i < ns; ++i) {
          const Vec3f g = gi[i];
          gp[i] = {m[0] * g.x + m[1] * g.y + m[2] * g.z, m[3] * g.x + m[4] * g.y + m[5] * g.z,
                   m[6] * g.x + m[7] * g.y + m[8] * g.z};
        }
        std::array<float, 4> c4{};
        if (cx.useCt) c4 = cx.ct.sampleLinear(float(p.x), float(p.y), float(p.z));
        const std::array<float, 4> sum = shadeSample(cx.table, cx.fields.slots, d.data(), gp.data(),
                                                     cx.useCt ? c4.data() : nullptr, tv, pMm, depth, view, cx.sf);
        if (cx.table.usesInk) {
          // As the shader: ink goes in front of what was composited since the ray came near
          // the slot's surface (passAcc).
          const float pixB = cx.sf.pixMm0 + cx.sf.pixMm1 * float(t - f.stepMm);
          const float pixC = cx.sf.pixMm0 + cx.sf.pixMm1 * float(t);
          holdInk = false;
          auto under = [&](const float* at, const float* lc, float ia) {
            const float r = 1.f - at[3];
            for (int ch = 0; ch < 4; ++ch) {
              const float x = r > 1e-6f ? (acc[ch] - at[ch]) / r : 0.f;
              const float ink = ch == 3 ? ia : ia * lc[ch];
              acc[ch] = at[ch] + r * (ink + (1.f - ia) * x);
            }
          };
          for (size_t i = 0; i < ns; ++i) {
            const PaintSlot& sl = cx.fields.slots[i];
            const int iid = sl.shellId > 0 ? sl.shellId : sl.id;
            const float a = histA[i], b = histB[i], c = d[i];
            histA[i] = b;
            histB[i] = c;
            const StyleRow r = cx.table.row(iid);
            if (!r[slot::Ink]) continue;
            const float op = r[slot::LineOpacity], lw = r[slot::LineWidthPx], hs = r[slot::HatchSpacingPx];
            // Every sampled minimum (ties too); the strongest of a pass counts.
            const float hw = (0.5f * lw + 1.f) * pixB;
            if (lw > 0.f && !entered[i] && a < kInkNone && b <= a && b <= c && (b < a || b < c))  // as the shader: nearOut
              near = std::min(near, std::max(std::abs(b) - 0.25f * std::abs(c - a), 0.f) / pixB - (0.5f * lw + 0.5f));
            if (lw > 0.f && !entered[i] && a < kInkNone && b <= a && b <= c && inPass[i] && b - 0.25f * std::abs(c - a) < hw &&
                b > -hw) {
              // Refined at a quarter step around the samples' vertex (as the shader).
              const float xv = inkVertex(a, b, c);
              const float kb = float(k - 1) + float(clip.jitter);
              auto along = [&](float ts) {  // the slot's distance at ts mm along the ray
                return cx.fields.at(float(clip.o.x) + ts * float(clip.d.x), float(clip.o.y) + ts * float(clip.d.y),
                                    float(clip.o.z) + ts * float(clip.d.z), int(i));
              };
              float mm[3];
              for (int q = 0; q < 3; ++q) mm[q] = along((kb + xv + 0.25f * float(q - 1)) * float(f.stepMm));
              const float vox = cx.sf.creaseProbeMm / float(kCreaseProbeVoxels);
              const float tv = (kb + xv) * float(f.stepMm);
              // Outline-only rows (no fill) keep every line: there the outline is the figure.
              const float fade = r[slot::Opacity] > 0.f ? inkFeatureFade(along(tv - vox), mm[1], along(tv + vox), vox) : 1.f;
              const float ia = op * inkLine(mm[0], mm[1], mm[2], lw, pixB) * fade;
              if (ia > inked[i]) {
                const float more = (ia - inked[i]) / (1.f - inked[i]);
                inked[i] = ia;
                under(&passAcc[i * 4], r[slot::LineColour], more);
              }
            }
            // Hidden lines: once the ray is well inside the slot, its silhouettes further on
            // (the far side of a transparent skin, the other foot behind) are not drawn.
            if (c < -(0.5f * lw + 1.f) * pixC) entered[i] = 1;
            if (!(std::abs(c) < std::max((0.5f * lw + 1.f) * pixC, 1.5f * cx.sf.coverageH))) {
              inPass[i] = 0;
              inked[i] = 0.f;
            } else if (!inPass[i]) {
              inPass[i] = 1;
              std::copy(acc, acc + 4, &passAcc[i * 4]);
            }
            holdInk = holdInk || (inPass[i] && lw > 0.f);  // a line may still come: no early exit
            const Vec3f g = gp[i];
            const float gl = std::sqrt(dot(g, g));
            if (hs > 0.f && b < kInkNone && b > 0.f && c <= 0.f && gl > 1e-6f && inPass[i]) {
              const float ndl = dot(g * (1.f / gl), cx.sf.light);
              if (ndl < 0.6f) near = -1.f;
              float u[3], fade[3];
              hatchCoordinates(cx.sf, pMm, g * (1.f / gl), u, fade);
              under(&passAcc[i * 4], r[slot::LineColour], op * inkHatch(ndl, u, fade, hs, r[slot::HatchWidthPx]));
            }
            if (creaseS < 0 && r[slot::CreaseWidthPx] > 0.f && b < kInkNone && b > 0.f && c <= 0.f && inPass[i]) {
              creaseS = int(i);
              creaseT = (float(k - 1) + float(clip.jitter) + b / (b - c)) * float(f.stepMm);
              std::copy(&passAcc[i * 4], &passAcc[i * 4] + 4, creaseAcc);
            }
          }
        }
        // Adaptive step: a sample in homogeneous space stands for the samples up to the
        // nearest band (skipBands), composited as one span.
        const int span = cx.settings.adaptiveStep ? skipSamples(d.data(), ns, skipOut.data(), skipIn.data(),
                                                                float(f.stepMm), clip.k1 - k + 1)
                                                  : 1;
        k += span - 1;
        if (sum[3] > 0.f) {
          const float aStep = 1.f - std::pow(std::max(1.f - sum[3], 0.f), float(f.stepMm) * float(span));
          for (int ch = 0; ch < 3; ++ch) acc[ch] += (1.f - acc[3]) * aStep * (sum[size_t(ch)] / sum[3]);
          acc[3] += (1.f - acc[3]) * aStep;
          if (acc[3] >= kEarlyAlpha && !holdInk) break;
        }
      }
      if (creaseS >= 0) {
        const PaintSlot& sl = cx.fields.slots[size_t(creaseS)];
        const StyleRow r = cx.table.row(sl.shellId > 0 ? sl.shellId : sl.id);
        const Vec3f q = f3(clip.o + clip.d * double(creaseT));
        const float ia = r[slot::LineOpacity] *
                         creaseInk(cx.fields, creaseS, q, f3(f.physToBox * f.right), f3(f.physToBox * f.up), cx.sf.gradToPhys,
                                   r[slot::CreaseWidthPx] + 1.5f * float(spacing - 1), r[slot::CreaseAngleDeg],
                                   cx.sf.pixMm0 + cx.sf.pixMm1 * creaseT, cx.sf.creaseProbeMm);
        if (ia > 0.f) near = -1.f;
        const float rr = 1.f - creaseAcc[3];
        for (int ch = 0; ch < 4; ++ch) {
          const float x = rr > 1e-6f ? (acc[ch] - creaseAcc[ch]) / rr : 0.f;
          const float ink = ch == 3 ? ia : ia * r[slot::LineColour][ch];
          acc[ch] = creaseAcc[ch] + rr * (ink + (1.f - ia) * x);
        }
      }
      const float bgA = s.background[3];
      float out[4];
      for (int ch = 0; ch < 3; ++ch) out[ch] = acc[ch] + (1 - acc[3]) * s.background[size_t(ch)] * bgA;
      out[3] = acc[3] + (1 - acc[3]) * bgA;
      for (int ch = 0; ch < 4; ++ch) {
        const float v = ch == 3 ? out[3] : (out[3] > 0 ? std::min(out[ch] / out[3], 1.f) : 0.f);
        rgba[ch] = std::clamp(v, 0.f, 1.f);
      }
    }
  }
}

void renderRows(const CpuContext& cx, RgbaImage& image, int y0, int y1) {
  RayTracer rt(cx);
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < image.width; ++x) {
      float v[4], near;
      rt.trace(x, y, 1, v, near);
      uint8_t* px = image.at(x, y);
      for (int ch = 0; ch < 4; ++ch) px[ch] = static_cast<uint8_t>(std::lround(v[ch] * 255.f));
    }
}

}  // namespace

namespace detail {

SampleFrame makeSampleFrame(const Geometry& g, const render::detail::Frame& f, const StyleTable& t) {
  SampleFrame sf;
  const Dims& d = g.dims;
  const Vec3 centre = g.indexToPhysical({(d.x - 1) * 0.5, (d.y - 1) * 0.5, (d.z - 1) * 0.5});
  const double radius = voxelBoxRadius(g, centre);
  sf.centre = f3(centre);
  sf.radius = float(std::max(radius, 1e-6));
  sf.forward = f3(f.forward);
  const Vec3 L = normalized(f.right * t.light.x + f.up * t.light.y - f.forward * t.light.z);
  sf.light = f3(L);
  // The coverage ramp is one ray step wide: as sharp as the sampling resolves, and the same
  // figure whatever the grid's spacing (one voxel at the default step).
  sf.coverageH = float(f.stepMm);
  sf.stepMm = float(f.stepMm);
  const double pix = 2.0 * f.halfH / std::max(f.height, 1);
  sf.pixMm0 = f.perspective ? 0.f : float(pix);
  sf.pixMm1 = f.perspective ? float(pix) : 0.f;
  if (t.usesInk) {
    // A line's three samples lie within half its width (at the farthest depth) plus two steps.
    const double far = f.perspective ? norm(centre - f.eye) + radius : 0.0;
    sf.inkReachMm = float(0.5 * t.maxLineWidthPx * (sf.pixMm0 + sf.pixMm1 * far) + 2.0 * f.stepMm + 0.5);
    sf.inkLineMm = float((0.5 * t.maxLineWidthPx + 1.0) * (sf.pixMm0 + sf.pixMm1 * far) + 0.5 * f.stepMm);
    // The ray is "in a pass" near a surface within max((w/2 + 1) px, 1.5 h) (main loop).
    sf.inkPassMm = std::max({sf.inkReachMm, float((0.5 * t.maxLineWidthPx + 1.0) * (sf.pixMm0 + sf.pixMm1 * far)),
                             1.5f * sf.coverageH});
  }
  {
    // Hatching planes: across the grid's z axis (cross-contours) and the two diagonals of z
    // with x; fixed to the anatomy, so strokes stay on the surface as the camera moves.
    const Vec3 z = normalized(g.direction * Vec3{0, 0, 1}), x = normalized(g.direction * Vec3{1, 0, 0});
    sf.hatchAxis[0] = f3(z);
    sf.hatchAxis[1] = f3(normalized(z + x));
    sf.hatchAxis[2] = f3(normalized(z - x));
    sf.hatchPixMm = float(pix * (f.perspective ? norm(centre - f.eye) : 1.0));
  }
  sf.creaseProbeMm = float(kCreaseProbeVoxels * std::cbrt(g.spacing.x * g.spacing.y * g.spacing.z));
  const Mat3 m = g.direction * Mat3::fromColumns({1 / g.spacing.x, 0, 0}, {0, 1 / g.spacing.y, 0}, {0, 0, 1 / g.spacing.z});
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) sf.gradToPhys[size_t(r * 3 + c)] = float(m(r, c));
  return sf;
}

}  // namespace detail

RgbaImage renderIllustrationCpu(const ShapeScene& scene, const Style& style, const IllustrationSettings& settings) {
  validateScene(scene);
  CpuContext cx{scene, settings, render::detail::makeFrame(scene.grid(), nullptr, settings.render),
                packStyle(style, scene.segments.table(), scene.segments.maxId(), scene.grid()), {}, {},
                false, {}, {}};
  cx.fields = makeFieldVolume(scene, true);
  if (cx.table.usesCt) {
    if (!scene.ct) throw Error("illustrate: style '" + style.name + "' uses the CT (illum = ct or boundary_measure = ct) but no CT was given");
    cx.ct = computeCtGradient(*scene.ct);
    cx.useCt = true;
  }
  if (cx.table.usesTextureVolume) {
    if (style.textureVolume.empty()) throw Error("illustrate: style '" + style.name + "' has texture = volume rows but no texture_volume");
    cx.texVol = loadTextureVolume(style.textureVolume);
  }
  cx.sf = makeSampleFrame(scene.grid(), cx.frame, cx.table);
  cx.skipMarginMm = skipMarginMm(scene.grid());
  if (settings.refineLevels > 0) {  // the GL renderer's scheme, ray for ray
    return refineImage(settings.render.width, settings.render.height, settings.refineLevels, settings.refineTolerance,
                       [&](RefineLevel& l, const std::vector<TileRun>& runs) {
                         parallelFor(int64_t(runs.size()), [&](int64_t r0, int64_t r1) {
                           RayTracer rt(cx);
                           for (int64_t r = r0; r < r1; ++r)
                             for (int j = 4 * runs[size_t(r)].y; j < 4 * runs[size_t(r)].y + 4; ++j)
                               for (int i = 4 * runs[size_t(r)].x0; i < 4 * runs[size_t(r)].x1; ++i) {
                                 const size_t p = size_t(j) * size_t(l.nx) + size_t(i);
                                 rt.trace(i * l.spacing, j * l.spacing, l.spacing, &l.rgba[p * 4], l.near[p]);
                               }
                         });
                       });
  }
  RgbaImage image(settings.render.width, settings.render.height);
  parallelFor(settings.render.height, [&](int64_t y0, int64_t y1) { renderRows(cx, image, int(y0), int(y1)); });
  return image;
}

}  // namespace vellum::illustration
