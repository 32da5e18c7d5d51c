// Curve-analogy pipeline ([SAVI 2.3] in docs/references.md): proxy, silhouette C1, alignment of C0,
// Laplacian curve deformation, lift to 3D, ARAP of the proxy, MVC transfer.
#include "vellum/illustration/curve_analogy.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numeric>

#include "curve_analogy_internal.hpp"
#include "shape_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"

namespace vellum::illustration {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

/// C0 (resampled) aligned onto C1: over both orientations and every cyclic start, the
/// least-squares similarity with the smallest residual whose rotation is within
/// `maxRotationDeg` (the drawing is read as the view's image, so it is upright; the limit
/// also stops a near-symmetric outline from matching itself upside down or mirrored).
Polyline2 alignCurve(const Polyline2& c0, const Polyline2& c1, double maxRotationDeg) {
  const size_t n = c1.size();
  const double minCos = std::cos(maxRotationDeg * 3.14159265358979323846 / 180);
  Polyline2 best, bestAny;
  double bestErr = 1e300, bestAnyErr = 1e300;
  Polyline2 shifted(n);
  for (int dir = 0; dir < 2; ++dir)
    for (size_t k = 0; k < n; ++k) {
      for (size_t i = 0; i < n; ++i) shifted[i] = c0[dir == 0 ? (i + k) % n : (k + n - i) % n];
      const Similarity2 s = fitSimilarity(shifted, c1);
      double err = 0;
      for (size_t i = 0; i < n; ++i) {
        const Point2 p = s.apply(shifted[i]);
        err += (p.x - c1[i].x) * (p.x - c1[i].x) + (p.y - c1[i].y) * (p.y - c1[i].y);
      }
      const bool upright = s.cosA >= minCos;
      if (err < (upright ? bestErr : bestAnyErr)) {
        Polyline2& into = upright ? best : bestAny;
        (upright ? bestErr : bestAnyErr) = err;
        into.resize(n);
        for (size_t i = 0; i < n; ++i) into[i] = s.apply(shifted[i]);
      }
    }
  return best.empty() ? bestAny : best;
}

/// `count` indices where a and b agree best, at least n / (2 count) apart along the loop.
std::vector<int> pickAnchors(const Polyline2& a, const Polyline2& b, int count) {
  const int n = static_cast<int>(a.size());
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  auto err = [&](int i) { return std::hypot(a[size_t(i)].x - b[size_t(i)].x, a[size_t(i)].y - b[size_t(i)].y); };
  std::stable_sort(order.begin(), order.end(), [&](int i, int j) { return err(i) < err(j); });
  const int gap = std::max(1, n / (2 * std::max(1, count)));
  std::vector<int> picked;
  for (int i : order) {
    if (static_cast<int>(picked.size()) >= count) break;
    bool ok = true;
    for (int j : picked) {
      const int d = std::abs(i - j);
      if (std::min(d, n - d) < gap) ok = false;
    }
    if (ok) picked.push_back(i);
  }
  return picked;
}
}  // namespace

Polyline2 loadCurveJson(const std::filesystem::path& path) {
  // A drawn curve has hundreds of points; 16 MiB holds about half a million.
  const nlohmann::json j = readJsonFile(path, 16u << 20, "curve file");
  if (!j.is_object() || !j.contains("points") || !j["points"].is_array())
    throw FileError(path, "expected {\"points\": [[x, y], ...]}");
  Polyline2 c;
  for (const auto& p : j["points"]) {
    if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
      throw FileError(path, "point " + std::to_string(c.size()) + " is not [x, y]");
    c.push_back({p[0].get<double>(), p[1].get<double>()});
    if (!std::isfinite(c.back().x) || !std::isfinite(c.back().y))
      throw FileError(path, "point " + std::to_string(c.size() - 1) + " is not finite");
  }
  if (c.size() < 3) throw FileError(path, "need at least 3 points");
  if (!(arcLength(c, true) > 0)) throw FileError(path, "the curve has zero length");
  return c;
}

TriMesh simplifyProxy(const TriMesh& mesh, int64_t targetFaces) {
  // The quadric bound only orders collapses and the normal guard is off: the face budget
  // decides the size (a cage needs the overall shape, not the features).
  TriMesh m = detail::smoothAndDecimate(mesh, 0, targetFaces, 1e6, 0.0);
  MeshChecks stats;
  return detail::repairMesh(m, stats);
}

TriMesh transferMesh(const TriMesh& mesh, const Cage& rest, const std::vector<Vec3>& deformed) {
  std::vector<Vec3> pts;
  pts.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) pts.push_back({v[0], v[1], v[2]});
  const auto moved = transferByMeanValueCoordinates(rest, deformed, pts);
  TriMesh out = mesh;
  for (size_t i = 0; i < moved.size(); ++i)
    out.vertices[i] = {float(moved[i].x), float(moved[i].y), float(moved[i].z)};
  return out;
}

CurveAnalogyResult curveAnalogy(const TriMesh& m0, const Polyline2& c0In,
                                const render::Projection& proj, const CurveAnalogyOptions& o) {
  if (o.samples < 8) throw Error("curve analogy: samples must be >= 8");
  if (o.anchors < 1) throw Error("curve analogy: anchors must be >= 1");
  CurveAnalogyResult r;
  auto t = Clock::now();
  r.proxy = simplifyProxy(m0, o.proxyFaces);
  r.proxyMs = msSince(t);

  t = Clock::now();
  const Polyline2 outline = projectedOutline(r.proxy, proj);
  r.c1 = resampleByArcLength(outline, o.samples, true);
  r.c0Aligned = alignCurve(resampleByArcLength(c0In, o.samples, true), r.c1, o.maxRotationDeg);
  r.anchors = pickAnchors(r.c0Aligned, r.c1, o.anchors);
  std::vector<Point2> targets;
  for (int a : r.anchors) targets.push_back(r.c1[size_t(a)]);
  LaplacianOptions lo;
  lo.closed = true;
  lo.lambda = o.lambda;
  lo.anchors = r.anchors;
  r.c1Deformed = deformCurveLaplacian(r.c0Aligned, targets, lo);
  r.curveMs = msSince(t);

  // Lift: every silhouette vertex on the outline moves in the image plane by the deformed
  // curve's displacement at its nearest point of C1; its depth stays.
  t = Clock::now();
  const double ppm = proj.pixelsPerMm();
  const size_t n = r.c1.size();
  std::vector<uint32_t> handles;
  std::vector<Vec3> handleTargets;
  for (uint32_t v : silhouetteVertices(r.proxy, proj)) {
    const auto& p = r.proxy.vertices[v];
    const Vec3 q = proj.toPixel(Vec3{p[0], p[1], p[2]}).value();
    double bestD = 1e300, dx = 0, dy = 0;
    for (size_t i = 0; i < n; ++i) {
      const Point2 &a = r.c1[i], &b = r.c1[(i + 1) % n];
      const double vx = b.x - a.x, vy = b.y - a.y, len2 = vx * vx + vy * vy;
      const double f = len2 > 0 ? std::clamp(((q.x - a.x) * vx + (q.y - a.y) * vy) / len2, 0.0, 1.0) : 0.0;
      const double d = std::hypot(q.x - (a.x + f * vx), q.y - (a.y + f * vy));
      if (d < bestD) {
        bestD = d;
        const Point2 &da = r.c1Deformed[i], &db = r.c1Deformed[(i + 1) % n];
        dx = (1 - f) * (da.x - a.x) + f * (db.x - b.x);
        dy = (1 - f) * (da.y - a.y) + f * (db.y - b.y);
      }
    }
    if (bestD > o.handleTolerancePx) continue;  // on a fold inside the outline: left to ARAP
    handles.push_back(v);
    handleTargets.push_back(Vec3{p[0], p[1], p[2]} + proj.screenRight() * (dx / ppm) - proj.screenUp() * (dy / ppm));
  }
  if (handles.empty()) throw Error("curve analogy: no mesh vertex lies on the outline (view too small?)");
  r.handles = static_cast<int>(handles.size());
  // Fixed vertices: farthest-point samples from the handles (the middle of the front and
  // back faces), so the deformation has something to push against.
  std::vector<double> far(r.proxy.vertices.size(), 1e300);
  auto P = [&](size_t v) { return Vec3{r.proxy.vertices[v][0], r.proxy.vertices[v][1], r.proxy.vertices[v][2]}; };
  auto relax = [&](uint32_t h) {
    for (size_t v = 0; v < far.size(); ++v) far[v] = std::min(far[v], norm(P(v) - P(h)));
  };
  for (uint32_t h : handles) relax(h);
  std::vector<uint32_t> fixed;
  for (int k = 0; k < o.fixedVertices; ++k) {
    const auto it = std::max_element(far.begin(), far.end());
    if (it == far.end() || *it <= 0) break;
    fixed.push_back(static_cast<uint32_t>(it - far.begin()));
    relax(fixed.back());
  }
  r.proxyDeformed = detail::arapDeform(r.proxy, handles, handleTargets, fixed, o.arapIterations);
  r.arapMs = msSince(t);

  TriMesh after = r.proxy;
  for (size_t i = 0; i < after.vertices.size(); ++i)
    after.vertices[i] = {float(r.proxyDeformed[i].x), float(r.proxyDeformed[i].y), float(r.proxyDeformed[i].z)};
  r.silhouetteAfter = projectedOutline(after, proj);
  r.hausdorffBeforePx = hausdorff(outline, r.c0Aligned, true, true);
  r.hausdorffAfterPx = hausdorff(r.silhouetteAfter, r.c0Aligned, true, true);
  return r;
}

}  // namespace vellum::illustration
