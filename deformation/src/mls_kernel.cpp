#include "mls_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "vellum/core/error.hpp"
#include "vellum/core/rigid_fit.hpp"

// AVX2/FMA clone of the hot loops with run-time dispatch (falls back to baseline x86-64).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define VELLUM_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define VELLUM_SIMD_CLONES
#endif
// Lambdas inside the cloned functions must be inlined: called out of line (as at -O0) they
// are compiled for the baseline target, and passing 32-byte vectors between an AVX2 caller
// and a baseline callee mismatches the ABI (a stack overflow under AddressSanitizer).
#define VELLUM_INLINE_LAMBDA __attribute__((always_inline))

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

// The no-attribute path, register-blocked: kLanes nodes at a time with every accumulator in
// a vector register (GCC vector extension; AVX2 in the haswell clone, 2 x SSE2 otherwise).
VELLUM_SIMD_CLONES void RowEvaluator::solveBlocked(const double* w, double* u, int kBegin, int kEnd) {
  typedef double v4 __attribute__((vector_size(32)));
  const int n = p_.count, L = len_, S = stride_;
  const double* vx = arr(kVx); const double* vy = arr(kVy); const double* vz = arr(kVz);
  const double eps = params_.regularisation;
  const bool constrained = params_.method != MlsMethod::Affine;
  const bool similarity = params_.method == MlsMethod::Similarity;
  const Vec3 sc = p_.sourceCentre;
  auto load = [](const double* p) VELLUM_INLINE_LAMBDA { v4 r; std::memcpy(&r, p, sizeof r); return r; };
  for (int k0 = kBegin; k0 < std::min(kEnd, L); k0 += kLanes) {
    // Dominant point per lane.
    v4 wmax = load(w + k0);
    v4 domv = {0, 0, 0, 0};
    for (int i = 1; i < n; ++i) {
      const v4 wi = load(w + static_cast<size_t>(i) * S + k0);
      const v4 iv = {double(i), double(i), double(i), double(i)};
      domv = wi > wmax ? iv : domv;  // branch-free arg-max
      wmax = wi > wmax ? wi : wmax;
    }
    v4 xm0, xm1, xm2, ym0, ym1, ym2;
    for (int l = 0; l < kLanes; ++l) {
      const size_t m = static_cast<size_t>(domv[l]);
      xm0[l] = p_.sx[m]; xm1[l] = p_.sy[m]; xm2[l] = p_.sz[m];
      ym0[l] = p_.tx[m]; ym1[l] = p_.ty[m]; ym2[l] = p_.tz[m];
    }
    // Pass 1: centroids relative to the dominant point.
    v4 W = {0, 0, 0, 0}, xh0 = W, xh1 = W, xh2 = W, yh0 = W, yh1 = W, yh2 = W;
    for (int i = 0; i < n; ++i) {
      const size_t si = static_cast<size_t>(i);
      const v4 wi = load(w + si * S + k0);
      W += wi;
      xh0 += wi * (p_.sx[si] - xm0); xh1 += wi * (p_.sy[si] - xm1); xh2 += wi * (p_.sz[si] - xm2);
      yh0 += wi * (p_.tx[si] - ym0); yh1 += wi * (p_.ty[si] - ym1); yh2 += wi * (p_.tz[si] - ym2);
    }
    const v4 invW = 1.0 / W;
    xh0 *= invW; xh1 *= invW; xh2 *= invW; yh0 *= invW; yh1 *= invW; yh2 *= invW;
    // Pass 2: A and B.
    const v4 z = {0, 0, 0, 0};
    v4 a00 = z, a01 = z, a02 = z, a11 = z, a12 = z, a22 = z;
    v4 b00 = z, b01 = z, b02 = z, b10 = z, b11 = z, b12 = z, b20 = z, b21 = z, b22 = z;
    for (int i = 0; i < n; ++i) {
      const size_t si = static_cast<size_t>(i);
      const v4 wi = load(w + si * S + k0);
      const v4 q0 = (p_.tx[si] - ym0) - yh0, q1 = (p_.ty[si] - ym1) - yh1, q2 = (p_.tz[si] - ym2) - yh2;
      const v4 p0 = (p_.sx[si] - xm0) - xh0, p1 = (p_.sy[si] - xm1) - xh1, p2 = (p_.sz[si] - xm2) - xh2;
      const v4 wq0 = wi * q0, wq1 = wi * q1, wq2 = wi * q2;
      a00 += wq0 * q0; a01 += wq0 * q1; a02 += wq0 * q2; a11 += wq1 * q1; a12 += wq1 * q2; a22 += wq2 * q2;
      b00 += wq0 * p0; b01 += wq0 * p1; b02 += wq0 * p2;
      b10 += wq1 * p0; b11 += wq1 * p1; b12 += wq1 * p2;
      b20 += wq2 * p0; b21 += wq2 * p1; b22 += wq2 * p2;
    }
    // Regularised inverse of A (see mls.hpp), lane-wise.
    const v4 tr = a00 + a11 + a22;
    const v4 mean = tr / 3.0;
    const v4 det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) + a02 * (a01 * a12 - a11 * a02);
    v4 lam;
    for (int l = 0; l < kLanes; ++l) {
      if (tr[l] > 0) {
        const double c = std::max(det[l] / (mean[l] * mean[l] * mean[l]), 0.0);
        const double r = eps / (eps + c);
        lam[l] = eps * r * r * mean[l];
      } else {
        lam[l] = 1.0;  // no spread at all: M = I (pure translation)
        a00[l] = a11[l] = a22[l] = 0;
        a01[l] = a02[l] = a12[l] = 0;
      }
    }
    v4 m[9] = {b00, b01, b02, b10, b11, b12, b20, b21, b22};
    if (!constrained) {
      affineSolution(shiftedInverse<v4>({a00, a01, a02, a11, a12, a22}, lam), lam, m);
    } else {
      for (int l = 0; l < kLanes; ++l) {
        double ml[9];
        for (int t = 0; t < 9; ++t) ml[t] = m[t][l];
        constrainToRotation(ml, tr[l], similarity);
        for (int t = 0; t < 9; ++t) m[t][l] = ml[t];
      }
    }
    const v4 d0 = (load(vx + k0) - ym0) - yh0, d1 = (load(vy + k0) - ym1) - yh1, d2 = (load(vz + k0) - ym2) - yh2;
    const v4 u0 = d0 * m[0] + d1 * m[3] + d2 * m[6] + (xm0 + xh0) + sc.x;
    const v4 u1 = d0 * m[1] + d1 * m[4] + d2 * m[7] + (xm1 + xh1) + sc.y;
    const v4 u2 = d0 * m[2] + d1 * m[5] + d2 * m[8] + (xm2 + xh2) + sc.z;
    const int lanes = std::min(kLanes, L - k0);
    for (int l = 0; l < lanes; ++l) {
      double* out = u + 3 * (k0 + l);
      const int h = hit_[static_cast<size_t>(k0 + l)];
      if (h >= 0) {
        const Vec3& x = p_.sourceMm[static_cast<size_t>(h)];
        out[0] = x.x; out[1] = x.y; out[2] = x.z;
      } else {
        out[0] = u0[l]; out[1] = u1[l]; out[2] = u2[l];
      }
    }
  }
}

// Single-precision variant for grids (8 nodes per AVX2 register). Weights are divided by the
// node's largest weight first (no float overflow for high powers next to a point). Lanes whose
// A is ill-conditioned (c < 1e-3, e.g. coplanar points) or that sit on a control point are
// redone in double precision, so the float path only ever handles well-posed solves.
VELLUM_SIMD_CLONES void RowEvaluator::solveBlockedFloat(const double* w, double* u) {
  typedef float v8 __attribute__((vector_size(32)));
  typedef double v4 __attribute__((vector_size(32)));
  constexpr int kF = 8;
  const int n = p_.count, L = len_, S = stride_;
  const double* vx = arr(kVx); const double* vy = arr(kVy); const double* vz = arr(kVz);
  const double eps = params_.regularisation;
  const Vec3 sc = p_.sourceCentre;
  auto load4 = [](const double* p) VELLUM_INLINE_LAMBDA { v4 r; std::memcpy(&r, p, sizeof r); return r; };
  typedef float v4f __attribute__((vector_size(16)));
  auto load8 = [&](const double* p) VELLUM_INLINE_LAMBDA {  // 8 doubles -> 8 floats (stride_ is a multiple of 4)
    const v4f a = __builtin_convertvector(load4(p), v4f), b = __builtin_convertvector(load4(p + 4), v4f);
    return __builtin_shufflevector(a, b, 0, 1, 2, 3, 4, 5, 6, 7);
  };
  for (int k0 = 0; k0 < L; k0 += kF) {
    if (k0 + kF > S) { solveBlocked(w, u, k0, L); break; }  // tail shorter than 8 lanes
    // Dominant point and the largest weight per lane (double).
    v4 wmaxA = load4(w + k0), wmaxB = load4(w + k0 + 4);
    v4 domA = {0, 0, 0, 0}, domB = domA;
    for (int i = 1; i < n; ++i) {
      const v4 a = load4(w + static_cast<size_t>(i) * S + k0), b = load4(w + static_cast<size_t>(i) * S + k0 + 4);
      const v4 iv = {double(i), double(i), double(i), double(i)};
      domA = a > wmaxA ? iv : domA; wmaxA = a > wmaxA ? a : wmaxA;
      domB = b > wmaxB ? iv : domB; wmaxB = b > wmaxB ? b : wmaxB;
    }
    float invMax[kF], xmf[3][kF], ymf[3][kF], dvf[3][kF];
    for (int l = 0; l < kF; ++l) {
      const size_t m = static_cast<size_t>(l < 4 ? domA[l] : domB[l - 4]);
      invMax[l] = static_cast<float>(1.0 / (l < 4 ? wmaxA[l] : wmaxB[l - 4]));
      xmf[0][l] = float(p_.sx[m]); xmf[1][l] = float(p_.sy[m]); xmf[2][l] = float(p_.sz[m]);
      ymf[0][l] = float(p_.tx[m]); ymf[1][l] = float(p_.ty[m]); ymf[2][l] = float(p_.tz[m]);
      dvf[0][l] = float(vx[k0 + l] - p_.tx[m]); dvf[1][l] = float(vy[k0 + l] - p_.ty[m]);
      dvf[2][l] = float(vz[k0 + l] - p_.tz[m]);
    }
    v8 im, xm0, xm1, xm2, ym0, ym1, ym2, dv0, dv1, dv2;
    std::memcpy(&im, invMax, 32);
    std::memcpy(&xm0, xmf[0], 32); std::memcpy(&xm1, xmf[1], 32); std::memcpy(&xm2, xmf[2], 32);
    std::memcpy(&ym0, ymf[0], 32); std::memcpy(&ym1, ymf[1], 32); std::memcpy(&ym2, ymf[2], 32);
    std::memcpy(&dv0, dvf[0], 32); std::memcpy(&dv1, dvf[1], 32); std::memcpy(&dv2, dvf[2], 32);
    const v8 z = {0, 0, 0, 0, 0, 0, 0, 0};
    v8 W = z, xh0 = z, xh1 = z, xh2 = z, yh0 = z, yh1 = z, yh2 = z;
    v8 a00 = z, a01 = z, a02 = z, a11 = z, a12 = z, a22 = z;
    v8 b00 = z, b01 = z, b02 = z, b10 = z, b11 = z, b12 = z, b20 = z, b21 = z, b22 = z;
    // One pass: moments about the dominant point (its own offsets are exactly 0, so the huge
    // weight next to a point cannot cancel), then centred: A = S_qq - W yh yh^T etc.
    for (int i = 0; i < n; ++i) {
      const size_t si = static_cast<size_t>(i);
      const v8 wi = load8(w + si * S + k0) * im;
      const v8 q0 = float(p_.tx[si]) - ym0, q1 = float(p_.ty[si]) - ym1, q2 = float(p_.tz[si]) - ym2;
      const v8 p0 = float(p_.sx[si]) - xm0, p1 = float(p_.sy[si]) - xm1, p2 = float(p_.sz[si]) - xm2;
      const v8 wq0 = wi * q0, wq1 = wi * q1, wq2 = wi * q2;
      W += wi;
      yh0 += wq0; yh1 += wq1; yh2 += wq2;
      xh0 += wi * p0; xh1 += wi * p1; xh2 += wi * p2;
      a00 += wq0 * q0; a01 += wq0 * q1; a02 += wq0 * q2; a11 += wq1 * q1; a12 += wq1 * q2; a22 += wq2 * q2;
      b00 += wq0 * p0; b01 += wq0 * p1; b02 += wq0 * p2;
      b10 += wq1 * p0; b11 += wq1 * p1; b12 += wq1 * p2;
      b20 += wq2 * p0; b21 += wq2 * p1; b22 += wq2 * p2;
    }
    const v8 invW = 1.0f / W;
    yh0 *= invW; yh1 *= invW; yh2 *= invW; xh0 *= invW; xh1 *= invW; xh2 *= invW;
    a00 -= W * yh0 * yh0; a01 -= W * yh0 * yh1; a02 -= W * yh0 * yh2;
    a11 -= W * yh1 * yh1; a12 -= W * yh1 * yh2; a22 -= W * yh2 * yh2;
    b00 -= W * yh0 * xh0; b01 -= W * yh0 * xh1; b02 -= W * yh0 * xh2;
    b10 -= W * yh1 * xh0; b11 -= W * yh1 * xh1; b12 -= W * yh1 * xh2;
    b20 -= W * yh2 * xh0; b21 -= W * yh2 * xh1; b22 -= W * yh2 * xh2;
    const v8 tr = a00 + a11 + a22, mean = tr / 3.0f;
    const v8 det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) + a02 * (a01 * a12 - a11 * a02);
    const v8 c = det / (mean * mean * mean);
    bool redo = false;
    for (int l = 0; l < kF; ++l)
      redo = redo || !(c[l] > 1e-3f) || !(tr[l] > 0) || hit_[static_cast<size_t>(k0 + l)] >= 0;
    const v8 r = float(eps) / (float(eps) + c);
    const v8 lam = float(eps) * r * r * mean;
    v8 m[9] = {b00, b01, b02, b10, b11, b12, b20, b21, b22};
    affineSolution(shiftedInverse<v8>({a00, a01, a02, a11, a12, a22}, lam), lam, m);
    const v8 d0 = dv0 - yh0, d1 = dv1 - yh1, d2 = dv2 - yh2;
    const v8 u0 = d0 * m[0] + d1 * m[3] + d2 * m[6] + xh0, u1 = d0 * m[1] + d1 * m[4] + d2 * m[7] + xh1,
             u2 = d0 * m[2] + d1 * m[5] + d2 * m[8] + xh2;
    const int lanes = std::min(kF, L - k0);
    for (int l = 0; l < lanes; ++l) {
      double* out = u + 3 * (k0 + l);
      out[0] = double(u0[l]) + double(xmf[0][l]) + sc.x;
      out[1] = double(u1[l]) + double(xmf[1][l]) + sc.y;
      out[2] = double(u2[l]) + double(xmf[2][l]) + sc.z;
    }
    if (redo) solveBlocked(w, u, k0, std::min(k0 + kF, L));
  }
}

}  // namespace vellum::deformation::detail
