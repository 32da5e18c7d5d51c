#include "render_common.hpp"

#include <algorithm>
#include <limits>
#include <numbers>
#include <string>

#include "vellum/core/box_corners.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::render::detail {

void checkImageSize(int width, int height) {
  if (width < 1 || height < 1 || width > kMaxImageSize || height > kMaxImageSize)
    throw Error("render size " + std::to_string(width) + "x" + std::to_string(height) +
                " is out of range: width and height must be 1.." + std::to_string(kMaxImageSize));
}

Frame makeFrame(const Geometry& source, const Geometry* mapGrid, const RenderSettings& s) {
  checkImageSize(s.width, s.height);
  validate(s);  // the table's ranges: zoom, field of view, step, angles
  const Camera& cam = s.camera;
  if (!isFinite(cam.panMm)) throw Error("camera pan must be finite");

  Frame f;
  f.width = s.width;
  f.height = s.height;
  f.box = mapGrid ? *mapGrid : source;
  const Dims& d = f.box.dims;
  Mat3 dirInv;
  if (!f.box.direction.inverse(dirInv)) throw Error("render: singular direction matrix");
  const Mat3 invSpacing = Mat3::fromColumns({1.0 / f.box.spacing.x, 0, 0},
                                            {0, 1.0 / f.box.spacing.y, 0},
                                            {0, 0, 1.0 / f.box.spacing.z});
  f.physToBox = invSpacing * dirInv;
  // Exactly -0.5 and dims - 0.5 unclipped, so the default picture is bit-identical.
  for (int a = 0; a < 3; ++a) {
    f.clipLo[a] = -0.5 + s.clipMin[size_t(a)] * double(d[a]);
    f.clipHi[a] = -0.5 + s.clipMax[size_t(a)] * double(d[a]);
  }

  // Bounding sphere of the box's eight corners (voxel boxes, not centres).
  const Vec3 centre = f.box.indexToPhysical({(d.x - 1) * 0.5, (d.y - 1) * 0.5, (d.z - 1) * 0.5});
  const double radius = voxelBoxRadius(f.box, centre);
  const Vec3 lookAt = centre + cam.panMm;

  // Orbit: azimuth about +z (superior), from anterior (-y) at azimuth 0; right is the
  // azimuth-rotated +x (patient left appears on screen right when seen from the front).
  const double az = cam.azimuthDeg * std::numbers::pi / 180.0;
  const double el = cam.elevationDeg * std::numbers::pi / 180.0;
  const Vec3 toEye{std::cos(el) * std::sin(az), -std::cos(el) * std::cos(az), std::sin(el)};
  f.forward = -toEye;
  f.right = {std::cos(az), std::sin(az), 0};
  f.up = cross(f.right, f.forward);

  // Zoom 1 fits the bounding sphere into the shorter image side.
  const double aspect = static_cast<double>(s.width) / s.height;
  const double sx = aspect >= 1 ? aspect : 1.0, sy = aspect >= 1 ? 1.0 : 1.0 / aspect;
  f.perspective = cam.fieldOfViewDeg > 0;
  if (f.perspective) {
    const double half = cam.fieldOfViewDeg * std::numbers::pi / 360.0;
    const double dist = radius / std::sin(half);
    f.eye = lookAt - f.forward * dist;
    f.halfW = std::tan(half) / cam.zoom * sx;
    f.halfH = std::tan(half) / cam.zoom * sy;
  } else {
    f.eye = lookAt - f.forward * (2 * radius + norm(cam.panMm) + 1.0);
    f.halfW = radius / cam.zoom * sx;
    f.halfH = radius / cam.zoom * sy;
  }

  f.stepMm = s.stepVoxels * source.minSpacing();
  const double maxLength = 2 * radius + 2 * norm(cam.panMm) + 4 * radius;
  if (maxLength / f.stepMm > static_cast<double>(kMaxStepsPerRay))
    throw Error("ray step of " + std::to_string(s.stepVoxels) +
                " voxels is too small for this volume (more than " +
                std::to_string(kMaxStepsPerRay) + " steps per ray)");
  return f;
}

Ray pixelRay(const Frame& f, int px, int py) {
  const double sx = ((px + 0.5) / f.width * 2 - 1) * f.halfW;
  const double sy = (1 - (py + 0.5) / f.height * 2) * f.halfH;
  const Vec3 offset = f.right * sx + f.up * sy;
  if (f.perspective) return {f.eye, normalized(f.forward + offset)};
  return {f.eye + offset, f.forward};
}

float pixelJitter(int px, int py) {
  uint32_t h = static_cast<uint32_t>(px) * 1973u + static_cast<uint32_t>(py) * 9277u + 26699u;
  h = (h ^ (h >> 15)) * 0x2c1b3c6du;
  h = (h ^ (h >> 12)) * 0x297a2d39u;
  h ^= h >> 15;
  return static_cast<float>(h >> 8) * (1.f / 16777216.f);
}

Clip clipRay(const Frame& f, const Ray& r, double jitter) {
  Clip c;
  c.jitter = jitter;
  c.o = f.physToBox * (r.origin - f.box.origin);
  c.d = f.physToBox * r.dir;
  double tmin = -std::numeric_limits<double>::infinity();
  double tmax = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    double da = c.d[a];
    if (std::abs(da) < 1e-12) da = da < 0 ? -1e-12 : 1e-12;
    const double t0 = (f.clipLo[a] - c.o[a]) / da, t1 = (f.clipHi[a] - c.o[a]) / da;
    tmin = std::max(tmin, std::min(t0, t1));
    tmax = std::min(tmax, std::max(t0, t1));
  }
  tmin = std::max(tmin, 0.0);
  if (tmax < tmin) return c;
  c.k0 = static_cast<int64_t>(std::ceil(tmin / f.stepMm - jitter));
  c.k1 = std::min(static_cast<int64_t>(std::floor(tmax / f.stepMm - jitter)), c.k0 + kMaxStepsPerRay);
  return c;
}

TfTable buildTfTable(const RenderSettings& s, double stepMm) {
  TransferFunction tf = s.transferFunction.points.empty() ? TransferFunction::forPreset(s.preset)
                                                          : s.transferFunction;
  if (s.windowWidth > 0) {
    const double scale = s.windowWidth / kPresetWindowWidth;
    for (auto& p : tf.points) p.value = s.windowCenter + (p.value - kPresetWindowCenter) * scale;
  }
  std::sort(tf.points.begin(), tf.points.end(),
            [](const auto& a, const auto& b) { return a.value < b.value; });
  TfTable t;
  if (!tf.points.empty()) {
    t.lo = tf.points.front().value;
    t.hi = tf.points.back().value;
  }
  if (!(t.hi - t.lo > 1e-6)) t.hi = t.lo + 1.0;
  t.rgba.resize(4 * kTfTableSize);
  for (int i = 0; i < kTfTableSize; ++i) {
    const double v = t.lo + (t.hi - t.lo) * i / (kTfTableSize - 1);
    std::array<float, 4> c = tf.evaluate(v);
    for (int k = 0; k < 4; ++k) c[k] = std::clamp(c[k], 0.f, 1.f);
    // Opacity per mm -> per step: the same optical depth whatever the step.
    c[3] = c[3] >= 1.f ? 1.f : static_cast<float>(1.0 - std::pow(1.0 - c[3], stepMm));
    std::copy(c.begin(), c.end(), t.rgba.begin() + 4 * i);
  }
  return t;
}

std::array<float, 4> TfTable::lookup(double value) const {
  const float x = std::clamp(static_cast<float>((value - lo) / (hi - lo)), 0.f, 1.f) *
                  static_cast<float>(kTfTableSize - 1);
  const int i = std::min(static_cast<int>(x), kTfTableSize - 2);
  const float f = x - static_cast<float>(i);
  std::array<float, 4> out{};
  for (int k = 0; k < 4; ++k) out[k] = rgba[4 * i + k] + f * (rgba[4 * (i + 1) + k] - rgba[4 * i + k]);
  return out;
}

double mipGrey(const RenderSettings& s, double maxValue) {
  const double width = s.windowWidth > 0 ? s.windowWidth : 1.0;
  return std::clamp((maxValue - (s.windowCenter - 0.5 * width)) / width, 0.0, 1.0);
}

void validateMap(const BackwardMap& map) {
  map.grid.validate("backward map grid");
  const auto n = static_cast<size_t>(map.grid.dims.voxelCount());
  if (map.sourceMm.size() != 3 * n)
    throw Error("backward map: sourceMm has " + std::to_string(map.sourceMm.size()) +
                " floats, expected 3 x " + map.grid.dims.str());
  if (!map.attributes.empty() && map.attributes.size() != 4 * n)
    throw Error("backward map: attributes has " + std::to_string(map.attributes.size()) +
                " floats, expected 0 or 4 x " + map.grid.dims.str());
  if (map.twist) {
    if (map.twist->weights.size() != map.twist->stride() * n)
      throw Error("backward map: the twist kernel has " + std::to_string(map.twist->stages().size()) + " stages and " +
                  std::to_string(map.twist->weights.size()) + " weights, expected one per stage and node (" +
                  map.grid.dims.str() + ")");
    if (map.upsampling != Upsampling::Trilinear) throw Error("backward map: the twist kernel replaces the trilinear one only");
  }
  if (map.rigidSnap && map.rigidSnap->fits.size() > static_cast<size_t>(kMaxSnapBodies))
    throw Error("backward map: the rigid snap has " + std::to_string(map.rigidSnap->fits.size()) +
                " bodies; the renderer handles at most " + std::to_string(kMaxSnapBodies));
}

}  // namespace vellum::render::detail

namespace vellum::render {

BackwardMap identityBackwardMap(const Geometry& grid, std::vector<float> attributes, std::optional<Geometry> output) {
  grid.validate("backward map grid");
  BackwardMap m;
  m.grid = grid;
  m.sourceMm = identityNodes(grid);
  m.attributes = std::move(attributes);
  m.output = std::move(output);
  detail::validateMap(m);
  return m;
}

}  // namespace vellum::render

namespace vellum::render::detail {

std::vector<float> mapToSourceIndex(const BackwardMap& map, const Geometry& source) {
  validateMap(map);
  std::vector<float> out;
  resizeHugePaged(out, map.sourceMm.size());
  const Geometry::ToIndex toIndex = source.physicalToIndexMap();  // the inverse direction once
  parallelFor(int64_t(out.size() / 3), [&](int64_t n0, int64_t n1) {  // a movie frame's 11.5 M nodes
    for (size_t i = 3 * size_t(n0); i < 3 * size_t(n1); i += 3) {
      const Vec3 u = toIndex({map.sourceMm[i], map.sourceMm[i + 1], map.sourceMm[i + 2]});
      out[i] = static_cast<float>(u.x);
      out[i + 1] = static_cast<float>(u.y);
      out[i + 2] = static_cast<float>(u.z);
    }
  });
  return out;
}

namespace {

float toLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }
float toSrgb(float c) {
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}
constexpr float kDelta = 6.f / 29.f;
float labF(float t) {
  return t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3 * kDelta * kDelta) + 4.f / 29.f;
}
float labFInv(float t) { return t > kDelta ? t * t * t : 3 * kDelta * kDelta * (t - 4.f / 29.f); }
constexpr float kWhite[3] = {0.95047f, 1.f, 1.08883f};

}  // namespace

// Same formulas as labShift() in the shader (shader_source.cpp).
std::array<float, 3> labShift(const std::array<float, 3>& rgb, float dL, float da, float db) {
  const float r = toLinear(rgb[0]), g = toLinear(rgb[1]), b = toLinear(rgb[2]);
  const float X = 0.4124f * r + 0.3576f * g + 0.1805f * b;
  const float Y = 0.2126f * r + 0.7152f * g + 0.0722f * b;
  const float Z = 0.0193f * r + 0.1192f * g + 0.9505f * b;
  const float fx = labF(X / kWhite[0]), fy = labF(Y / kWhite[1]), fz = labF(Z / kWhite[2]);
  const float L = 116 * fy - 16 + dL, A = 500 * (fx - fy) + da, B = 200 * (fy - fz) + db;
  const float gy = (L + 16) / 116, gx = gy + A / 500, gz = gy - B / 200;
  const float X2 = kWhite[0] * labFInv(gx), Y2 = kWhite[1] * labFInv(gy), Z2 = kWhite[2] * labFInv(gz);
  const float r2 = 3.2406f * X2 - 1.5372f * Y2 - 0.4986f * Z2;
  const float g2 = -0.9689f * X2 + 1.8758f * Y2 + 0.0415f * Z2;
  const float b2 = 0.0557f * X2 - 0.2040f * Y2 + 1.0570f * Z2;
  return {std::clamp(toSrgb(std::max(r2, 0.f)), 0.f, 1.f), std::clamp(toSrgb(std::max(g2, 0.f)), 0.f, 1.f),
          std::clamp(toSrgb(std::max(b2, 0.f)), 0.f, 1.f)};
}

}  // namespace vellum::render::detail
