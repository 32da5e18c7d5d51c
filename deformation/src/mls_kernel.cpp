#include "mls_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "vellum/core/error.hpp"
#include "vellum/core/rigid_fit.hpp"
#include "vellum/core/simd_clones.hpp"

namespace vellum::deformation::detail {
namespace {

// Accumulator slots (arrays of maxLen doubles each).
enum Slot {
  kVx = 0, kVy, kVz, kW, kXh0, kXh1, kXh2, kYh0, kYh1, kYh2, kZh0,
  kA00 = kZh0 + 4, kA01, kA02, kA11, kA12, kA22,
  kB00, kC00 = kB00 + 9, kYm0 = kC00 + 12, kYm1, kYm2, kXm0, kXm1, kXm2, kWmax, kMd2, kMid,
  kSlots
};

// Below this distance (mm) v counts as sitting on y_i: u = x_i exactly.
constexpr double kHitDist2 = 1e-18;
// Weights are computed from max(d^2, this): 1e-6 mm keeps (1/d^2)^3 within float range.
constexpr double kWeightDist2 = 1e-12;

// Rotation (and similarity scale) from B = sum w q^T p: the nearest rotation to B maximises
// trace(R^T B), i.e. minimises sum w |q R - p|^2 over rotations (row-vector convention).
void constrainToRotation(double* m, double traceA, bool similarity) {
  Mat3 b;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) b(r, c) = m[r * 3 + c];
  double signedTrace = 0;
  const Mat3 r = nearestRotation(b, &signedTrace);
  const double mu = similarity && traceA > 0 ? signedTrace / traceA : 1.0;
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) m[i * 3 + c] = mu * r(i, c);
}


// The regularised normal matrix A' = A + lam I is symmetric: six entries per node.
template <class V>
struct Sym3 {
  V a00, a01, a02, a11, a12, a22;
};

// (A + lam I)^-1 by cofactors, and the affine solution M = (A + lam I)^-1 (B + lam I) for a
// row-major B, in place. One copy for the three solvers (scalar doubles, 4-double and 8-float
// vectors: V is the lane type), so they differ only in the precision of V.
template <class V>
VELLUM_INLINE_LAMBDA inline Sym3<V> shiftedInverse(Sym3<V> a, V lam) {
  a.a00 += lam; a.a11 += lam; a.a22 += lam;
  const V c00 = a.a11 * a.a22 - a.a12 * a.a12, c01 = a.a02 * a.a12 - a.a01 * a.a22,
          c02 = a.a01 * a.a12 - a.a02 * a.a11, c11 = a.a00 * a.a22 - a.a02 * a.a02,
          c12 = a.a01 * a.a02 - a.a00 * a.a12, c22 = a.a00 * a.a11 - a.a01 * a.a01;
  const V inv = 1 / (a.a00 * c00 + a.a01 * c01 + a.a02 * c02);
  return {c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, c22 * inv};
}

template <class V>
VELLUM_INLINE_LAMBDA inline void affineSolution(const Sym3<V>& i, V lam, V* m) {
  m[0] += lam; m[4] += lam; m[8] += lam;
  V r[9];
  for (int c = 0; c < 3; ++c) {
    r[0 + c] = i.a00 * m[c] + i.a01 * m[3 + c] + i.a02 * m[6 + c];
    r[3 + c] = i.a01 * m[c] + i.a11 * m[3 + c] + i.a12 * m[6 + c];
    r[6 + c] = i.a02 * m[c] + i.a12 * m[3 + c] + i.a22 * m[6 + c];
  }
  for (int t = 0; t < 9; ++t) m[t] = r[t];
}
}  // namespace

PointData PointData::from(const ControlPoints& points, bool withAttributes) {
  PointData d;
  d.count = static_cast<int>(points.size());
  if (d.count == 0) throw Error("MLS deformation needs at least one control point");
  for (const auto& p : points) {
    if (!isFinite(p.source) || !isFinite(p.target))
      throw Error("control point with a non-finite position");
    d.sourceCentre += p.source / d.count;
    d.targetCentre += p.target / d.count;
  }
  d.attributes = withAttributes;
  for (const auto& p : points) {
    const Vec3 s = p.source - d.sourceCentre, t = p.target - d.targetCentre;
    d.sx.push_back(s.x); d.sy.push_back(s.y); d.sz.push_back(s.z);
    d.tx.push_back(t.x); d.ty.push_back(t.y); d.tz.push_back(t.z);
    d.sxf.push_back(float(s.x)); d.syf.push_back(float(s.y)); d.szf.push_back(float(s.z));
    d.txf.push_back(float(t.x)); d.tyf.push_back(float(t.y)); d.tzf.push_back(float(t.z));
    d.sourceMm.push_back(p.source);
    const auto v = p.attributes.values();
    d.zi.push_back(v);
    for (int a = 0; a < PointAttributes::kCount; ++a) d.z[a].push_back(v[static_cast<size_t>(a)]);
  }
  return d;
}

RowEvaluator::RowEvaluator(const PointData& points, const MlsParams& params, int maxLen)
    : p_(points), params_(params), maxLen_((std::max(maxLen, 1) + kLanes - 1) / kLanes * kLanes) {
  if (!(params.power > 0) || !std::isfinite(params.power))
    throw Error("MLS weight power must be > 0");
  if (!(params.regularisation > 0) || params.regularisation >= 1)
    throw Error("MLS regularisation must be in (0, 1)");
  const size_t n = static_cast<size_t>(p_.count) * maxLen_;
  w0_.assign(n, 0.0);
  w_.assign(n, 0.0);
  buf_.assign(static_cast<size_t>(kSlots) * maxLen_, 0.0);
  hit_.assign(static_cast<size_t>(maxLen_), -1);
  dom_.assign(static_cast<size_t>(maxLen_), 0);
}

void RowEvaluator::setRow(const Vec3& baseMm, const Vec3& stepMm, int len) {
  len_ = std::min(len, maxLen_);
  stride_ = (len_ + kLanes - 1) / kLanes * kLanes;
  const Vec3 b = baseMm - p_.targetCentre;
  double* vx = arr(kVx); double* vy = arr(kVy); double* vz = arr(kVz);
  for (int k = 0; k < len_; ++k) {
    vx[k] = b.x + k * stepMm.x;
    vy[k] = b.y + k * stepMm.y;
    vz[k] = b.z + k * stepMm.z;
  }
  computeWeights();
}

void RowEvaluator::setPositions(const Vec3* positionsMm, int len) {
  len_ = std::min(len, maxLen_);
  stride_ = (len_ + kLanes - 1) / kLanes * kLanes;
  double* vx = arr(kVx); double* vy = arr(kVy); double* vz = arr(kVz);
  for (int k = 0; k < len_; ++k) {
    const Vec3 v = positionsMm[k] - p_.targetCentre;
    vx[k] = v.x; vy[k] = v.y; vz[k] = v.z;
  }
  computeWeights();
}

VELLUM_SIMD_CLONES void RowEvaluator::computeWeights() {
  double* vx = arr(kVx); double* vy = arr(kVy); double* vz = arr(kVz);
  // Padding lanes repeat the last node (finite weights; results discarded).
  for (int k = len_; k < stride_; ++k) { vx[k] = vx[len_ - 1]; vy[k] = vy[len_ - 1]; vz[k] = vz[len_ - 1]; }
  double* md2 = arr(kMd2); double* mid = arr(kMid);
  for (int k = 0; k < stride_; ++k) { md2[k] = 1e300; mid[k] = 0; }
  const double n = params_.power;
  const int mode = n == 2 ? 0 : n == 4 ? 1 : n == 1 ? 2 : n == 3 ? 3 : 4;
  for (int i = 0; i < p_.count; ++i) {
    const double tx = p_.tx[static_cast<size_t>(i)], ty = p_.ty[static_cast<size_t>(i)],
                 tz = p_.tz[static_cast<size_t>(i)];
    double* w = w0_.data() + static_cast<size_t>(i) * stride_;
    // One loop per power so that each vectorises (no branch inside). The reciprocal is taken
    // in single precision (4x the throughput): any positive weights keep the map's exactness
    // properties, and hits are decided on the exact squared distance below.
    typedef double v4 __attribute__((vector_size(32)));
    typedef float v4f __attribute__((vector_size(16)));
    auto load = [](const double* p) VELLUM_INLINE_LAMBDA { v4 r; std::memcpy(&r, p, sizeof r); return r; };
    auto store = [](double* p, v4 v) VELLUM_INLINE_LAMBDA { std::memcpy(p, &v, sizeof v); };
    const v4 fi = {double(i), double(i), double(i), double(i)};
    const v4 floor2 = {kWeightDist2, kWeightDist2, kWeightDist2, kWeightDist2};
    const v4f one = {1.f, 1.f, 1.f, 1.f};
    auto loop = [&](auto weightOf) VELLUM_INLINE_LAMBDA {  // explicit 4-lane vectors: stride_ is a multiple of 4
      for (int k = 0; k < stride_; k += 4) {
        const v4 dx = load(vx + k) - tx, dy = load(vy + k) - ty, dz = load(vz + k) - tz;
        const v4 d2 = dx * dx + dy * dy + dz * dz;
        const v4 d2c = d2 > floor2 ? d2 : floor2;
        const v4 r = __builtin_convertvector(one / __builtin_convertvector(d2c, v4f), v4);
        store(w + k, weightOf(r));
        const v4 old = load(md2 + k);
        const auto closer = d2 < old;
        store(md2 + k, closer ? d2 : old);
        store(mid + k, closer ? fi : load(mid + k));
      }
    };
    switch (mode) {
      case 0: loop([](v4 r) VELLUM_INLINE_LAMBDA { return r; }); break;
      case 1: loop([](v4 r) VELLUM_INLINE_LAMBDA { return r * r; }); break;
      case 2: loop([](v4 r) VELLUM_INLINE_LAMBDA { for (int l = 0; l < 4; ++l) r[l] = std::sqrt(r[l]); return r; }); break;
      case 3: loop([](v4 r) VELLUM_INLINE_LAMBDA { for (int l = 0; l < 4; ++l) r[l] *= std::sqrt(r[l]); return r; }); break;
      default: loop([n](v4 r) VELLUM_INLINE_LAMBDA { for (int l = 0; l < 4; ++l) r[l] = std::pow(r[l], 0.5 * n); return r; }); break;
    }
  }
  for (int k = 0; k < len_; ++k)
    hit_[static_cast<size_t>(k)] = md2[k] < kHitDist2 ? static_cast<int>(mid[k]) : -1;
}

VELLUM_SIMD_CLONES void RowEvaluator::solve(const float* rho, double* u, double* attr) {
  const int n = p_.count, L = len_, S = stride_;
  const double* w = w0_.data();
  if (rho) {
    for (int i = 0; i < n; ++i) {
      const double* a = w0_.data() + static_cast<size_t>(i) * S;
      double* b = w_.data() + static_cast<size_t>(i) * S;
      const float* r = rho + static_cast<size_t>(i) * L;
#pragma omp simd
      for (int k = 0; k < L; ++k) b[k] = a[k] * static_cast<double>(r[k]);
      for (int k = L; k < S; ++k) b[k] = a[k];
    }
    w = w_.data();
  }
  const bool withAttr = attr && p_.attributes;
  if (!withAttr) {
    if (singlePrecision_ && params_.method == MlsMethod::Affine) solveBlockedFloat(w, u);
    else solveBlocked(w, u, 0, L);
    if (attr)
      for (int k = 0; k < L; ++k) { attr[4 * k] = attr[4 * k + 1] = attr[4 * k + 2] = 0; attr[4 * k + 3] = 1; }
    return;
  }
  solveWithAttributes(w, u, attr);
}

// The attribute path, pass by pass over arrays of nodes (slots of buf_).
void RowEvaluator::solveWithAttributes(const double* w, double* u, double* attr) {
  std::fill(buf_.begin() + static_cast<ptrdiff_t>(kW) * maxLen_, buf_.end(), 0.0);
  findDominantPoints(w);
  accumulateCentroids(w);
  accumulateMoments(w);
  solveNodes();
  writePositions(u);
  writeAttributes(attr);
}

VELLUM_SIMD_CLONES void RowEvaluator::findDominantPoints(const double* w) {
  const int n = p_.count, L = len_, S = stride_;
  // Pass 0: the dominant point m of each node. Centroids and q_i, p_i are formed relative to
  // y_m and x_m, so that when one weight dwarfs the others (v next to y_m, high power n) the
  // tiny q_m = y_m - y^ is computed from small differences instead of cancelling to noise.
  double* ym0 = arr(kYm0); double* ym1 = arr(kYm1); double* ym2 = arr(kYm2);
  double* xm0 = arr(kXm0); double* xm1 = arr(kXm1); double* xm2 = arr(kXm2);
  double* wmax = arr(kWmax);
  for (int k = 0; k < L; ++k) { wmax[k] = -1; dom_[static_cast<size_t>(k)] = 0; }
  for (int i = 0; i < n; ++i) {
    const double* wi = w + static_cast<size_t>(i) * S;
    for (int k = 0; k < L; ++k)
      if (wi[k] > wmax[k]) { wmax[k] = wi[k]; dom_[static_cast<size_t>(k)] = i; }
  }
  for (int k = 0; k < L; ++k) {
    const size_t m = static_cast<size_t>(dom_[static_cast<size_t>(k)]);
    ym0[k] = p_.tx[m]; ym1[k] = p_.ty[m]; ym2[k] = p_.tz[m];
    xm0[k] = p_.sx[m]; xm1[k] = p_.sy[m]; xm2[k] = p_.sz[m];
  }
}

VELLUM_SIMD_CLONES void RowEvaluator::accumulateCentroids(const double* w) {
  const int n = p_.count, L = len_, S = stride_;
  const double* ym0 = arr(kYm0); const double* ym1 = arr(kYm1); const double* ym2 = arr(kYm2);
  const double* xm0 = arr(kXm0); const double* xm1 = arr(kXm1); const double* xm2 = arr(kXm2);
  // Pass 1: weight sums and centroids (as offsets from x_m, y_m).
  double* W = arr(kW);
  double* xh0 = arr(kXh0); double* xh1 = arr(kXh1); double* xh2 = arr(kXh2);
  double* yh0 = arr(kYh0); double* yh1 = arr(kYh1); double* yh2 = arr(kYh2);
  for (int i = 0; i < n; ++i) {
    const size_t si = static_cast<size_t>(i);
    const double sx = p_.sx[si], sy = p_.sy[si], sz = p_.sz[si];
    const double tx = p_.tx[si], ty = p_.ty[si], tz = p_.tz[si];
    const double* wi = w + si * S;
#pragma omp simd
    for (int k = 0; k < L; ++k) {
      const double wk = wi[k];
      W[k] += wk;
      xh0[k] += wk * (sx - xm0[k]); xh1[k] += wk * (sy - xm1[k]); xh2[k] += wk * (sz - xm2[k]);
      yh0[k] += wk * (tx - ym0[k]); yh1[k] += wk * (ty - ym1[k]); yh2[k] += wk * (tz - ym2[k]);
    }
    for (int a = 0; a < PointAttributes::kCount; ++a) {
        double* zh = arr(kZh0 + a);
        const double z = p_.z[a][si];
#pragma omp simd
        for (int k = 0; k < L; ++k) zh[k] += wi[k] * z;
      }
  }
#pragma omp simd
  for (int k = 0; k < L; ++k) {
    const double inv = 1.0 / W[k];
    xh0[k] *= inv; xh1[k] *= inv; xh2[k] *= inv;
    yh0[k] *= inv; yh1[k] *= inv; yh2[k] *= inv;
  }
  for (int a = 0; a < PointAttributes::kCount; ++a) {
    double* zh = arr(kZh0 + a);
    for (int k = 0; k < L; ++k) zh[k] /= W[k];
  }
}

VELLUM_SIMD_CLONES void RowEvaluator::accumulateMoments(const double* w) {
  const int n = p_.count, L = len_, S = stride_;
  const double* ym0 = arr(kYm0); const double* ym1 = arr(kYm1); const double* ym2 = arr(kYm2);
  const double* xm0 = arr(kXm0); const double* xm1 = arr(kXm1); const double* xm2 = arr(kXm2);
  const double* xh0 = arr(kXh0); const double* xh1 = arr(kXh1); const double* xh2 = arr(kXh2);
  const double* yh0 = arr(kYh0); const double* yh1 = arr(kYh1); const double* yh2 = arr(kYh2);
  // Pass 2: A = sum w q^T q, B = sum w q^T p (and C = sum w q^T r for attributes).
  double* A[6];
  for (int s = 0; s < 6; ++s) A[s] = arr(kA00 + s);
  double* B[9];
  for (int s = 0; s < 9; ++s) B[s] = arr(kB00 + s);
  for (int i = 0; i < n; ++i) {
    const size_t si = static_cast<size_t>(i);
    const double sx = p_.sx[si], sy = p_.sy[si], sz = p_.sz[si];
    const double tx = p_.tx[si], ty = p_.ty[si], tz = p_.tz[si];
    const double* wi = w + si * S;
    double *a00 = A[0], *a01 = A[1], *a02 = A[2], *a11 = A[3], *a12 = A[4], *a22 = A[5];
    double *b00 = B[0], *b01 = B[1], *b02 = B[2], *b10 = B[3], *b11 = B[4], *b12 = B[5],
           *b20 = B[6], *b21 = B[7], *b22 = B[8];
#pragma omp simd
    for (int k = 0; k < L; ++k) {
      const double q0 = (tx - ym0[k]) - yh0[k], q1 = (ty - ym1[k]) - yh1[k],
                   q2 = (tz - ym2[k]) - yh2[k];
      const double p0 = (sx - xm0[k]) - xh0[k], p1 = (sy - xm1[k]) - xh1[k],
                   p2 = (sz - xm2[k]) - xh2[k];
      const double wq0 = wi[k] * q0, wq1 = wi[k] * q1, wq2 = wi[k] * q2;
      a00[k] += wq0 * q0; a01[k] += wq0 * q1; a02[k] += wq0 * q2;
      a11[k] += wq1 * q1; a12[k] += wq1 * q2; a22[k] += wq2 * q2;
      b00[k] += wq0 * p0; b01[k] += wq0 * p1; b02[k] += wq0 * p2;
      b10[k] += wq1 * p0; b11[k] += wq1 * p1; b12[k] += wq1 * p2;
      b20[k] += wq2 * p0; b21[k] += wq2 * p1; b22[k] += wq2 * p2;
    }
    for (int a = 0; a < PointAttributes::kCount; ++a) {
        const double z = p_.z[a][si];
        const double* zh = arr(kZh0 + a);
        double* c0 = arr(kC00 + a);
        double* c1 = arr(kC00 + 4 + a);
        double* c2 = arr(kC00 + 8 + a);
#pragma omp simd
        for (int k = 0; k < L; ++k) {
          const double wr = wi[k] * (z - zh[k]);
          c0[k] += wr * ((tx - ym0[k]) - yh0[k]);
          c1[k] += wr * ((ty - ym1[k]) - yh1[k]);
          c2[k] += wr * ((tz - ym2[k]) - yh2[k]);
        }
      }
  }
}

VELLUM_SIMD_CLONES void RowEvaluator::solveNodes() {
  const int L = len_;
  double* W = arr(kW);
  double* A[6];
  for (int s = 0; s < 6; ++s) A[s] = arr(kA00 + s);
  double* B[9];
  for (int s = 0; s < 9; ++s) B[s] = arr(kB00 + s);
  // Per node: regularised solve (M in B; A'^-1 in A for the attribute step).
  const double eps = params_.regularisation;
  const bool constrained = params_.method != MlsMethod::Affine;
#pragma omp simd
  for (int k = 0; k < L; ++k) {
    double a00 = A[0][k], a01 = A[1][k], a02 = A[2][k], a11 = A[3][k], a12 = A[4][k],
           a22 = A[5][k];
    double m[9] = {B[0][k], B[1][k], B[2][k], B[3][k], B[4][k], B[5][k], B[6][k], B[7][k], B[8][k]};
    const double tr = a00 + a11 + a22;
    W[k] = tr;  // the weight sum is no longer needed; keep trace(A) for the similarity scale
    double i00 = 1, i01 = 0, i02 = 0, i11 = 1, i12 = 0, i22 = 1;  // A'^-1
    double lam = 0;
    if (tr > 0) {
      const double mean = tr / 3.0;
      const double det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) +
                         a02 * (a01 * a12 - a11 * a02);
      const double c = std::max(det / (mean * mean * mean), 0.0);
      const double r = eps / (eps + c);
      lam = eps * r * r * mean;
      const Sym3<double> inv = shiftedInverse<double>({a00, a01, a02, a11, a12, a22}, lam);
      i00 = inv.a00; i01 = inv.a01; i02 = inv.a02; i11 = inv.a11; i12 = inv.a12; i22 = inv.a22;
    } else {
      lam = 1.0;  // no spread at all: M = I (pure translation)
    }
    if (!constrained) affineSolution<double>({i00, i01, i02, i11, i12, i22}, lam, m);
    // Keep inverse rows for the attribute step.
    A[0][k] = i00; A[1][k] = i01; A[2][k] = i02; A[3][k] = i11; A[4][k] = i12; A[5][k] = i22;
    for (int t = 0; t < 9; ++t) B[t][k] = m[t];
  }
  if (constrained) {
    const bool similarity = params_.method == MlsMethod::Similarity;
    for (int k = 0; k < L; ++k) {
      double m[9];
      for (int t = 0; t < 9; ++t) m[t] = B[t][k];
      constrainToRotation(m, W[k], similarity);
      for (int t = 0; t < 9; ++t) B[t][k] = m[t];
    }
  }
}

VELLUM_SIMD_CLONES void RowEvaluator::writePositions(double* u) const {
  const int L = len_;
  const double* ym0 = arr(kYm0); const double* ym1 = arr(kYm1); const double* ym2 = arr(kYm2);
  const double* xm0 = arr(kXm0); const double* xm1 = arr(kXm1); const double* xm2 = arr(kXm2);
  const double* xh0 = arr(kXh0); const double* xh1 = arr(kXh1); const double* xh2 = arr(kXh2);
  const double* yh0 = arr(kYh0); const double* yh1 = arr(kYh1); const double* yh2 = arr(kYh2);
  const double* vx = arr(kVx); const double* vy = arr(kVy); const double* vz = arr(kVz);
  const double* B[9];
  for (int s = 0; s < 9; ++s) B[s] = arr(kB00 + s);
  const Vec3 sc = p_.sourceCentre;
  for (int k = 0; k < L; ++k) {
    const double d0 = (vx[k] - ym0[k]) - yh0[k], d1 = (vy[k] - ym1[k]) - yh1[k],
                 d2 = (vz[k] - ym2[k]) - yh2[k];
    double* out = u + 3 * k;
    out[0] = d0 * B[0][k] + d1 * B[3][k] + d2 * B[6][k] + (xm0[k] + xh0[k]) + sc.x;
    out[1] = d0 * B[1][k] + d1 * B[4][k] + d2 * B[7][k] + (xm1[k] + xh1[k]) + sc.y;
    out[2] = d0 * B[2][k] + d1 * B[5][k] + d2 * B[8][k] + (xm2[k] + xh2[k]) + sc.z;
    const int h = hit_[static_cast<size_t>(k)];
    if (h >= 0) {
      const Vec3& x = p_.sourceMm[static_cast<size_t>(h)];
      out[0] = x.x; out[1] = x.y; out[2] = x.z;
    }
  }
}

VELLUM_SIMD_CLONES void RowEvaluator::writeAttributes(double* attr) const {
  const int L = len_;
  const double* ym0 = arr(kYm0); const double* ym1 = arr(kYm1); const double* ym2 = arr(kYm2);
  const double* yh0 = arr(kYh0); const double* yh1 = arr(kYh1); const double* yh2 = arr(kYh2);
  const double* vx = arr(kVx); const double* vy = arr(kVy); const double* vz = arr(kVz);
  const double* A[6];
  for (int s = 0; s < 6; ++s) A[s] = arr(kA00 + s);
  if (attr) {
    for (int k = 0; k < L; ++k) {
      double* out = attr + 4 * k;
      const int h = hit_[static_cast<size_t>(k)];
      if (!p_.attributes) {
        out[0] = out[1] = out[2] = 0; out[3] = 1;
        continue;
      }
      if (h >= 0) {
        for (int a = 0; a < 4; ++a) out[a] = p_.zi[static_cast<size_t>(h)][static_cast<size_t>(a)];
        continue;
      }
      const double d0 = (vx[k] - ym0[k]) - yh0[k], d1 = (vy[k] - ym1[k]) - yh1[k],
                   d2 = (vz[k] - ym2[k]) - yh2[k];
      // g = d A'^-1 (row vector), then f = g C + z^
      const double g0 = d0 * A[0][k] + d1 * A[1][k] + d2 * A[2][k];
      const double g1 = d0 * A[1][k] + d1 * A[3][k] + d2 * A[4][k];
      const double g2 = d0 * A[2][k] + d1 * A[4][k] + d2 * A[5][k];
      for (int a = 0; a < 4; ++a)
        out[a] = g0 * arr(kC00 + a)[k] + g1 * arr(kC00 + 4 + a)[k] + g2 * arr(kC00 + 8 + a)[k] +
                 arr(kZh0 + a)[k];
    }
  }
}

// ---- The register-blocked solves, step by step -------------------------------------------
// Each block of lanes (4 doubles or 8 floats per AVX2 register) goes through: find each lane's
// dominant point, accumulate the weighted moments about it, solve for M, apply M to the node.
// The steps are inlined into the cloned solvers (VELLUM_INLINE_LAMBDA), so the registers and
// the arithmetic are those of one loop body.
namespace {

typedef double v4 __attribute__((vector_size(32)));
typedef float v8 __attribute__((vector_size(32)));
typedef float v4f __attribute__((vector_size(16)));

VELLUM_INLINE_LAMBDA inline v4 load4(const double* p) { v4 r; std::memcpy(&r, p, sizeof r); return r; }

// The dominant point of each of 4 lanes (the largest weight, the first on ties) and its weight.
VELLUM_INLINE_LAMBDA inline void dominantPoints(const double* w, int n, int S, int k0, v4& wmax, v4& dom) {
  wmax = load4(w + k0);
  dom = v4{0, 0, 0, 0};
  for (int i = 1; i < n; ++i) {
    const v4 wi = load4(w + static_cast<size_t>(i) * S + k0);
    const v4 iv = {double(i), double(i), double(i), double(i)};
    dom = wi > wmax ? iv : dom;  // branch-free arg-max
    wmax = wi > wmax ? wi : wmax;
  }
}

// Per lane: the dominant point's source (x) and target (y), the origin of the moments.
template <class V>
struct Frame {
  V xm0, xm1, xm2, ym0, ym1, ym2;
};

// Weighted moments of the points about the lane's frame: the weight sum, the centroids
// (xh, yh), A = sum w q q^T and B = sum w q^T p (row-major) of the centred offsets.
template <class V>
struct Moments {
  V W, xh0, xh1, xh2, yh0, yh1, yh2;
  Sym3<V> a;
  V b[9];
};

VELLUM_INLINE_LAMBDA inline Frame<v4> frameOf(const PointData& p, const v4& dom) {
  Frame<v4> f;
  for (int l = 0; l < 4; ++l) {
    const size_t m = static_cast<size_t>(dom[l]);
    f.xm0[l] = p.sx[m]; f.xm1[l] = p.sy[m]; f.xm2[l] = p.sz[m];
    f.ym0[l] = p.tx[m]; f.ym1[l] = p.ty[m]; f.ym2[l] = p.tz[m];
  }
  return f;
}

// Double precision, two passes: the centroids relative to the dominant point, then A and B
// about them.
VELLUM_INLINE_LAMBDA inline void accumulateMoments4(const PointData& p, const double* w, int S, int k0,
                                                    const Frame<v4>& f, Moments<v4>& m) {
  const int n = p.count;
  const v4 z = {0, 0, 0, 0};
  m.W = m.xh0 = m.xh1 = m.xh2 = m.yh0 = m.yh1 = m.yh2 = z;
  for (int i = 0; i < n; ++i) {
    const size_t si = static_cast<size_t>(i);
    const v4 wi = load4(w + si * S + k0);
    m.W += wi;
    m.xh0 += wi * (p.sx[si] - f.xm0); m.xh1 += wi * (p.sy[si] - f.xm1); m.xh2 += wi * (p.sz[si] - f.xm2);
    m.yh0 += wi * (p.tx[si] - f.ym0); m.yh1 += wi * (p.ty[si] - f.ym1); m.yh2 += wi * (p.tz[si] - f.ym2);
  }
  const v4 invW = 1.0 / m.W;
  m.xh0 *= invW; m.xh1 *= invW; m.xh2 *= invW; m.yh0 *= invW; m.yh1 *= invW; m.yh2 *= invW;
  Sym3<v4>& a = m.a;
  a = {z, z, z, z, z, z};
  for (int t = 0; t < 9; ++t) m.b[t] = z;
  for (int i = 0; i < n; ++i) {
    const size_t si = static_cast<size_t>(i);
    const v4 wi = load4(w + si * S + k0);
    const v4 q0 = (p.tx[si] - f.ym0) - m.yh0, q1 = (p.ty[si] - f.ym1) - m.yh1, q2 = (p.tz[si] - f.ym2) - m.yh2;
    const v4 p0 = (p.sx[si] - f.xm0) - m.xh0, p1 = (p.sy[si] - f.xm1) - m.xh1, p2 = (p.sz[si] - f.xm2) - m.xh2;
    const v4 wq0 = wi * q0, wq1 = wi * q1, wq2 = wi * q2;
    a.a00 += wq0 * q0; a.a01 += wq0 * q1; a.a02 += wq0 * q2; a.a11 += wq1 * q1; a.a12 += wq1 * q2; a.a22 += wq2 * q2;
    m.b[0] += wq0 * p0; m.b[1] += wq0 * p1; m.b[2] += wq0 * p2;
    m.b[3] += wq1 * p0; m.b[4] += wq1 * p1; m.b[5] += wq1 * p2;
    m.b[6] += wq2 * p0; m.b[7] += wq2 * p1; m.b[8] += wq2 * p2;
  }
}

// M per lane from the moments (in m.b on return): the regularised affine solution
// (see mls.hpp), or the nearest rotation (similarity: scaled) for the constrained methods.
VELLUM_INLINE_LAMBDA inline void solveLanes4(Moments<v4>& m, double eps, bool constrained, bool similarity) {
  Sym3<v4>& a = m.a;
  const v4 tr = a.a00 + a.a11 + a.a22;
  const v4 mean = tr / 3.0;
  const v4 det = a.a00 * (a.a11 * a.a22 - a.a12 * a.a12) - a.a01 * (a.a01 * a.a22 - a.a12 * a.a02) +
                 a.a02 * (a.a01 * a.a12 - a.a11 * a.a02);
  v4 lam;
  for (int l = 0; l < 4; ++l) {
    if (tr[l] > 0) {
      const double c = std::max(det[l] / (mean[l] * mean[l] * mean[l]), 0.0);
      const double r = eps / (eps + c);
      lam[l] = eps * r * r * mean[l];
    } else {
      lam[l] = 1.0;  // no spread at all: M = I (pure translation)
      a.a00[l] = a.a11[l] = a.a22[l] = 0;
      a.a01[l] = a.a02[l] = a.a12[l] = 0;
    }
  }
  if (!constrained) {
    affineSolution(shiftedInverse<v4>(a, lam), lam, m.b);
    return;
  }
  for (int l = 0; l < 4; ++l) {
    double ml[9];
    for (int t = 0; t < 9; ++t) ml[t] = m.b[t][l];
    constrainToRotation(ml, tr[l], similarity);
    for (int t = 0; t < 9; ++t) m.b[t][l] = ml[t];
  }
}

// u = (v - y*) M + x* per lane, where * is the weighted centroid; a node on a point takes
// that point's source exactly.
VELLUM_INLINE_LAMBDA inline void applyLanes4(const PointData& p, const Frame<v4>& f, const Moments<v4>& m,
                                             const v4 (&v)[3], const int* hit, int lanes, double* u) {
  const Vec3 sc = p.sourceCentre;
  const v4* M = m.b;
  const v4 d0 = (v[0] - f.ym0) - m.yh0, d1 = (v[1] - f.ym1) - m.yh1, d2 = (v[2] - f.ym2) - m.yh2;
  const v4 u0 = d0 * M[0] + d1 * M[3] + d2 * M[6] + (f.xm0 + m.xh0) + sc.x;
  const v4 u1 = d0 * M[1] + d1 * M[4] + d2 * M[7] + (f.xm1 + m.xh1) + sc.y;
  const v4 u2 = d0 * M[2] + d1 * M[5] + d2 * M[8] + (f.xm2 + m.xh2) + sc.z;
  for (int l = 0; l < lanes; ++l) {
    double* out = u + 3 * l;
    if (hit[l] >= 0) {
      const Vec3& x = p.sourceMm[static_cast<size_t>(hit[l])];
      out[0] = x.x; out[1] = x.y; out[2] = x.z;
    } else {
      out[0] = u0[l]; out[1] = u1[l]; out[2] = u2[l];
    }
  }
}

// 8 doubles -> 8 floats (stride_ is a multiple of 4).
VELLUM_INLINE_LAMBDA inline v8 load8(const double* p) {
  const v4f a = __builtin_convertvector(load4(p), v4f), b = __builtin_convertvector(load4(p + 4), v4f);
  return __builtin_shufflevector(a, b, 0, 1, 2, 3, 4, 5, 6, 7);
}

// The float lanes' frame: the dominant point in float, 1 / its weight (weights are divided by
// it, so no float overflow for high powers next to a point) and v - y_dominant (taken in double).
struct FloatFrame {
  float invMax[8], xm[3][8], ym[3][8], dv[3][8];
};

VELLUM_INLINE_LAMBDA inline void floatFrameOf(const PointData& p, const double* w, int S, int k0,
                                              const double* const (&v)[3], FloatFrame& f) {
  v4 wmaxA, wmaxB, domA, domB;
  dominantPoints(w, p.count, S, k0, wmaxA, domA);
  dominantPoints(w, p.count, S, k0 + 4, wmaxB, domB);
  for (int l = 0; l < 8; ++l) {
    const size_t m = static_cast<size_t>(l < 4 ? domA[l] : domB[l - 4]);
    f.invMax[l] = static_cast<float>(1.0 / (l < 4 ? wmaxA[l] : wmaxB[l - 4]));
    f.xm[0][l] = float(p.sx[m]); f.xm[1][l] = float(p.sy[m]); f.xm[2][l] = float(p.sz[m]);
    f.ym[0][l] = float(p.tx[m]); f.ym[1][l] = float(p.ty[m]); f.ym[2][l] = float(p.tz[m]);
    f.dv[0][l] = float(v[0][k0 + l] - p.tx[m]); f.dv[1][l] = float(v[1][k0 + l] - p.ty[m]);
    f.dv[2][l] = float(v[2][k0 + l] - p.tz[m]);
  }
}

VELLUM_INLINE_LAMBDA inline v8 lanes8(const float (&values)[8]) { v8 r; std::memcpy(&r, values, 32); return r; }

// Single precision, one pass: moments about the dominant point (its own offsets are exactly 0,
// so the huge weight next to a point cannot cancel), then centred: A = S_qq - W yh yh^T etc.
VELLUM_INLINE_LAMBDA inline void accumulateMoments8(const PointData& p, const double* w, int S, int k0,
                                                    const FloatFrame& f, Moments<v8>& m) {
  const v8 im = lanes8(f.invMax);
  const v8 xm0 = lanes8(f.xm[0]), xm1 = lanes8(f.xm[1]), xm2 = lanes8(f.xm[2]);
  const v8 ym0 = lanes8(f.ym[0]), ym1 = lanes8(f.ym[1]), ym2 = lanes8(f.ym[2]);
  const v8 z = {0, 0, 0, 0, 0, 0, 0, 0};
  m.W = m.xh0 = m.xh1 = m.xh2 = m.yh0 = m.yh1 = m.yh2 = z;
  Sym3<v8>& a = m.a;
  a = {z, z, z, z, z, z};
  for (int t = 0; t < 9; ++t) m.b[t] = z;
  for (int i = 0; i < p.count; ++i) {
    const size_t si = static_cast<size_t>(i);
    const v8 wi = load8(w + si * S + k0) * im;
    const v8 q0 = p.txf[si] - ym0, q1 = p.tyf[si] - ym1, q2 = p.tzf[si] - ym2;
    const v8 p0 = p.sxf[si] - xm0, p1 = p.syf[si] - xm1, p2 = p.szf[si] - xm2;
    const v8 wq0 = wi * q0, wq1 = wi * q1, wq2 = wi * q2;
    m.W += wi;
    m.yh0 += wq0; m.yh1 += wq1; m.yh2 += wq2;
    m.xh0 += wi * p0; m.xh1 += wi * p1; m.xh2 += wi * p2;
    a.a00 += wq0 * q0; a.a01 += wq0 * q1; a.a02 += wq0 * q2; a.a11 += wq1 * q1; a.a12 += wq1 * q2; a.a22 += wq2 * q2;
    m.b[0] += wq0 * p0; m.b[1] += wq0 * p1; m.b[2] += wq0 * p2;
    m.b[3] += wq1 * p0; m.b[4] += wq1 * p1; m.b[5] += wq1 * p2;
    m.b[6] += wq2 * p0; m.b[7] += wq2 * p1; m.b[8] += wq2 * p2;
  }
  const v8 invW = 1.0f / m.W, W = m.W;
  m.yh0 *= invW; m.yh1 *= invW; m.yh2 *= invW; m.xh0 *= invW; m.xh1 *= invW; m.xh2 *= invW;
  a.a00 -= W * m.yh0 * m.yh0; a.a01 -= W * m.yh0 * m.yh1; a.a02 -= W * m.yh0 * m.yh2;
  a.a11 -= W * m.yh1 * m.yh1; a.a12 -= W * m.yh1 * m.yh2; a.a22 -= W * m.yh2 * m.yh2;
  m.b[0] -= W * m.yh0 * m.xh0; m.b[1] -= W * m.yh0 * m.xh1; m.b[2] -= W * m.yh0 * m.xh2;
  m.b[3] -= W * m.yh1 * m.xh0; m.b[4] -= W * m.yh1 * m.xh1; m.b[5] -= W * m.yh1 * m.xh2;
  m.b[6] -= W * m.yh2 * m.xh0; m.b[7] -= W * m.yh2 * m.xh1; m.b[8] -= W * m.yh2 * m.xh2;
}

// The affine M per lane (in m.b on return). False when a lane needs double precision: A
// ill-conditioned (c < 1e-3, e.g. coplanar points), no spread, or a node on a point.
VELLUM_INLINE_LAMBDA inline bool solveLanes8(Moments<v8>& m, double eps, const int* hit) {
  const Sym3<v8>& a = m.a;
  const v8 tr = a.a00 + a.a11 + a.a22, mean = tr / 3.0f;
  const v8 det = a.a00 * (a.a11 * a.a22 - a.a12 * a.a12) - a.a01 * (a.a01 * a.a22 - a.a12 * a.a02) +
                 a.a02 * (a.a01 * a.a12 - a.a11 * a.a02);
  const v8 c = det / (mean * mean * mean);
  bool wellPosed = true;
  for (int l = 0; l < 8; ++l) wellPosed = wellPosed && c[l] > 1e-3f && tr[l] > 0 && hit[l] < 0;
  const v8 r = float(eps) / (float(eps) + c);
  const v8 lam = float(eps) * r * r * mean;
  affineSolution(shiftedInverse<v8>(a, lam), lam, m.b);
  return wellPosed;
}

// u = (v - y*) M + x* per lane, back in double around the dominant point.
VELLUM_INLINE_LAMBDA inline void applyLanes8(const PointData& p, const FloatFrame& f, const Moments<v8>& m,
                                             int lanes, double* u) {
  const Vec3 sc = p.sourceCentre;
  const v8* M = m.b;
  const v8 d0 = lanes8(f.dv[0]) - m.yh0, d1 = lanes8(f.dv[1]) - m.yh1, d2 = lanes8(f.dv[2]) - m.yh2;
  const v8 u0 = d0 * M[0] + d1 * M[3] + d2 * M[6] + m.xh0, u1 = d0 * M[1] + d1 * M[4] + d2 * M[7] + m.xh1,
           u2 = d0 * M[2] + d1 * M[5] + d2 * M[8] + m.xh2;
  for (int l = 0; l < lanes; ++l) {
    double* out = u + 3 * l;
    out[0] = double(u0[l]) + double(f.xm[0][l]) + sc.x;
    out[1] = double(u1[l]) + double(f.xm[1][l]) + sc.y;
    out[2] = double(u2[l]) + double(f.xm[2][l]) + sc.z;
  }
}

}  // namespace

// The no-attribute path, register-blocked: kLanes nodes at a time with every accumulator in
// a vector register (GCC vector extension; AVX2 in the haswell clone, 2 x SSE2 otherwise).
VELLUM_SIMD_CLONES void RowEvaluator::solveBlocked(const double* w, double* u, int kBegin, int kEnd) {
  const int L = len_, S = stride_;
  const double* vx = arr(kVx); const double* vy = arr(kVy); const double* vz = arr(kVz);
  const bool constrained = params_.method != MlsMethod::Affine;
  const bool similarity = params_.method == MlsMethod::Similarity;
  for (int k0 = kBegin; k0 < std::min(kEnd, L); k0 += kLanes) {
    v4 wmax, dom;
    dominantPoints(w, p_.count, S, k0, wmax, dom);
    const Frame<v4> frame = frameOf(p_, dom);
    Moments<v4> m;
    accumulateMoments4(p_, w, S, k0, frame, m);
    solveLanes4(m, params_.regularisation, constrained, similarity);
    const v4 v[3] = {load4(vx + k0), load4(vy + k0), load4(vz + k0)};
    applyLanes4(p_, frame, m, v, hit_.data() + k0, std::min(kLanes, L - k0), u + 3 * k0);
  }
}

// Single-precision variant for grids (8 nodes per AVX2 register). Lanes that are not
// well-posed in float (see solveLanes8) are redone in double precision.
VELLUM_SIMD_CLONES void RowEvaluator::solveBlockedFloat(const double* w, double* u) {
  constexpr int kF = 8;
  const int L = len_, S = stride_;
  const double* const v[3] = {arr(kVx), arr(kVy), arr(kVz)};
  for (int k0 = 0; k0 < L; k0 += kF) {
    if (k0 + kF > S) { solveBlocked(w, u, k0, L); break; }  // tail shorter than 8 lanes
    FloatFrame frame;
    floatFrameOf(p_, w, S, k0, v, frame);
    Moments<v8> m;
    accumulateMoments8(p_, w, S, k0, frame, m);
    const bool wellPosed = solveLanes8(m, params_.regularisation, hit_.data() + k0);
    applyLanes8(p_, frame, m, std::min(kF, L - k0), u + 3 * k0);
    if (!wellPosed) solveBlocked(w, u, k0, std::min(k0 + kF, L));
  }
}

}  // namespace vellum::deformation::detail
