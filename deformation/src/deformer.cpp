#include "vellum/deformation/deformer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "mls_kernel.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/simd_clones.hpp"
#include "vellum/deformation/deform_params.hpp"

namespace vellum::deformation {
struct RowWork;
namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The trilinear blend of all n rho fields at one position: rho[p] = sum over the 8 corners of
// weight * field value (a node's n fields are contiguous in the cache). Blocks of 8 points are
// one vector each: one AVX2 multiply-add per corner in the fast clone, two SSE ones otherwise.
VELLUM_SIMD_CLONES void blendRhoCorners(const float* fields, const int64_t* offsets,
                                        const float* weights, int n, float* rho, int stride) {
  using Float8 = float __attribute__((vector_size(32)));
  int p0 = 0;
  for (; p0 + 8 <= n; p0 += 8) {
    Float8 acc = {};
    for (int q = 0; q < 8; ++q) {
      Float8 f;
      std::memcpy(&f, fields + offsets[q] * n + p0, sizeof f);
      acc += weights[q] * f;
    }
    for (int p = 0; p < 8; ++p) rho[static_cast<size_t>(p0 + p) * stride] = acc[p];
  }
  for (; p0 < n; ++p0) {
    float acc = 0;
    for (int q = 0; q < 8; ++q) acc += weights[q] * fields[offsets[q] * n + p0];
    rho[static_cast<size_t>(p0) * stride] = acc;
  }
}

}  // namespace

struct Deformer::Impl {
  DeformParams params;
  Geometry output, grid, rhoGrid;
  int rhoScale = 1;
  Mat3 mmToIndex;  // (direction * diag(spacing))^-1 of the source (= output) geometry
  std::unique_ptr<DensityVolume> density;
  ControlPoints points;
  // rho cache: nodes x N floats (point fastest), the source each field was built for.
  std::vector<float> rhoFields;
  std::vector<Vec3> fieldSource;
  std::vector<bool> fieldValid;
  ControlVolume cv;
  DeformTimings timings;

  Vec3 sourceIndex(const Vec3& mm) const { return mmToIndex * (mm - output.origin); }

  void rebuildRhoFields(Progress& progress);
  void computeMap(Progress& progress);
  void lookupRho(const Vec3& ui, float* rho, int stride) const;
  void solveRow(RowWork& w, const std::vector<Vec3>& xIdx, bool withAttr) const;
};

Deformer::Deformer(const AnyVolume& source, const DeformParams& params)
    : impl_(std::make_unique<Impl>()) {
  validate(params);
  auto& m = *impl_;
  m.params = params;
  m.output = geometryOf(source);
  m.output.validate("deformation source");
  m.grid = controlGrid(m.output, params.controlScale);
  m.rhoScale = params.rhoScale > 0 ? params.rhoScale : params.controlScale;
  m.rhoGrid = controlGrid(m.output, m.rhoScale);
  const Mat3 toMm = m.output.direction * Mat3::fromColumns({m.output.spacing.x, 0, 0},
                                                            {0, m.output.spacing.y, 0},
                                                            {0, 0, m.output.spacing.z});
  if (!toMm.inverse(m.mmToIndex)) throw Error("deformation source: singular geometry");
  if (params.density.enabled) {
    const auto t0 = std::chrono::steady_clock::now();
    m.density = std::make_unique<DensityVolume>(source, params.density);
    m.timings.densityBuildMs = msSince(t0);
  }
  m.cv.grid = m.grid;
  m.cv.scale = params.controlScale;
}

Deformer::~Deformer() = default;
Deformer::Deformer(Deformer&&) noexcept = default;
Deformer& Deformer::operator=(Deformer&&) noexcept = default;

const DeformParams& Deformer::params() const { return impl_->params; }
const Geometry& Deformer::outputGeometry() const { return impl_->output; }
const Geometry& Deformer::grid() const { return impl_->grid; }
const ControlPoints& Deformer::points() const { return impl_->points; }
const ControlVolume& Deformer::controlVolume() const { return impl_->cv; }
const DeformTimings& Deformer::timings() const { return impl_->timings; }

void Deformer::setPoints(const ControlPoints& points) {
  auto& m = *impl_;
  if (points.size() != m.points.size()) {
    m.fieldValid.assign(points.size(), false);
    m.fieldSource.assign(points.size(), Vec3{});
    m.rhoFields.clear();
  }
  for (size_t i = 0; i < points.size(); ++i)
    if (!(m.fieldSource[i] == points[i].source)) m.fieldValid[i] = false;
  m.points = points;
}

void Deformer::Impl::rebuildRhoFields(Progress& progress) {
  timings.rhoFieldsRebuilt = 0;
  timings.rhoCacheMs = 0;
  if (!density || !params.density.rhoCache) return;
  const size_t n = points.size();
  std::vector<int> stale;
  for (size_t i = 0; i < n; ++i)
    if (!fieldValid[i]) stale.push_back(static_cast<int>(i));
  if (stale.empty()) return;
  const auto t0 = std::chrono::steady_clock::now();
  const Dims d = rhoGrid.dims;
  if (rhoFields.size() != static_cast<size_t>(d.voxelCount()) * n) {
    checkMemoryBudget(static_cast<uint64_t>(d.voxelCount()) * n * sizeof(float), "rho-field cache");
    rhoFields.assign(static_cast<size_t>(d.voxelCount()) * n, 1.f);
  }
  std::vector<Vec3> xIdx;
  for (int i : stale) xIdx.push_back(sourceIndex(points[static_cast<size_t>(i)].source));
  const double s = rhoScale;
  progress.begin("rho fields", static_cast<uint64_t>(d.z));
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const Vec3 a{i * s, j * s, k * s};  // node position in source index space
          float* f = rhoFields.data() + static_cast<size_t>((k * d.y + j) * d.x + i) * n;
          for (size_t t = 0; t < stale.size(); ++t)
            f[stale[t]] = static_cast<float>(density->rho(a, xIdx[t]));
        }
      progress.advance();
    }
  });
  progress.end();
  for (int i : stale) {
    fieldValid[static_cast<size_t>(i)] = true;
    fieldSource[static_cast<size_t>(i)] = points[static_cast<size_t>(i)].source;
  }
  timings.rhoFieldsRebuilt = static_cast<int>(stale.size());
  timings.rhoCacheMs = msSince(t0);
}

// Per-thread buffers of one row solve.
struct RowWork {
  detail::RowEvaluator eval;
  std::vector<double> u, u2, attr;
  std::vector<float> rho;
  RowWork(const detail::PointData& data, const MlsParams& mls, int maxLen, bool withAttr,
          bool density)
      : eval(data, mls, maxLen), u(3 * static_cast<size_t>(maxLen)), u2(u.size()),
        attr(withAttr ? 4 * static_cast<size_t>(maxLen) : 0),
        rho(density ? static_cast<size_t>(data.count) * maxLen : 0) {}
};

// Trilinear lookup of all N rho fields at a source index position (they share the corner
// weights); writes rho[p * stride + x].
void Deformer::Impl::lookupRho(const Vec3& ui, float* rho, int stride) const {
  const Dims d = rhoGrid.dims;
  const int n = static_cast<int>(points.size());
  const double invS = 1.0 / rhoScale;
  double c[3];
  int64_t i0[3];
  const int64_t dd[3] = {d.x, d.y, d.z};
  for (int a = 0; a < 3; ++a) {
    const double g = std::clamp(ui[a] * invS, 0.0, double(dd[a] - 1));
    i0[a] = std::min<int64_t>(static_cast<int64_t>(g), std::max<int64_t>(dd[a] - 2, 0));
    c[a] = dd[a] > 1 ? g - double(i0[a]) : 0.0;
  }
  const int64_t sx = d.x > 1 ? 1 : 0, sy = d.y > 1 ? d.x : 0, sz = d.z > 1 ? d.x * d.y : 0;
  const int64_t base = (i0[2] * d.y + i0[1]) * d.x + i0[0];
  const int64_t off[8] = {base, base + sx, base + sy, base + sy + sx,
                          base + sz, base + sz + sx, base + sz + sy, base + sz + sy + sx};
  const float wgt[8] = {
      float((1 - c[0]) * (1 - c[1]) * (1 - c[2])), float(c[0] * (1 - c[1]) * (1 - c[2])),
      float((1 - c[0]) * c[1] * (1 - c[2])), float(c[0] * c[1] * (1 - c[2])),
      float((1 - c[0]) * (1 - c[1]) * c[2]), float(c[0] * (1 - c[1]) * c[2]),
      float((1 - c[0]) * c[1] * c[2]), float(c[0] * c[1] * c[2])};
  blendRhoCorners(rhoFields.data(), off, wgt, n, rho, stride);
}

// Solves the row already set in w.eval: plain MLS, then the density fixed point. Result in w.u.
void Deformer::Impl::solveRow(RowWork& w, const std::vector<Vec3>& xIdx, bool withAttr) const {
  const int len = w.eval.length();
  const int n = static_cast<int>(points.size());
  w.eval.solve(nullptr, w.u.data(), withAttr ? w.attr.data() : nullptr);
  if (!density || params.density.iterations <= 0) return;
  for (int it = 0; it < params.density.iterations; ++it) {
    for (int x = 0; x < len; ++x) {
      const Vec3 ui = sourceIndex({w.u[3 * x], w.u[3 * x + 1], w.u[3 * x + 2]});
      if (params.density.rhoCache) {
        lookupRho(ui, w.rho.data() + x, len);
      } else {
        for (int p = 0; p < n; ++p)
          w.rho[static_cast<size_t>(p) * len + x] =
              static_cast<float>(density->rho(ui, xIdx[static_cast<size_t>(p)]));
      }
    }
    w.eval.solve(w.rho.data(), w.u2.data(), withAttr ? w.attr.data() : nullptr);
    double maxDelta = 0;
    for (size_t t = 0; t < 3 * static_cast<size_t>(len); ++t)
      maxDelta = std::max(maxDelta, std::abs(w.u2[t] - w.u[t]));
    w.u.swap(w.u2);
    if (params.density.toleranceMm > 0 && maxDelta < params.density.toleranceMm) break;
  }
}

void Deformer::Impl::computeMap(Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool withAttr = params.attributes && hasAttributes(points);
  const auto data = detail::PointData::from(points, withAttr);
  const Dims d = grid.dims;
  const int nx = static_cast<int>(d.x);
  checkMemoryBudget(d, 3 * sizeof(float), "control volume");
  cv.grid = grid;
  cv.scale = params.controlScale;
  cv.rigidSnap.reset();
  resizeHugePaged(cv.sourceMm, static_cast<size_t>(d.voxelCount()) * 3);
  if (withAttr) cv.attributes.resize(static_cast<size_t>(d.voxelCount()) * 4);
  else cv.attributes.clear();

  const Vec3 stepMm = grid.direction.column(0) * grid.spacing.x;
  std::vector<Vec3> xIdx;
  for (const auto& p : points) xIdx.push_back(sourceIndex(p.source));
  const int64_t rows = d.y * d.z;
  progress.begin("control volume", static_cast<uint64_t>(d.z));
  parallelFor(rows, [&](int64_t r0, int64_t r1) {
    RowWork w(data, params.mls, nx, withAttr, density != nullptr);
    w.eval.setSinglePrecision(params.singlePrecisionGrid);
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t j = r % d.y, k = r / d.y;
      w.eval.setRow(grid.indexToPhysical({0.0, double(j), double(k)}), stepMm, nx);
      solveRow(w, xIdx, withAttr);
      float* out = cv.sourceMm.data() + static_cast<size_t>(r) * nx * 3;
      for (size_t t = 0; t < 3 * static_cast<size_t>(nx); ++t) out[t] = static_cast<float>(w.u[t]);
      if (withAttr) {
        float* oa = cv.attributes.data() + static_cast<size_t>(r) * nx * 4;
        for (size_t t = 0; t < 4 * static_cast<size_t>(nx); ++t) oa[t] = static_cast<float>(w.attr[t]);
      }
      if (j == d.y - 1) progress.advance();
    }
  }, 4);
  progress.end();
  timings.mapMs = msSince(t0);
}

std::vector<Vec3> Deformer::mapPoints(const std::vector<Vec3>& outputMm,
                                      std::vector<std::array<double, 4>>* attributesOut) {
  auto& m = *impl_;
  if (m.points.empty()) throw Error("deformation: no control points");
  m.rebuildRhoFields(Progress::none());
  const bool withAttr = attributesOut != nullptr;
  const auto data = detail::PointData::from(m.points, withAttr);
  std::vector<Vec3> xIdx;
  for (const auto& p : m.points) xIdx.push_back(m.sourceIndex(p.source));
  std::vector<Vec3> result(outputMm.size());
  if (attributesOut) attributesOut->assign(outputMm.size(), {0, 0, 0, 1});
  constexpr int kChunk = 128;
  const int64_t chunks = (static_cast<int64_t>(outputMm.size()) + kChunk - 1) / kChunk;
  parallelFor(chunks, [&](int64_t c0, int64_t c1) {
    RowWork w(data, m.params.mls, kChunk, withAttr, m.density != nullptr);
    for (int64_t c = c0; c < c1; ++c) {
      const size_t begin = static_cast<size_t>(c) * kChunk;
      const int len = static_cast<int>(std::min<size_t>(kChunk, outputMm.size() - begin));
      w.eval.setPositions(outputMm.data() + begin, len);
      m.solveRow(w, xIdx, withAttr);
      for (int k = 0; k < len; ++k) {
        result[begin + static_cast<size_t>(k)] = {w.u[3 * k], w.u[3 * k + 1], w.u[3 * k + 2]};
        if (attributesOut)
          for (int a = 0; a < 4; ++a)
            (*attributesOut)[begin + static_cast<size_t>(k)][static_cast<size_t>(a)] =
                w.attr[4 * static_cast<size_t>(k) + static_cast<size_t>(a)];
      }
    }
  });
  return result;
}

const ControlVolume& Deformer::update(Progress& progress) {
  auto& m = *impl_;
  if (m.points.empty()) throw Error("deformation: no control points");
  m.rebuildRhoFields(progress);
  m.computeMap(progress);
  return m.cv;
}

ControlVolume computeControlVolume(const AnyVolume& source, const ControlPoints& points,
                                   const DeformParams& params, Progress& progress) {
  Deformer d(source, params);
  d.setPoints(points);
  return d.update(progress);
}

}  // namespace vellum::deformation
