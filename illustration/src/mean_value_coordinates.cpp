// Mean value coordinates for closed triangle meshes (Ju, Schaefer, Warren 2005), evaluated
// per triangle in the numerically stable half-angle form, with an explicit on-surface test.
#include "vellum/illustration/mean_value_coordinates.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::illustration {

Cage cageOf(const TriMesh& mesh) {
  Cage c;
  c.vertices.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) c.vertices.push_back({v[0], v[1], v[2]});
  c.faces = mesh.faces;
  return c;
}

namespace {

/// Closest point of triangle abc to p as barycentric weights (Ericson, Real-Time Collision
/// Detection 5.1.5: Voronoi regions of vertices, edges, face).
std::array<double, 3> closestBarycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

double diagonal(const Cage& cage) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const auto& v : cage.vertices)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], v[a]);
      hi[a] = std::max(hi[a], v[a]);
    }
  return std::max(norm(hi - lo), 1e-300);
}

/// The cage with what every point's evaluation shares: unit face normals, the tolerance.
struct Prepared {
  const Cage& cage;
  std::vector<Vec3> normals;
  double tol;
  Prepared(const Cage& c, double relTol) : cage(c), tol(relTol * diagonal(c)) {
    normals.reserve(c.faces.size());
    for (const auto& f : c.faces) {
      const Vec3 n = cross(c.vertices[f[1]] - c.vertices[f[0]], c.vertices[f[2]] - c.vertices[f[0]]);
      const double len = norm(n);
      normals.push_back(len > 0 ? n / len : Vec3{0, 0, 0});
    }
  }
};

/// Fills w (size = cage vertices) with the normalised coordinates of x.
void evaluate(const Prepared& prep, const Vec3& x, std::vector<double>& w) {
  const Cage& cage = prep.cage;
  const double tol = prep.tol;
  std::fill(w.begin(), w.end(), 0.0);
  constexpr double kEps = 1e-12;
  // On the surface the integral is singular: return the barycentric limit.
  for (size_t fi = 0; fi < cage.faces.size(); ++fi) {
    const auto& f = cage.faces[fi];
    const Vec3 &a = cage.vertices[f[0]], &b = cage.vertices[f[1]], &c = cage.vertices[f[2]];
    // Cheap reject: farther than tol from the face's plane (degenerate faces: full test).
    if (std::abs(dot(x - a, prep.normals[fi])) > tol && dot(prep.normals[fi], prep.normals[fi]) > 0) continue;
    const auto bc = closestBarycentric(x, a, b, c);
    const Vec3 q = a * bc[0] + b * bc[1] + c * bc[2];
    if (norm(q - x) <= tol) {
      for (int i = 0; i < 3; ++i) w[f[i]] += bc[i];
      return;
    }
  }
  std::vector<double> d(cage.vertices.size());
  std::vector<Vec3> u(cage.vertices.size());
  for (size_t i = 0; i < cage.vertices.size(); ++i) {
    const Vec3 r = cage.vertices[i] - x;
    d[i] = norm(r);
    u[i] = r / d[i];  // d > tol here: x is farther than tol from every face
  }
  for (const auto& f : cage.faces) {
    // Angles by atan2 (asin of the chord loses precision near pi, i.e. near edges), and the
    // sines of the dihedral angles from the tetrahedron's volume, not sqrt(1 - c^2): next to
    // a face c is -1 + O(dist^2) and the square root would keep only a few digits.
    double theta[3], sinTheta[3], c[3], s[3];
    for (int i = 0; i < 3; ++i) {
      const Vec3& a = u[f[(i + 1) % 3]];
      const Vec3& b = u[f[(i + 2) % 3]];
      sinTheta[i] = norm(cross(a, b));  // unit vectors: |a x b| = sin(theta)
      theta[i] = std::atan2(sinTheta[i], dot(a, b));
    }
    const double h = (theta[0] + theta[1] + theta[2]) / 2;
    const Vec3 r0 = cage.vertices[f[0]] - x, r1 = cage.vertices[f[1]] - x, r2 = cage.vertices[f[2]] - x;
    const double detU = dot(r0, cross(r1, r2)) / (d[f[0]] * d[f[1]] * d[f[2]]);
    bool flat = std::abs(detU) <= kEps * kEps;
    for (int i = 0; i < 3 && !flat; ++i) {
      const int ip = (i + 1) % 3, im = (i + 2) % 3;
      const double denom = sinTheta[ip] * sinTheta[im];
      if (!(std::abs(denom) > kEps)) { flat = true; break; }
      c[i] = 2 * std::sin(h) * std::sin(h - theta[i]) / denom - 1;
      s[i] = detU / denom;
    }
    // x in the plane of this face but outside it: the face contributes nothing. (No test on
    // pi - h: it shrinks with the squared distance to the face, so the paper's epsilon test
    // would drop the dominant face of points 1e-7 away; on-face points were handled above.)
    if (flat) continue;
    for (int i = 0; i < 3; ++i) {
      const int ip = (i + 1) % 3, im = (i + 2) % 3;
      w[f[i]] += (theta[i] - c[ip] * theta[im] - c[im] * theta[ip]) /
                 (d[f[i]] * sinTheta[ip] * s[im]);
    }
  }
  double sum = 0;
  for (double v : w) sum += v;
  if (!(std::abs(sum) > 0) || !std::isfinite(sum)) throw Error("mean value coordinates: degenerate cage");
  for (double& v : w) v /= sum;
}

}  // namespace

std::vector<double> meanValueCoordinates(const Cage& cage, const Vec3& x, const MvcOptions& options) {
  std::vector<double> w(cage.vertices.size());
  evaluate(Prepared(cage, options.surfaceTolerance), x, w);
  return w;
}

std::vector<Vec3> transferByMeanValueCoordinates(const Cage& rest,
                                                 const std::vector<Vec3>& deformedVertices,
                                                 const std::vector<Vec3>& points,
                                                 const MvcOptions& options) {
  if (deformedVertices.size() != rest.vertices.size())
    throw Error("mean value transfer: deformed cage has " + std::to_string(deformedVertices.size()) +
                " vertices, the rest cage " + std::to_string(rest.vertices.size()));
  const Prepared prep(rest, options.surfaceTolerance);
  std::vector<Vec3> out(points.size());
  parallelFor(static_cast<int64_t>(points.size()), [&](int64_t begin, int64_t end) {
    std::vector<double> w(rest.vertices.size());
    for (int64_t p = begin; p < end; ++p) {
      evaluate(prep, points[static_cast<size_t>(p)], w);
      Vec3 y{0, 0, 0};
      for (size_t i = 0; i < w.size(); ++i)
        if (w[i] != 0) y += deformedVertices[i] * w[i];
      out[static_cast<size_t>(p)] = y;
    }
  });
  return out;
}

}  // namespace vellum::illustration
