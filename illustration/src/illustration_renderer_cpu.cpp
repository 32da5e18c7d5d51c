// CPU reference of the illustration ray caster (the shader's loop, step for step), plus
// scene loading/validation.
#include <algorithm>
#include <cmath>

#include "illustration_renderer_common.hpp"
#include "render_common.hpp"  // modules/render: camera rays, clip, jitter (shared with its shaders)
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::illustration {

using namespace detail;

const char* interpolationName(Interpolation i) { return i == Interpolation::Eight ? "eight" : "nearest"; }

Interpolation parseInterpolation(const std::string& name) {
  if (name == "eight") return Interpolation::Eight;
  if (name == "nearest") return Interpolation::Nearest;
  throw Error("unknown interpolation '" + name + "' (valid: eight, nearest)");
}

void validateScene(const ShapeScene& scene) {
  scene.distance.geometry().validate("shape distance volume");
  if (!scene.segments.geometry().approxEqual(scene.distance.geometry()))
    throw Error("shape scene: segments grid " + scene.segments.geometry().dims.str() +
                " differs from the distance grid " + scene.distance.dims().str());
  if (scene.ct && !geometryOf(*scene.ct).approxEqual(scene.distance.geometry()))
    throw Error("shape scene: CT grid " + geometryOf(*scene.ct).dims.str() +
                " differs from the shape grid " + scene.distance.dims().str() +
                " (the shape folder must be made from this CT)");
  if (scene.segments.maxId() >= kMaxLabels)
    throw Error("shape scene: segment ids must be <= 255 (found " + std::to_string(scene.segments.maxId()) + ")");
}

ShapeScene loadShapeFolder(const std::filesystem::path& dir) {
  if (!std::filesystem::is_directory(dir))
    throw FileError(dir, std::filesystem::exists(dir) ? "is not a shape folder (not a directory)"
                                                      : "no such shape folder (make one with `vellum shape`)");
  const auto dPath = dir / "distance.nrrd", sPath = dir / "segments.nrrd";
  for (const auto& p : {dPath, sPath})
    if (!std::filesystem::exists(p)) throw FileError(p, "missing from the shape folder (make it with `vellum shape`)");
  ShapeScene s;
  AnyVolume d = io::loadVolume(dPath).volume;
  if (!std::holds_alternative<VolumeF32>(d))
    throw FileError(dPath, std::string("expected float32 signed distances, got ") + voxelTypeName(voxelTypeOf(d)));
  s.distance = std::move(std::get<VolumeF32>(d));
  s.segments = io::loadLabels(sPath);
  if (!s.segments.geometry().approxEqual(s.distance.geometry()))
    throw FileError(sPath, "grid " + s.segments.geometry().dims.str() + " differs from distance.nrrd's " +
                               s.distance.dims().str());
  if (s.segments.maxId() >= kMaxLabels)
    throw FileError(sPath, "segment ids must be <= 255 (found " + std::to_string(s.segments.maxId()) + ")");
  return s;
}

namespace {

struct CpuContext {
  const ShapeScene& scene;
  const IllustrationSettings& settings;
  render::detail::Frame frame;
  StyleTable table;
  Volume4 grad, ct;
  bool useCt = false;
  std::optional<TextureVolume> texVol;
  SampleFrame sf;
};

Vec3f f3(const Vec3& v) { return {float(v.x), float(v.y), float(v.z)}; }

void renderRows(const CpuContext& cx, RgbaImage& image, int y0, int y1) {
  const auto& s = cx.settings.render;
  const auto& f = cx.frame;
  const Geometry& g = cx.scene.distance.geometry();
  const Dims dims = g.dims;
  const VolumeU16& labels = cx.scene.segments.ids();
  const bool eight = cx.settings.interpolation == Interpolation::Eight;
  const TextureVolume* tv = cx.texVol ? &*cx.texVol : nullptr;
  const Vec3 c0{cx.sf.centre.x, cx.sf.centre.y, cx.sf.centre.z};
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < s.width; ++x) {
      const render::detail::Ray ray = render::detail::pixelRay(f, x, y);
      const auto clip = render::detail::clipRay(f, ray, s.jitter ? render::detail::pixelJitter(x, y) : 0.0);
      const Vec3f view = f3(-ray.dir);
      float acc[4] = {0, 0, 0, 0};
      for (int64_t k = clip.k0; k <= clip.k1; ++k) {
        const Vec3 p = clip.o + clip.d * ((double(k) + clip.jitter) * f.stepMm);
        const double t = (double(k) + clip.jitter) * f.stepMm;
        const Vec3f pMm = f3(ray.origin + ray.dir * t);
        const float depth = float((dot(ray.origin - c0, f.forward) + t * dot(ray.dir, f.forward)) / (2.0 * cx.sf.radius) + 0.5);
        std::array<float, 4> sum{0, 0, 0, 0};
        if (eight) {
          const double fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
          const int64_t i0 = int64_t(fx), j0 = int64_t(fy), k0 = int64_t(fz);
          const float tx = float(p.x - fx), ty = float(p.y - fy), tz = float(p.z - fz);
          int labs[8];
          bool anyZero = false;
          for (int c = 0; c < 8; ++c) {
            const int64_t i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), kk = k0 + ((c >> 2) & 1);
            labs[c] = g.contains(i, j, kk) ? int(labels(i, j, kk)) : -1;
            anyZero = anyZero || labs[c] == 0;
          }
          auto weight = [&](int c) {
            return ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz);
          };
          int dom = -1;  // outer-surface extension (see the shader)
          if (anyZero && !cx.table.visible[0]) {
            float domW = 0;
            for (int c = 0; c < 8; ++c)
              if (labs[c] > 0 && cx.table.visible[size_t(labs[c])] && weight(c) > domW) {
                domW = weight(c);
                dom = labs[c];
              }
          }
          for (int c = 0; c < 8; ++c) {
            const int64_t i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), kk = k0 + ((c >> 2) & 1);
            int lab = labs[c];
            if (lab < 0) continue;
            if (lab == 0 && dom > 0 && cx.grad.at(i, j, kk)[3] > 0.f) lab = dom;
            if (!cx.table.visible[size_t(lab)]) continue;
            const float w = weight(c);
            const auto v = styledSample(cx.table, lab, cx.grad.at(i, j, kk), cx.useCt ? cx.ct.at(i, j, kk) : nullptr,
                                        tv, pMm, depth, view, cx.sf);
            for (int ch = 0; ch < 4; ++ch) sum[size_t(ch)] += w * v[size_t(ch)];
          }
        } else {
          const int64_t i = std::clamp<int64_t>(int64_t(std::floor(p.x + 0.5)), 0, dims.x - 1);
          const int64_t j = std::clamp<int64_t>(int64_t(std::floor(p.y + 0.5)), 0, dims.y - 1);
          const int64_t kk = std::clamp<int64_t>(int64_t(std::floor(p.z + 0.5)), 0, dims.z - 1);
          const int lab = labels(i, j, kk);
          if (!cx.table.visible[size_t(lab)]) continue;
          // Same-label corners only (see the shader).
          const double fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
          const int64_t i0 = int64_t(fx), j0 = int64_t(fy), k0 = int64_t(fz);
          const float tx = float(p.x - fx), ty = float(p.y - fy), tz = float(p.z - fz);
          std::array<float, 4> g4{0, 0, 0, 0};
          float wsum = 0;
          for (int c = 0; c < 8; ++c) {
            const int64_t qi = std::clamp<int64_t>(i0 + (c & 1), 0, dims.x - 1);
            const int64_t qj = std::clamp<int64_t>(j0 + ((c >> 1) & 1), 0, dims.y - 1);
            const int64_t qk = std::clamp<int64_t>(k0 + ((c >> 2) & 1), 0, dims.z - 1);
            if (labels(qi, qj, qk) != lab) continue;
            const float w = ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz);
            const float* gv = cx.grad.at(qi, qj, qk);
            for (int ch = 0; ch < 4; ++ch) g4[size_t(ch)] += w * gv[ch];
            wsum += w;
          }
          for (auto& v : g4) v /= wsum;
          std::array<float, 4> c4{};
          if (cx.useCt) c4 = cx.ct.sampleLinear(float(p.x), float(p.y), float(p.z));
          sum = styledSample(cx.table, lab, g4.data(), cx.useCt ? c4.data() : nullptr, tv, pMm, depth, view, cx.sf);
        }
        if (sum[3] > 0.f) {
          const float aStep = 1.f - std::pow(std::max(1.f - sum[3], 0.f), float(f.stepMm));
          for (int ch = 0; ch < 3; ++ch) acc[ch] += (1.f - acc[3]) * aStep * (sum[size_t(ch)] / sum[3]);
          acc[3] += (1.f - acc[3]) * aStep;
          if (acc[3] >= kEarlyAlpha) break;
        }
      }
      const float bgA = s.background[3];
      float out[4];
      for (int ch = 0; ch < 3; ++ch) out[ch] = acc[ch] + (1 - acc[3]) * s.background[size_t(ch)] * bgA;
      out[3] = acc[3] + (1 - acc[3]) * bgA;
      uint8_t* px = image.at(x, y);
      for (int ch = 0; ch < 4; ++ch) {
        const float v = ch == 3 ? out[3] : (out[3] > 0 ? std::min(out[ch] / out[3], 1.f) : 0.f);
        px[ch] = static_cast<uint8_t>(std::lround(std::clamp(v, 0.f, 1.f) * 255.f));
      }
    }
}

}  // namespace

namespace detail {

SampleFrame makeSampleFrame(const Geometry& g, const render::detail::Frame& f, const StyleTable& t) {
  SampleFrame sf;
  const Dims& d = g.dims;
  const Vec3 centre = g.indexToPhysical({(d.x - 1) * 0.5, (d.y - 1) * 0.5, (d.z - 1) * 0.5});
  double radius = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner{(c & 1) ? d.x - 0.5 : -0.5, (c & 2) ? d.y - 0.5 : -0.5, (c & 4) ? d.z - 0.5 : -0.5};
    radius = std::max(radius, norm(g.indexToPhysical(corner) - centre));
  }
  sf.centre = f3(centre);
  sf.radius = float(std::max(radius, 1e-6));
  sf.forward = f3(f.forward);
  const Vec3 L = normalized(f.right * t.light.x + f.up * t.light.y - f.forward * t.light.z);
  sf.light = f3(L);
  sf.coverageH = float(std::min({g.spacing.x, g.spacing.y, g.spacing.z}));
  sf.stepMm = float(f.stepMm);
  return sf;
}

}  // namespace detail

RgbaImage renderIllustrationCpu(const ShapeScene& scene, const Style& style, const IllustrationSettings& settings) {
  validateScene(scene);
  CpuContext cx{scene, settings, render::detail::makeFrame(scene.distance.geometry(), nullptr, settings.render),
                packStyle(style, scene.segments.table(), scene.segments.maxId(), scene.distance.geometry()), {}, {},
                false, {}, {}};
  cx.grad = computeDistanceGradient(scene.distance, scene.segments.ids());
  if (cx.table.usesCt) {
    if (!scene.ct) throw Error("illustrate: style '" + style.name + "' uses the CT (illum = ct or boundary_measure = ct) but no CT was given");
    cx.ct = computeCtGradient(*scene.ct);
    cx.useCt = true;
  }
  if (cx.table.usesTextureVolume) {
    if (style.textureVolume.empty()) throw Error("illustrate: style '" + style.name + "' has texture = volume rows but no texture_volume");
    cx.texVol = loadTextureVolume(style.textureVolume);
  }
  cx.sf = makeSampleFrame(scene.distance.geometry(), cx.frame, cx.table);
  RgbaImage image(settings.render.width, settings.render.height);
  parallelFor(settings.render.height, [&](int64_t y0, int64_t y1) { renderRows(cx, image, int(y0), int(y1)); });
  return image;
}

}  // namespace vellum::illustration
