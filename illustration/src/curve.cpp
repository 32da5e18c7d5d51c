// Curve tools: resampling, Umeyama similarity, Laplacian curve deformation (Eigen CG).
#include "vellum/illustration/curve.hpp"

#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <string>

#include "vellum/core/error.hpp"

namespace vellum::illustration {

namespace {
double dist(const Point2& a, const Point2& b) { return std::hypot(a.x - b.x, a.y - b.y); }

double pointSegment(const Point2& p, const Point2& a, const Point2& b) {
  const double vx = b.x - a.x, vy = b.y - a.y;
  const double len2 = vx * vx + vy * vy;
  double t = len2 > 0 ? ((p.x - a.x) * vx + (p.y - a.y) * vy) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p.x - (a.x + t * vx), p.y - (a.y + t * vy));
}

double directed(const Polyline2& a, const Polyline2& b, bool closedB) {
  double worst = 0;
  const size_t segs = closedB ? b.size() : b.size() - 1;
  for (const auto& p : a) {
    double best = b.size() == 1 ? dist(p, b[0]) : 1e300;
    for (size_t i = 0; i < segs; ++i) best = std::min(best, pointSegment(p, b[i], b[(i + 1) % b.size()]));
    worst = std::max(worst, best);
  }
  return worst;
}
}  // namespace

double arcLength(const Polyline2& c, bool closed) {
  double s = 0;
  for (size_t i = 1; i < c.size(); ++i) s += dist(c[i - 1], c[i]);
  if (closed && c.size() > 1) s += dist(c.back(), c.front());
  return s;
}

Polyline2 resampleByArcLength(const Polyline2& curve, int count, bool closed) {
  if (curve.size() < 2 || count < 2) throw Error("resample: need >= 2 points and count >= 2");
  Polyline2 c = curve;
  if (closed) c.push_back(curve.front());
  std::vector<double> s(c.size(), 0.0);
  for (size_t i = 1; i < c.size(); ++i) s[i] = s[i - 1] + dist(c[i - 1], c[i]);
  const double total = s.back();
  if (!(total > 0)) throw Error("resample: curve has zero length");
  Polyline2 out;
  out.reserve(static_cast<size_t>(count));
  const double step = total / (closed ? count : count - 1);
  size_t seg = 0;
  for (int k = 0; k < count; ++k) {
    const double t = std::min(total, k * step);
    while (seg + 2 < s.size() && s[seg + 1] < t) ++seg;
    const double len = s[seg + 1] - s[seg];
    const double f = len > 0 ? (t - s[seg]) / len : 0.0;
    out.push_back({c[seg].x + f * (c[seg + 1].x - c[seg].x), c[seg].y + f * (c[seg + 1].y - c[seg].y)});
  }
  return out;
}

Similarity2 fitSimilarity(const Polyline2& from, const Polyline2& to) {
  if (from.size() != to.size() || from.size() < 2) throw Error("similarity fit: need two equal-size point lists (>= 2)");
  const double n = static_cast<double>(from.size());
  Point2 mf, mt;
  for (size_t i = 0; i < from.size(); ++i) {
    mf.x += from[i].x / n; mf.y += from[i].y / n;
    mt.x += to[i].x / n; mt.y += to[i].y / n;
  }
  // 2D Umeyama: the optimal rotation maximises sum <R a_i, b_i>; with complex numbers it is
  // the argument of sum conj(a_i) b_i, and the scale is |that sum| / sum |a_i|^2.
  double re = 0, im = 0, var = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    const double ax = from[i].x - mf.x, ay = from[i].y - mf.y;
    const double bx = to[i].x - mt.x, by = to[i].y - mt.y;
    re += ax * bx + ay * by;
    im += ax * by - ay * bx;
    var += ax * ax + ay * ay;
  }
  const double r = std::hypot(re, im);
  if (!(var > 0) || !(r > 0)) throw Error("similarity fit: degenerate point set");
  Similarity2 s;
  s.cosA = re / r;
  s.sinA = im / r;
  s.scale = r / var;
  const Point2 rm = s.apply(mf);  // with t = 0
  s.tx = mt.x - rm.x;
  s.ty = mt.y - rm.y;
  return s;
}

Polyline2 deformCurveLaplacian(const Polyline2& shape, const std::vector<Point2>& targets,
                               const LaplacianOptions& o) {
  const int n = static_cast<int>(shape.size());
  if (n < 3) throw Error("Laplacian curve deformation: need >= 3 points");
  if (o.anchors.empty()) throw Error("Laplacian curve deformation: need at least one anchor");
  if (targets.size() != o.anchors.size()) throw Error("Laplacian curve deformation: one target per anchor");
  if (!(o.lambda > 0)) throw Error("Laplacian curve deformation: lambda must be > 0");
  using SpMat = Eigen::SparseMatrix<double>;
  std::vector<Eigen::Triplet<double>> t;
  int rows = 0;
  for (int i = 0; i < n; ++i) {
    if (!o.closed && (i == 0 || i == n - 1)) continue;
    t.emplace_back(rows, i, 1.0);
    t.emplace_back(rows, (i + n - 1) % n, -0.5);
    t.emplace_back(rows, (i + 1) % n, -0.5);
    ++rows;
  }
  SpMat L(rows, n);
  L.setFromTriplets(t.begin(), t.end());
  // Normal equations: (L^T L + lambda sum e_j e_j^T) v = L^T L u + lambda sum e_j target_j.
  SpMat A = SpMat(L.transpose() * L);
  Eigen::VectorXd ux(n), uy(n);
  for (int i = 0; i < n; ++i) { ux[i] = shape[static_cast<size_t>(i)].x; uy[i] = shape[static_cast<size_t>(i)].y; }
  Eigen::VectorXd bx = A * ux, by = A * uy;
  for (size_t k = 0; k < o.anchors.size(); ++k) {
    const int j = o.anchors[k];
    if (j < 0 || j >= n) throw Error("Laplacian curve deformation: anchor " + std::to_string(j) + " out of range");
    A.coeffRef(j, j) += o.lambda;
    bx[j] += o.lambda * targets[k].x;
    by[j] += o.lambda * targets[k].y;
  }
  A.makeCompressed();
  Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper> cg;
  cg.setMaxIterations(o.maxIterations);
  cg.setTolerance(o.tolerance);
  cg.compute(A);
  const Eigen::VectorXd vx = cg.solveWithGuess(bx, ux), vy = cg.solveWithGuess(by, uy);
  if (cg.info() != Eigen::Success && cg.error() > 1e-6)
    throw Error("Laplacian curve deformation: conjugate gradients did not converge");
  Polyline2 out(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) out[static_cast<size_t>(i)] = {vx[i], vy[i]};
  return out;
}

double hausdorff(const Polyline2& a, const Polyline2& b, bool closedA, bool closedB) {
  if (a.empty() || b.empty()) throw Error("hausdorff: empty curve");
  return std::max(directed(a, b, closedB), directed(b, a, closedA));
}

}  // namespace vellum::illustration
