// The MLS lane solver (deformation/src/mls_kernel.cpp: 4 double lanes, 8 float lanes with a
// double redo, attributes) against a plain scalar reference: one node at a time, double
// precision, written straight from the formulas in mls.hpp. Runs in every build type.
//
// Tolerances (mm; the point sets span about 200 mm):
//  - double lanes: 1e-7. Both sides compute the same sums about the same point; they differ in
//    summation order, the 3x3 inverse and fused multiply-adds: rounding ~1e-16 relative, times
//    the 200 mm field, times the condition of A + lam I, which reaches ~1/eps = 1e6 for coplanar
//    sets (3 points): <= 2e-8 mm; ~1e-13 mm for well-spread sets.
//  - float lanes: 1e-3. Coordinates (|x| <= ~100 mm about their centre) and moments are rounded
//    to float (unit roundoff u = 2^-24 = 6e-8), and the error is amplified by the condition of A.
//    The lanes accept a node only when c = det A / (tr A / 3)^3 > 1e-3 (else the double redo),
//    which bounds cond(A) <= 27 / c = 2.7e4: a worst case of u * 2.7e4 * 100 mm = 0.16 mm. In
//    practice far less: measured 2.7e-4 mm at most (5 points, power 1: the least well-conditioned
//    set accepted here), 1e-5..1e-4 mm for 16 points. 1e-3 mm is 1/1000 of a 1 mm voxel (the map
//    is stored as float anyway), and far below any solver fault (a wrong lane or term).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "mls_kernel.hpp"
#include "vellum/core/rigid_fit.hpp"
#include "vellum/deformation/mls.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

constexpr double kDoubleTolMm = 1e-7;
constexpr double kFloatTolMm = 1e-3;

double maxAbs(const Vec3& v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

struct Result {
  Vec3 u;
  std::array<double, 4> attr;
};

// The kernel's weight 1 / max(d^2, 1e-12)^(n/2), with its single-precision reciprocal (a design
// choice of the kernel, see computeWeights), so that the comparison isolates the solver. d is
// taken about the targets' centre, as the kernel does, so the float rounding sees the same d^2.
double kernelWeight(const Vec3& v, const Vec3& y, double power) {
  const double d2 = std::max(dot(v - y, v - y), 1e-12);
  return std::pow(static_cast<double>(1.0f / static_cast<float>(d2)), 0.5 * power);
}

// u(v) = (v - y*) M + x*,  M = (A + lam I)^-1 (B + lam I)  or  mu R;  f(v) = (v - y*) (A + lam I)^-1 C + z*.
Result referenceMls(const ControlPoints& pts, const MlsParams& prm, const Vec3& vMm, const std::vector<double>& rho) {
  const size_t n = pts.size();
  Vec3 centre;
  for (const auto& p : pts) centre += p.target / static_cast<double>(n);
  const Vec3 v = vMm - centre;
  for (const auto& p : pts)
    if (dot(v - (p.target - centre), v - (p.target - centre)) < 1e-18) return {p.source, p.attributes.values()};
  std::vector<double> w(n);
  for (size_t i = 0; i < n; ++i) w[i] = kernelWeight(v, pts[i].target - centre, prm.power) * rho[i];
  // Sums about the heaviest point m: when it holds nearly all the weight, y* - y_m is then tiny
  // and exact enough, where y* taken plainly would leave rounding noise in every q and in A.
  const size_t m = static_cast<size_t>(std::max_element(w.begin(), w.end()) - w.begin());
  double W = 0;
  Vec3 xs, ys;
  std::array<double, 4> zs{};
  for (size_t i = 0; i < n; ++i) {
    W += w[i];
    xs += (pts[i].source - pts[m].source) * w[i];
    ys += (pts[i].target - pts[m].target) * w[i];
    for (int a = 0; a < 4; ++a) zs[a] += w[i] * pts[i].attributes.values()[a];
  }
  xs = xs / W; ys = ys / W;  // offsets from x_m, y_m
  for (double& z : zs) z /= W;
  Mat3 A, B;
  A.m = B.m = {};
  double C[3][4] = {};
  for (size_t i = 0; i < n; ++i) {
    const Vec3 q = (pts[i].target - pts[m].target) - ys, p = (pts[i].source - pts[m].source) - xs;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) { A(r, c) += w[i] * q[r] * q[c]; B(r, c) += w[i] * q[r] * p[c]; }
      for (int a = 0; a < 4; ++a) C[r][a] += w[i] * q[r] * (pts[i].attributes.values()[a] - zs[a]);
    }
  }
  const double tr = A(0, 0) + A(1, 1) + A(2, 2);
  double lam = 1;  // no spread: M = I
  if (tr > 0) {
    const double mean = tr / 3, c = std::max(A.determinant() / (mean * mean * mean), 0.0);
    lam = prm.regularisation * std::pow(prm.regularisation / (prm.regularisation + c), 2) * mean;
  } else {
    A.m = {};
  }
  Mat3 shifted = A, inv;
  for (int d = 0; d < 3; ++d) shifted(d, d) += lam;
  EXPECT_TRUE(shifted.inverse(inv, 0));
  Mat3 M;
  if (prm.method == MlsMethod::Affine) {
    Mat3 b = B;
    for (int d = 0; d < 3; ++d) b(d, d) += lam;
    M = inv * b;
  } else {
    double signedTrace = 0;
    const Mat3 R = nearestRotation(B, &signedTrace);
    const double mu = prm.method == MlsMethod::Similarity && tr > 0 ? signedTrace / tr : 1.0;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) M(r, c) = mu * R(r, c);
  }
  const Vec3 d = (vMm - pts[m].target) - ys;
  const Vec3 g = inv.transposed() * d;  // row vector d A'^-1 (A' symmetric)
  Result res{pts[m].source + xs + M.transposed() * d, zs};
  for (int a = 0; a < 4; ++a) res.attr[a] += g.x * C[0][a] + g.y * C[1][a] + g.z * C[2][a];
  return res;
}

struct Case {
  const char* name;
  ControlPoints points;
  MlsParams params;
  bool density = false;  // random per-point, per-node rho in [0.2, 1]
};

ControlPoints randomPoints(int n, unsigned seed, double spreadMm, double moveMm, bool attributes) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-spreadMm, spreadMm), move(-moveMm, moveMm), attr(-20, 20);
  ControlPoints pts;
  for (int i = 0; i < n; ++i) {
    ControlPoint p;
    p.source = Vec3{pos(rng), pos(rng), pos(rng)} + Vec3{12, -30, 45};
    p.target = p.source + Vec3{move(rng), move(rng), move(rng)};
    if (attributes) p.attributes = {attr(rng), attr(rng), attr(rng), 1 + attr(rng) / 40};
    pts.push_back(p);
  }
  return pts;
}

// Targets from sources by y = T x + t (structured: the map is then that affine, exactly).
ControlPoints transformed(ControlPoints pts, const Mat3& T, const Vec3& t) {
  for (auto& p : pts) p.target = T * p.source + t;
  return pts;
}

Mat3 rotation(double angle) {
  Mat3 r;
  const double c = std::cos(angle), s = std::sin(angle);
  r.m = {{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  return r;
}

std::vector<Case> cases() {
  std::vector<Case> out;
  const MlsMethod methods[] = {MlsMethod::Affine, MlsMethod::Similarity, MlsMethod::Rigid};
  for (MlsMethod m : methods) {
    MlsParams p;
    p.method = m;
    out.push_back({"random 16", randomPoints(16, 1, 90, 25, false), p});
    out.push_back({"random 40, attributes", randomPoints(40, 2, 100, 30, true), p});
    out.push_back({"random 16, density", randomPoints(16, 12, 90, 25, false), p, true});
    auto with = [&](double power, double eps) {
      MlsParams q = p;
      q.power = power;
      q.regularisation = eps;
      return q;
    };
    out.push_back({"random 16, power 4", randomPoints(16, 3, 90, 25, false), with(4, 1e-6)});
    out.push_back({"random 9, power 3, eps 1e-2, density", randomPoints(9, 4, 80, 20, true), with(3, 1e-2), true});
    out.push_back({"random 5, power 1", randomPoints(5, 5, 80, 20, false), with(1, 1e-6)});
    out.push_back({"random 3 (always coplanar), power 2.5", randomPoints(3, 6, 80, 20, true), with(2.5, 1e-6)});
    out.push_back({"one point", randomPoints(1, 7, 80, 20, true), p});
    Mat3 s = rotation(0.3);
    for (auto& row : s.m)
      for (double& e : row) e *= 1.2;
    out.push_back({"similarity transform", transformed(randomPoints(12, 8, 90, 0, false), s, {5, -7, 3}), p});
    out.push_back({"rigid transform", transformed(randomPoints(12, 9, 90, 0, false), rotation(-0.5), {-9, 2, 4}), p});
    Mat3 shear;
    shear.m = {{{1.1, 0.2, 0}, {0, 0.9, 0.1}, {0.05, 0, 1.05}}};
    out.push_back({"affine transform, density", transformed(randomPoints(12, 10, 90, 0, true), shear, {1, 2, 3}), p, true});
    ControlPoints flat = randomPoints(10, 11, 90, 20, false);
    for (auto& q : flat) q.target.z = 45;  // coplanar targets: the regularisation decides
    out.push_back({"coplanar targets", flat, p});
  }
  return out;
}

// The nodes: a row (37 long: tails of 4 and 8 lanes) sweeping through the points' box, and every
// target exactly (hits) with neighbours 1e-7 mm off (huge dominant weights).
std::vector<Vec3> nodesFor(const ControlPoints& pts) {
  std::vector<Vec3> v;
  for (int k = 0; k < 37; ++k) v.push_back(Vec3{-95, -125, -40} + Vec3{5.3, 4.9, 4.1} * k);
  for (const auto& p : pts) {
    v.push_back(p.target);
    v.push_back(p.target + Vec3{1e-7, 0, 0});
  }
  return v;
}

// Max |lanes - reference| over the case's nodes, for positions and attributes.
std::pair<double, double> maxDifference(const Case& c, bool singlePrecision) {
  const bool withAttr = hasAttributes(c.points);
  const auto data = detail::PointData::from(c.points, withAttr);
  const std::vector<Vec3> nodes = nodesFor(c.points);
  const int len = static_cast<int>(nodes.size());
  detail::RowEvaluator eval(data, c.params, len);
  eval.setSinglePrecision(singlePrecision);
  eval.setPositions(nodes.data(), len);
  const size_t n = c.points.size();
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> rhoOf(0.2f, 1.0f);
  std::vector<float> rho(n * static_cast<size_t>(len), 1.0f);
  if (c.density)
    for (float& r : rho) r = rhoOf(rng);
  std::vector<double> u(3 * static_cast<size_t>(len)), attr(4 * static_cast<size_t>(len));
  eval.solve(c.density ? rho.data() : nullptr, u.data(), withAttr ? attr.data() : nullptr);
  double du = 0, da = 0;
  for (int k = 0; k < len; ++k) {
    std::vector<double> rk(n);
    for (size_t i = 0; i < n; ++i) rk[i] = rho[i * static_cast<size_t>(len) + static_cast<size_t>(k)];
    const Result ref = referenceMls(c.points, c.params, nodes[static_cast<size_t>(k)], rk);
    for (int a = 0; a < 3; ++a) du = std::max(du, std::abs(u[3 * static_cast<size_t>(k) + a] - ref.u[a]));
    if (withAttr)
      for (int a = 0; a < 4; ++a) da = std::max(da, std::abs(attr[4 * static_cast<size_t>(k) + a] - ref.attr[a]));
  }
  return {du, da};
}

void checkAll(bool singlePrecision, double tol) {
  double worst = 0;
  for (const Case& c : cases()) {
    const auto [du, da] = maxDifference(c, singlePrecision);
    worst = std::max(worst, du);
    // Attributes have no float path: they are solved in double lanes.
    EXPECT_LE(du, tol) << c.name << ", " << mlsMethodName(c.params.method);
    if (std::getenv("MLS_LANES_VERBOSE")) std::printf("  %-40s %-10s %.3g mm (attributes %.3g)\n", c.name, mlsMethodName(c.params.method), du, da);
    EXPECT_LE(da, kDoubleTolMm) << c.name << ", " << mlsMethodName(c.params.method) << " (attributes)";
  }
  std::printf("max |lanes - reference| (%s lanes): %.3g mm\n", singlePrecision ? "float" : "double", worst);
}

}  // namespace

TEST(MlsLanes, DoubleLanesMatchScalarReference) { checkAll(false, kDoubleTolMm); }

TEST(MlsLanes, FloatLanesMatchScalarReference) { checkAll(true, kFloatTolMm); }

// The float grid path falls back to double lanes for ill-posed lanes: the same cases through
// evaluateMls (double lanes, in parallel chunks) give the reference too.
TEST(MlsLanes, EvaluateMlsMatchesScalarReference) {
  for (const Case& c : cases()) {
    if (c.density) continue;
    const std::vector<Vec3> nodes = nodesFor(c.points);
    std::vector<std::array<double, 4>> attr;
    const auto u = evaluateMls(c.points, c.params, nodes, &attr);
    const std::vector<double> ones(c.points.size(), 1.0);
    for (size_t k = 0; k < nodes.size(); ++k) {
      const Result ref = referenceMls(c.points, c.params, nodes[k], ones);
      EXPECT_LE(maxAbs(u[k] - ref.u), kDoubleTolMm) << c.name << " node " << k;
    }
  }
}
