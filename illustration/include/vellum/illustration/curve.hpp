#pragma once
// 2D curve tools of the curve analogy ([SAVI 2.3] steps 2-3 in docs/references.md): arc-length resampling,
// similarity alignment (Umeyama 1991, least squares) and Laplacian curve deformation.
// Units are whatever the caller uses (image pixels in curve analogy).
#include <vector>

namespace vellum::illustration {

struct Point2 {
  double x = 0, y = 0;
};
using Polyline2 = std::vector<Point2>;

/// `count` points evenly spaced by arc length along the polyline; for a closed curve the
/// segment from the last point back to the first counts and the last sample is not a
/// repeat of the first. Needs >= 2 points and count >= 2.
Polyline2 resampleByArcLength(const Polyline2& curve, int count, bool closed);

/// Length of the polyline (closed: including the closing segment).
double arcLength(const Polyline2& curve, bool closed);

/// Similarity x -> scale * R x + t.
struct Similarity2 {
  double scale = 1, cosA = 1, sinA = 0, tx = 0, ty = 0;
  Point2 apply(const Point2& p) const {
    return {scale * (cosA * p.x - sinA * p.y) + tx, scale * (sinA * p.x + cosA * p.y) + ty};
  }
};
/// Least-squares similarity taking from[i] onto to[i] (same size, >= 2, no reflection).
Similarity2 fitSimilarity(const Polyline2& from, const Polyline2& to);

struct LaplacianOptions {
  bool closed = true;
  double lambda = 10.0;      ///< weight of the anchors' squared distance to their targets
  std::vector<int> anchors;  ///< indices kept near anchorTargets (>= 1 for a closed curve)
  int maxIterations = 2000;  ///< conjugate gradients
  double tolerance = 1e-12;  ///< relative residual
};
/// Minimises sum_i |L(v)_i - L(u)_i|^2 + lambda sum_{j in anchors} |v_j - target_j|^2 with
/// L(v)_i = v_i - (v_{i-1} + v_{i+1}) / 2 (open curves: rows for interior points only),
/// solved on the normal equations with Eigen's sparse conjugate gradients (x and y apart).
/// `shape` = u (the curve whose details are wanted), `anchorTargets` = one target per anchor.
Polyline2 deformCurveLaplacian(const Polyline2& shape, const std::vector<Point2>& anchorTargets,
                               const LaplacianOptions& options);

/// Symmetric Hausdorff distance between two polylines (point-to-segment both ways).
double hausdorff(const Polyline2& a, const Polyline2& b, bool closedA, bool closedB);

}  // namespace vellum::illustration
