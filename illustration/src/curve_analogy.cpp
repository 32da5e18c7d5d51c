// Curve-analogy pipeline (algorithms.md 2.3): proxy, silhouette C1, alignment of C0,
// Laplacian curve deformation, lift to 3D, ARAP of the proxy, MVC transfer.
#include "vellum/illustration/curve_analogy.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>

#include "curve_analogy_internal.hpp"
#include "shape_internal.hpp"
#include "vellum/core/error.hpp"

namespace vellum::illustration {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

double signedArea(const Polyline2& c) {
  double a = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    const auto& p = c[i];
    const auto& q = c[(i + 1) % c.size()];
    a += p.x * q.y - q.x * p.y;
  }
  return a / 2;
}

/// C0 resampled, started at the cyclic shift that fits C1 best, and aligned onto C1.
Polyline2 alignCurve(Polyline2 c0, const Polyline2& c1) {
  const size_t n = c1.size();
  Polyline2 best;
  double bestErr = 1e300;
  Polyline2 shifted(n);
  for (size_t k = 0; k < n; ++k) {
    for (size_t i = 0; i < n; ++i) shifted[i] = c0[(i + k) % n];
    const Similarity2 s = fitSimilarity(shifted, c1);
    double err = 0;
    for (size_t i = 0; i < n; ++i) {
      const Point2 p = s.apply(shifted[i]);
      err += (p.x - c1[i].x) * (p.x - c1[i].x) + (p.y - c1[i].y) * (p.y - c1[i].y);
    }
    if (err < bestErr) {
      bestErr = err;
      best.resize(n);
      for (size_t i = 0; i < n; ++i) best[i] = s.apply(shifted[i]);
    }
  }
  return best;
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
  std::ifstream is(path);
  if (!is) throw FileError(path, "cannot open the curve file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(is);
  } catch (const std::exception& e) {
    throw FileError(path, std::string("not valid JSON: ") + e.what());
  }
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
  // The quadric bound only orders collapses here: the face budget decides the size.
  TriMesh m = detail::smoothAndDecimate(mesh, 0, targetFaces, 1e6);
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
  const Silhouette sil = silhouetteLoop(r.proxy, proj);
  Polyline2 c0 = c0In;
  if ((signedArea(c0) > 0) != (signedArea(sil.pixels) > 0)) std::reverse(c0.begin(), c0.end());
  r.c1 = resampleByArcLength(sil.pixels, o.samples, true);
  r.c0Aligned = alignCurve(resampleByArcLength(c0, o.samples, true), r.c1);
  r.anchors = pickAnchors(r.c0Aligned, r.c1, o.anchors);
  std::vector<Point2> targets;
  for (int a : r.anchors) targets.push_back(r.c1[size_t(a)]);
  LaplacianOptions lo;
  lo.closed = true;
  lo.lambda = o.lambda;
  lo.anchors = r.anchors;
  r.c1Deformed = deformCurveLaplacian(r.c0Aligned, targets, lo);
  r.curveMs = msSince(t);

  // Lift: each silhouette vertex moves in the image plane by the displacement of the
  // deformed curve at its arc-length position; its depth stays.
  t = Clock::now();
  const double ppm = proj.pixelsPerMm();
  const size_t n = r.c1.size();
  std::vector<double> s(sil.pixels.size(), 0.0);
  for (size_t i = 1; i < s.size(); ++i)
    s[i] = s[i - 1] + std::hypot(sil.pixels[i].x - sil.pixels[i - 1].x, sil.pixels[i].y - sil.pixels[i - 1].y);
  const double total = arcLength(sil.pixels, true);
  std::vector<uint32_t> handles;
  std::vector<Vec3> handleTargets;
  std::vector<char> isHandle(r.proxy.vertices.size(), 0);
  for (size_t i = 0; i < sil.vertices.size(); ++i) {
    const uint32_t v = sil.vertices[i];
    if (isHandle[v]) continue;  // a loop through a pinch point visits it twice
    isHandle[v] = 1;
    const double u = s[i] / total * double(n);
    const size_t i0 = static_cast<size_t>(std::floor(u)) % n, i1 = (i0 + 1) % n;
    const double f = u - std::floor(u);
    const double dx = (1 - f) * (r.c1Deformed[i0].x - r.c1[i0].x) + f * (r.c1Deformed[i1].x - r.c1[i1].x);
    const double dy = (1 - f) * (r.c1Deformed[i0].y - r.c1[i0].y) + f * (r.c1Deformed[i1].y - r.c1[i1].y);
    const auto& p = r.proxy.vertices[v];
    handles.push_back(v);
    handleTargets.push_back(Vec3{p[0], p[1], p[2]} + proj.screenRight() * (dx / ppm) - proj.screenUp() * (dy / ppm));
  }
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
  r.silhouetteAfter = silhouetteLoop(after, proj).pixels;
  r.hausdorffBeforePx = hausdorff(sil.pixels, r.c0Aligned, true, true);
  r.hausdorffAfterPx = hausdorff(r.silhouetteAfter, r.c0Aligned, true, true);
  return r;
}

}  // namespace vellum::illustration
