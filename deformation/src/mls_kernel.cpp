#include "mls_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "vellum/core/error.hpp"
#include "vellum/core/rigid_fit.hpp"
#include "vellum/core/simd_clones.hpp"
#include "vellum/deformation/deform_params.hpp"

namespace vellum::deformation::detail {
namespace {

// Below this distance (mm) v counts as sitting on y_i: u = x_i exactly.
constexpr double kHitDist2 = 1e-18;
// Weights are computed from max(d^2, this): 1e-6 mm keeps (1/d^2)^3 within float range.
constexpr double kWeightDist2 = 1e-12;
// Float lanes whose normalised conditioning c is below this are redone in double precision.
constexpr float kFloatMinConditioning = 1e-3f;

// Lane types (GCC vector extension; AVX2 registers in the haswell clone, 2 x SSE2 otherwise).
typedef double v4 __attribute__((vector_size(32)));
typedef float v8 __attribute__((vector_size(32)));
typedef float v4f __attribute__((vector_size(16)));
template <class V>
using Scalar = std::remove_cv_t<std::remove_reference_t<decltype(V{}[0])>>;
template <class V>
constexpr int kWidth = static_cast<int>(sizeof(V) / sizeof(Scalar<V>));

VELLUM_INLINE_LAMBDA inline v4 load4(const double* p) { v4 r; std::memcpy(&r, p, sizeof r); return r; }
VELLUM_INLINE_LAMBDA inline void store4(double* p, v4 v) { std::memcpy(p, &v, sizeof v); }

// kWidth<V> doubles from p in the lane type (8 doubles -> 8 floats; the stride is a multiple of 4).
template <class V>
VELLUM_INLINE_LAMBDA inline V loadLanes(const double* p) {
  if constexpr (std::is_same_v<V, v4>) {
    return load4(p);
  } else {
    const v4f a = __builtin_convertvector(load4(p), v4f), b = __builtin_convertvector(load4(p + 4), v4f);
    return __builtin_shufflevector(a, b, 0, 1, 2, 3, 4, 5, 6, 7);
  }
}

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

// (A + lam I)^-1 by cofactors.
template <class V>
VELLUM_INLINE_LAMBDA inline Sym3<V> shiftedInverse(Sym3<V> a, V lam) {
  a.a00 += lam; a.a11 += lam; a.a22 += lam;
  const V c00 = a.a11 * a.a22 - a.a12 * a.a12, c01 = a.a02 * a.a12 - a.a01 * a.a22,
          c02 = a.a01 * a.a12 - a.a02 * a.a11, c11 = a.a00 * a.a22 - a.a02 * a.a02,
          c12 = a.a01 * a.a02 - a.a00 * a.a12, c22 = a.a00 * a.a11 - a.a01 * a.a01;
  const V inv = 1 / (a.a00 * c00 + a.a01 * c01 + a.a02 * c02);
  return {c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, c22 * inv};
}

// The affine solution M = (A + lam I)^-1 (B + lam I) for a row-major B, in place.
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

// ---- The lane solver ----------------------------------------------------------------------
// One block of kWidth<V> nodes (4 doubles or 8 floats per AVX2 register) goes through: find each
// lane's dominant point (frameOf), accumulate the weighted moments about it, solve for M
// (solveLanes), apply M to the node (applyLanes). Every path (double and float grids, picking,
// attributes) runs these steps; they are inlined into the cloned solvers (VELLUM_INLINE_LAMBDA),
// so the registers and the arithmetic are those of one loop body.

// The point coordinates in the lane precision (float lanes read them rounded once per set).
template <class T>
struct Coords {
  const T* s[3];
  const T* t[3];
};
inline Coords<double> coordsOf(const PointData& p, double) {
  return {{p.sx.data(), p.sy.data(), p.sz.data()}, {p.tx.data(), p.ty.data(), p.tz.data()}};
}
inline Coords<float> coordsOf(const PointData& p, float) {
  return {{p.sxf.data(), p.syf.data(), p.szf.data()}, {p.txf.data(), p.tyf.data(), p.tzf.data()}};
}

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

// Per lane: the dominant point's source (xm) and target (ym), the origin of the moments, so that
// when one weight dwarfs the others (v next to y_m, high power n) the tiny q_m = y_m - y^ comes
// from small differences instead of cancelling to noise. dv = v - ym (taken in double);
// invMax = 1 / the dominant weight (float lanes divide by it: no overflow for high powers).
template <class V>
struct Frame {
  V xm[3], ym[3], dv[3], invMax;
};

template <class V>
VELLUM_INLINE_LAMBDA inline Frame<V> frameOf(const PointData& p, const double* w, int S, int k0,
                                             const double* const (&v)[3]) {
  using T = Scalar<V>;
  const Coords<double> x = coordsOf(p, 0.0);
  Frame<V> f;
  for (int h = 0; h < kWidth<V>; h += 4) {
    v4 wmax, dom;
    dominantPoints(w, p.count, S, k0 + h, wmax, dom);
    for (int l = 0; l < 4; ++l) {
      const size_t m = static_cast<size_t>(dom[l]);
      const int k = k0 + h + l;
      f.invMax[h + l] = static_cast<T>(1.0 / wmax[l]);
      for (int c = 0; c < 3; ++c) {
        f.xm[c][h + l] = static_cast<T>(x.s[c][m]);
        f.ym[c][h + l] = static_cast<T>(x.t[c][m]);
        f.dv[c][h + l] = static_cast<T>(v[c][k] - x.t[c][m]);
      }
    }
  }
  return f;
}

// Weighted moments of the points about the lane's frame: the weight sum, the centroids
// (xh, yh), A = sum w q q^T and B = sum w q^T p (row-major) of the centred offsets.
template <class V>
struct Moments {
  V W, xh[3], yh[3];
  Sym3<V> a;
  V b[9];
};

// The attribute extension: centroids zh and C = sum w q^T (z - zh) (row r, attribute a: c[4r + a]).
struct AttributeMoments {
  v4 zh[PointAttributes::kCount], c[3 * PointAttributes::kCount];
};

template <class V>
VELLUM_INLINE_LAMBDA inline void clearMoments(Moments<V>& m) {
  const V z = V{};
  m.W = z;
  for (int c = 0; c < 3; ++c) m.xh[c] = m.yh[c] = z;
  m.a = {z, z, z, z, z, z};
  for (int t = 0; t < 9; ++t) m.b[t] = z;
}

// A += w q q^T, B += w q^T p for one point (wq = w q).
template <class V>
VELLUM_INLINE_LAMBDA inline void addProducts(Moments<V>& m, const V (&wq)[3], const V (&q)[3], const V (&p)[3]) {
  Sym3<V>& a = m.a;
  a.a00 += wq[0] * q[0]; a.a01 += wq[0] * q[1]; a.a02 += wq[0] * q[2];
  a.a11 += wq[1] * q[1]; a.a12 += wq[1] * q[2]; a.a22 += wq[2] * q[2];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.b[3 * r + c] += wq[r] * p[c];
}

// Double lanes, two passes: the centroids relative to the frame, then A and B (and C) about them.
template <bool kAttr>
VELLUM_INLINE_LAMBDA inline void accumulateCentred(const PointData& p, const double* w, int S, int k0,
                                                   const Frame<v4>& f, Moments<v4>& m, AttributeMoments& at) {
  constexpr int kA = PointAttributes::kCount;
  const Coords<double> x = coordsOf(p, 0.0);
  clearMoments(m);
  if constexpr (kAttr)
    for (int t = 0; t < kA; ++t) at.zh[t] = at.c[t] = at.c[kA + t] = at.c[2 * kA + t] = v4{};
  for (int i = 0; i < p.count; ++i) {
    const size_t si = static_cast<size_t>(i);
    const v4 wi = load4(w + si * S + k0);
    m.W += wi;
    for (int c = 0; c < 3; ++c) m.xh[c] += wi * (x.s[c][si] - f.xm[c]);
    for (int c = 0; c < 3; ++c) m.yh[c] += wi * (x.t[c][si] - f.ym[c]);
    if constexpr (kAttr)
      for (int a = 0; a < kA; ++a) at.zh[a] += wi * p.z[a][si];
  }
  const v4 invW = 1.0 / m.W;
  for (int c = 0; c < 3; ++c) { m.xh[c] *= invW; m.yh[c] *= invW; }
  if constexpr (kAttr)
    for (int a = 0; a < kA; ++a) at.zh[a] /= m.W;
  for (int i = 0; i < p.count; ++i) {
    const size_t si = static_cast<size_t>(i);
    const v4 wi = load4(w + si * S + k0);
    v4 q[3], d[3];
    for (int c = 0; c < 3; ++c) q[c] = (x.t[c][si] - f.ym[c]) - m.yh[c];
    for (int c = 0; c < 3; ++c) d[c] = (x.s[c][si] - f.xm[c]) - m.xh[c];
    const v4 wq[3] = {wi * q[0], wi * q[1], wi * q[2]};
    addProducts(m, wq, q, d);
    if constexpr (kAttr)
      for (int a = 0; a < kA; ++a) {
        const v4 wr = wi * (p.z[a][si] - at.zh[a]);
        for (int r = 0; r < 3; ++r) at.c[r * kA + a] += wr * q[r];
      }
  }
}

// Float lanes, one pass: moments about the dominant point (its own offsets are exactly 0, so the
// huge weight next to a point cannot cancel), then centred: A = S_qq - W yh yh^T etc.
VELLUM_INLINE_LAMBDA inline void accumulateAboutFrame(const PointData& p, const double* w, int S, int k0,
                                                      const Frame<v8>& f, Moments<v8>& m) {
  const Coords<float> x = coordsOf(p, 0.0f);
  clearMoments(m);
  for (int i = 0; i < p.count; ++i) {
    const size_t si = static_cast<size_t>(i);
    const v8 wi = loadLanes<v8>(w + si * S + k0) * f.invMax;
    v8 q[3], d[3];
    for (int c = 0; c < 3; ++c) q[c] = x.t[c][si] - f.ym[c];
    for (int c = 0; c < 3; ++c) d[c] = x.s[c][si] - f.xm[c];
    const v8 wq[3] = {wi * q[0], wi * q[1], wi * q[2]};
    m.W += wi;
    for (int c = 0; c < 3; ++c) { m.yh[c] += wq[c]; m.xh[c] += wi * d[c]; }
    addProducts(m, wq, q, d);
  }
  const v8 invW = 1.0f / m.W, W = m.W;
  for (int c = 0; c < 3; ++c) { m.yh[c] *= invW; m.xh[c] *= invW; }
  const v8 wy[3] = {W * m.yh[0], W * m.yh[1], W * m.yh[2]};
  Sym3<v8>& a = m.a;
  a.a00 -= wy[0] * m.yh[0]; a.a01 -= wy[0] * m.yh[1]; a.a02 -= wy[0] * m.yh[2];
  a.a11 -= wy[1] * m.yh[1]; a.a12 -= wy[1] * m.yh[2]; a.a22 -= wy[2] * m.yh[2];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.b[3 * r + c] -= wy[r] * m.xh[c];
}

// What solveLanes leaves besides M: (A + lam I)^-1 for the attributes, and per lane trace(A)
// and the normalised conditioning c, for the float lanes' well-posedness test.
template <class V>
struct Solution {
  Sym3<V> inverse;
  V trace, conditioning;
};

// M per lane from the moments (in m.b on return): the regularised affine solution (see
// mls.hpp), or the nearest rotation (similarity: scaled) for the constrained methods. A lane
// without spread (trace(A) = 0) gets M = I: a pure translation.
template <class V>
VELLUM_INLINE_LAMBDA inline Solution<V> solveLanes(Moments<V>& m, double eps, MlsMethod method) {
  using T = Scalar<V>;
  const V zero = V{}, one = zero + 1;
  Sym3<V>& a = m.a;
  const V tr = a.a00 + a.a11 + a.a22, mean = tr / T(3);
  const V det = a.a00 * (a.a11 * a.a22 - a.a12 * a.a12) - a.a01 * (a.a01 * a.a22 - a.a12 * a.a02) +
                a.a02 * (a.a01 * a.a12 - a.a11 * a.a02);
  V c = det / (mean * mean * mean);
  c = c < zero ? zero : c;
  const V r = T(eps) / (T(eps) + c);
  const auto spread = tr > zero;
  const V lam = spread ? T(eps) * r * r * mean : one;
  a = {spread ? a.a00 : zero, spread ? a.a01 : zero, spread ? a.a02 : zero,
       spread ? a.a11 : zero, spread ? a.a12 : zero, spread ? a.a22 : zero};
  const Sym3<V> inverse = shiftedInverse<V>(a, lam);
  if (method == MlsMethod::Affine) {
    affineSolution(inverse, lam, m.b);
  } else {
    for (int l = 0; l < kWidth<V>; ++l) {
      double ml[9];
      for (int t = 0; t < 9; ++t) ml[t] = m.b[t][l];
      constrainToRotation(ml, tr[l], method == MlsMethod::Similarity);
      for (int t = 0; t < 9; ++t) m.b[t][l] = static_cast<T>(ml[t]);
    }
  }
  return {inverse, tr, c};
}

// True when every lane's float solution stands: A well-conditioned (not e.g. coplanar points),
// some spread, and no node on a point.
VELLUM_INLINE_LAMBDA inline bool wellPosedInFloat(const Solution<v8>& s, const int* hit) {
  bool ok = true;
  for (int l = 0; l < 8; ++l)
    ok = ok && s.conditioning[l] > kFloatMinConditioning && s.trace[l] > 0 && hit[l] < 0;
  return ok;
}

// u = (v - y*) M + x* per lane, where * is the weighted centroid; a node on a point takes that
// point's source exactly. Float lanes add back the frame in double (their rounding stays relative
// to the dominant point); double lanes add frame and centroid first, as the attribute path did.
template <class V>
VELLUM_INLINE_LAMBDA inline void applyLanes(const PointData& p, const Frame<V>& f, const Moments<V>& m,
                                            const int* hit, int lanes, double* u) {
  const double sc[3] = {p.sourceCentre.x, p.sourceCentre.y, p.sourceCentre.z};
  const V* M = m.b;
  const V d0 = f.dv[0] - m.yh[0], d1 = f.dv[1] - m.yh[1], d2 = f.dv[2] - m.yh[2];
  for (int c = 0; c < 3; ++c) {
    constexpr bool kDouble = std::is_same_v<V, v4>;
    const V uc = d0 * M[c] + d1 * M[3 + c] + d2 * M[6 + c] + (kDouble ? f.xm[c] + m.xh[c] : m.xh[c]);
    for (int l = 0; l < lanes; ++l) {
      const double frame = kDouble ? 0.0 : double(f.xm[c][l]);
      u[3 * l + c] = kDouble ? uc[l] + sc[c] : double(uc[l]) + frame + sc[c];
    }
  }
  for (int l = 0; l < lanes; ++l)
    if (hit[l] >= 0) {
      const Vec3& x = p.sourceMm[static_cast<size_t>(hit[l])];
      u[3 * l] = x.x; u[3 * l + 1] = x.y; u[3 * l + 2] = x.z;
    }
}

// Attributes per lane: f = (v - y*) (A + lam I)^-1 C + z*; a node on a point takes its values.
VELLUM_INLINE_LAMBDA inline void applyAttributes(const PointData& p, const Frame<v4>& f, const Moments<v4>& m,
                                                 const AttributeMoments& at, const Sym3<v4>& i,
                                                 const int* hit, int lanes, double* attr) {
  constexpr int kA = PointAttributes::kCount;
  const v4 d0 = f.dv[0] - m.yh[0], d1 = f.dv[1] - m.yh[1], d2 = f.dv[2] - m.yh[2];
  const v4 g0 = d0 * i.a00 + d1 * i.a01 + d2 * i.a02;
  const v4 g1 = d0 * i.a01 + d1 * i.a11 + d2 * i.a12;
  const v4 g2 = d0 * i.a02 + d1 * i.a12 + d2 * i.a22;
  for (int a = 0; a < kA; ++a) {
    const v4 fa = g0 * at.c[a] + g1 * at.c[kA + a] + g2 * at.c[2 * kA + a] + at.zh[a];
    for (int l = 0; l < lanes; ++l)
      attr[kA * l + a] = hit[l] >= 0 ? p.zi[static_cast<size_t>(hit[l])][static_cast<size_t>(a)] : fa[l];
  }
}

// The double-lane loop over nodes [kBegin, kEnd), with or without attributes.
template <bool kAttr>
VELLUM_INLINE_LAMBDA inline void solveDoubleLanes(const PointData& p, const MlsParams& params, const double* w,
                                                  int S, const double* const (&v)[3], const int* hit,
                                                  int kBegin, int kEnd, double* u, double* attr) {
  for (int k0 = kBegin; k0 < kEnd; k0 += 4) {
    const Frame<v4> f = frameOf<v4>(p, w, S, k0, v);
    Moments<v4> m;
    AttributeMoments at;
    accumulateCentred<kAttr>(p, w, S, k0, f, m, at);
    const Solution<v4> s = solveLanes(m, params.regularisation, params.method);
    const int lanes = std::min(4, kEnd - k0);
    applyLanes(p, f, m, hit + k0, lanes, u + 3 * k0);
    if constexpr (kAttr) applyAttributes(p, f, m, at, s.inverse, hit + k0, lanes, attr + 4 * k0);
  }
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
  params::validate(mlsParamsTable(), params);
  const size_t n = static_cast<size_t>(p_.count) * maxLen_;
  w0_.assign(n, 0.0);
  w_.assign(n, 0.0);
  for (auto* a : {&vx_, &vy_, &vz_, &md2_, &mid_}) a->assign(static_cast<size_t>(maxLen_), 0.0);
  hit_.assign(static_cast<size_t>(maxLen_), -1);
}

void RowEvaluator::setRow(const Vec3& baseMm, const Vec3& stepMm, int len) {
  len_ = std::min(len, maxLen_);
  stride_ = (len_ + kLanes - 1) / kLanes * kLanes;
  const Vec3 b = baseMm - p_.targetCentre;
  for (int k = 0; k < len_; ++k) {
    vx_[static_cast<size_t>(k)] = b.x + k * stepMm.x;
    vy_[static_cast<size_t>(k)] = b.y + k * stepMm.y;
    vz_[static_cast<size_t>(k)] = b.z + k * stepMm.z;
  }
  computeWeights();
}

void RowEvaluator::setPositions(const Vec3* positionsMm, int len) {
  len_ = std::min(len, maxLen_);
  stride_ = (len_ + kLanes - 1) / kLanes * kLanes;
  for (int k = 0; k < len_; ++k) {
    const Vec3 v = positionsMm[k] - p_.targetCentre;
    vx_[static_cast<size_t>(k)] = v.x; vy_[static_cast<size_t>(k)] = v.y; vz_[static_cast<size_t>(k)] = v.z;
  }
  computeWeights();
}

VELLUM_SIMD_CLONES void RowEvaluator::computeWeights() {
  double* vx = vx_.data(); double* vy = vy_.data(); double* vz = vz_.data();
  // Padding lanes repeat the last node (finite weights; results discarded).
  for (int k = len_; k < stride_; ++k) { vx[k] = vx[len_ - 1]; vy[k] = vy[len_ - 1]; vz[k] = vz[len_ - 1]; }
  double* md2 = md2_.data(); double* mid = mid_.data();
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
    const v4 fi = {double(i), double(i), double(i), double(i)};
    const v4 floor2 = {kWeightDist2, kWeightDist2, kWeightDist2, kWeightDist2};
    const v4f one = {1.f, 1.f, 1.f, 1.f};
    auto loop = [&](auto weightOf) VELLUM_INLINE_LAMBDA {  // explicit 4-lane vectors: stride_ is a multiple of 4
      for (int k = 0; k < stride_; k += 4) {
        const v4 dx = load4(vx + k) - tx, dy = load4(vy + k) - ty, dz = load4(vz + k) - tz;
        const v4 d2 = dx * dx + dy * dy + dz * dz;
        const v4 d2c = d2 > floor2 ? d2 : floor2;
        const v4 r = __builtin_convertvector(one / __builtin_convertvector(d2c, v4f), v4);
        store4(w + k, weightOf(r));
        const v4 old = load4(md2 + k);
        const auto closer = d2 < old;
        store4(md2 + k, closer ? d2 : old);
        store4(mid + k, closer ? fi : load4(mid + k));
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
  if (attr && p_.attributes) {
    solveBlocked(w, u, attr, 0, L);
    return;
  }
  if (singlePrecision_ && params_.method == MlsMethod::Affine) solveBlockedFloat(w, u);
  else solveBlocked(w, u, nullptr, 0, L);
  if (attr)
    for (int k = 0; k < L; ++k) { attr[4 * k] = attr[4 * k + 1] = attr[4 * k + 2] = 0; attr[4 * k + 3] = 1; }
}

// Double precision, kLanes nodes at a time (attributes too when attr is given).
VELLUM_SIMD_CLONES void RowEvaluator::solveBlocked(const double* w, double* u, double* attr, int kBegin, int kEnd) {
  const double* const v[3] = {vx_.data(), vy_.data(), vz_.data()};
  if (attr) solveDoubleLanes<true>(p_, params_, w, stride_, v, hit_.data(), kBegin, kEnd, u, attr);
  else solveDoubleLanes<false>(p_, params_, w, stride_, v, hit_.data(), kBegin, kEnd, u, nullptr);
}

// Single precision for grids (8 nodes per AVX2 register). Blocks with a lane that is not
// well-posed in float (see wellPosedInFloat) are redone in double precision.
VELLUM_SIMD_CLONES void RowEvaluator::solveBlockedFloat(const double* w, double* u) {
  constexpr int kF = kWidth<v8>;
  const int L = len_, S = stride_;
  const double* const v[3] = {vx_.data(), vy_.data(), vz_.data()};
  for (int k0 = 0; k0 < L; k0 += kF) {
    if (k0 + kF > S) { solveBlocked(w, u, nullptr, k0, L); break; }  // tail shorter than 8 lanes
    const Frame<v8> f = frameOf<v8>(p_, w, S, k0, v);
    Moments<v8> m;
    accumulateAboutFrame(p_, w, S, k0, f, m);
    const Solution<v8> s = solveLanes(m, params_.regularisation, MlsMethod::Affine);
    const int* hit = hit_.data() + k0;
    applyLanes(p_, f, m, hit, std::min(kF, L - k0), u + 3 * k0);
    if (!wellPosedInFloat(s, hit)) solveBlocked(w, u, nullptr, k0, std::min(k0 + kF, L));
  }
}

}  // namespace vellum::deformation::detail
