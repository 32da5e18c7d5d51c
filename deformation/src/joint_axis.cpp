// A joint's axis from its articular surfaces (pose.hpp, fitArticularSurface()): a hinge turns
// about the axis of its curved contact surfaces (the talar dome under the tibial plafond, the
// humeral trochlea), so a least-squares cylinder fitted to one bone's surface voxels in the
// contact zone gives it; a ball joint turns about a sphere's centre. Voxel surfaces carry
// flat side facets (the malleoli) and neighbouring joints' pieces as well, so the fits are
// robust: the surface normals vote for the axis direction (a cylinder's normals are all
// perpendicular to its axis; a facet's are not) and start the circle (its normals meet at the
// centre), and the residual is MSAC (a point's squared residual is clipped at the inlier band,
// so an outlier costs the same however far it is).
#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "axis_geometry.hpp"
#include "vellum/deformation/pose.hpp"

namespace vellum::deformation {
namespace {

using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;
using axis::basisAcross;
using axis::thinned;
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// A circle (N = 2, in the plane across a cylinder's axis) or a sphere (N = 3).
template <int N>
struct Round {
  Eigen::Matrix<double, N, 1> c = Eigen::Matrix<double, N, 1>::Zero();
  double r = 0, cost = kInf;  // cost: mean clipped squared residual
  double inliers = 0, rms = 0;
  bool ok = false;
};
using Circle = Round<2>;
using Sphere = Round<3>;

/// An inlier lies within the band of the surface AND faces along its normal (within 35°, either
/// way: convex or concave): a facet crossing the surface is not on it.
const double kFacing = std::cos(35 * kDeg);
template <class V>
bool inlier(const V& offset, const V& normal, double e, double band2) {
  return e * e < band2 && std::abs(normal.dot(offset)) >= kFacing * offset.norm();
}

/// From a start (c0, r0): the inliers of it, two Gauss-Newton steps of the geometric residual
/// |q - c| - r over them, reclassified, `rounds` times; the best with r <= maxRadius kept. `m`:
/// the points' unit normals (for a circle projected into the plane: shorter when they lean along
/// the axis).
template <int N>
Round<N> fitRound(const std::vector<Eigen::Matrix<double, N, 1>>& q, const std::vector<Eigen::Matrix<double, N, 1>>& m,
                  Eigen::Matrix<double, N, 1> c0, double r0, double band, int rounds, double maxRadius = kInf) {
  using V = Eigen::Matrix<double, N, 1>;
  using J = Eigen::Matrix<double, N + 1, 1>;
  Round<N> best;
  const double band2 = band * band;
  std::vector<char> in(q.size());
  for (size_t i = 0; i < q.size(); ++i)  // a wider band at first: the start is rough
    in[i] = inlier<V>(q[i] - c0, m[i], (q[i] - c0).norm() - r0, 4 * band2);
  V c = c0;
  double r = r0;
  for (int round = 0; round < rounds; ++round) {
    if (std::count(in.begin(), in.end(), 1) < 2 * N + 2) break;
    for (int gn = 0; gn < 2; ++gn) {
      Eigen::Matrix<double, N + 1, N + 1> jj = Eigen::Matrix<double, N + 1, N + 1>::Zero();
      J jr = J::Zero();
      for (size_t i = 0; i < q.size(); ++i) {
        if (!in[i]) continue;
        const V d = q[i] - c;
        const double len = d.norm();
        if (len < 1e-9) continue;
        J j;
        j.template head<N>() = -d / len;
        j[N] = -1.0;
        jj += j * j.transpose();
        jr += j * (len - r);
      }
      const J step = jj.ldlt().solve(-jr);
      if (!step.allFinite()) break;
      c += step.template head<N>();
      r += step[N];
    }
    Round<N> now;
    now.c = c;
    now.r = r = std::abs(r);
    double cost = 0, sq = 0;
    int inl = 0;
    for (size_t i = 0; i < q.size(); ++i) {
      const double e = (q[i] - c).norm() - now.r;
      in[i] = inlier<V>(q[i] - c, m[i], e, band2);
      cost += in[i] ? e * e : band2;
      if (in[i]) sq += e * e, ++inl;
    }
    now.cost = cost / double(q.size());
    now.inliers = double(inl) / double(q.size());
    now.rms = inl ? std::sqrt(sq / inl) : 0;
    now.ok = std::isfinite(now.cost) && now.r <= maxRadius;
    if (now.ok && now.cost < best.cost) best = now;
  }
  return best;
}

/// A surface voxel (mm, centred) and its outward unit normal.
struct SurfacePoint {
  V3 p, n;
};

/// The point nearest (least squares) to the lines through p_i along n_i, over the points with
/// false when the lines are (nearly) parallel in some direction (a flat patch). N = 2 (in a
/// plane) or 3.
template <int N>
bool nearestToLines(const std::vector<Eigen::Matrix<double, N, 1>>& p, const std::vector<Eigen::Matrix<double, N, 1>>& n,
                    Eigen::Matrix<double, N, 1>& c) {
  using M = Eigen::Matrix<double, N, N>;
  M a = M::Zero();
  Eigen::Matrix<double, N, 1> b = Eigen::Matrix<double, N, 1>::Zero();
  for (size_t i = 0; i < p.size(); ++i) {
    const M proj = M::Identity() - n[i] * n[i].transpose();
    a += proj;
    b += proj * p[i];
  }
  if (p.size() < 6) return false;
  Eigen::SelfAdjointEigenSolver<M> es(a);
  // Lines spread over at least ~6° in every direction of the space they span (a shallow arc
  // is still a start; the sagitta and plane checks judge the result).
  if (!(es.eigenvalues()[0] > 0.01 * double(p.size()))) return false;
  c = a.ldlt().solve(b);
  return c.allFinite();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// The cylinder of axis direction `d` through the points: its cross-section circle, started
/// from `warm` or else where the in-plane normals of the points facing across the axis meet.
Circle cylinderAlong(const std::vector<SurfacePoint>& pts, const V3& d, double band, double maxRadius, int rounds,
                     const Circle* warm = nullptr) {
  V3 u, v;
  basisAcross(d, u, v);
  std::vector<V2> q(pts.size()), m(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    q[i] = {pts[i].p.dot(u), pts[i].p.dot(v)};
    m[i] = {pts[i].n.dot(u), pts[i].n.dot(v)};
  }
  V2 c0;
  double r0;
  if (warm) {
    c0 = warm->c, r0 = warm->r;
  } else {
    std::vector<V2> lp, ln;
    for (size_t i = 0; i < pts.size(); ++i) {
      if (m[i].norm() < std::cos(25 * kDeg)) continue;  // a facet across the axis, not its wall
      lp.push_back(q[i]);
      ln.push_back(m[i].normalized());
    }
    if (!nearestToLines<2>(lp, ln, c0)) return {};
    std::vector<double> r;
    for (const V2& x : lp) r.push_back((x - c0).norm());
    r0 = median(r);
  }
  if (!(r0 <= maxRadius)) return {};
  Circle c = fitRound<2>(q, m, c0, r0, band, rounds);
  if (c.ok && c.r > maxRadius) c = {};  // a flat patch: no hinge
  return c;
}

/// MSAC cost of the best plane through one side (its mean normal, the median offset along it):
/// the curved models must do clearly better, or the contact is flat (no hinge, no ball).
double planeCost(const std::vector<SurfacePoint>& side, double band) {
  V3 n = V3::Zero();
  for (const SurfacePoint& q : side) n += q.n;
  if (!(n.norm() > 1e-9)) return band * band;
  n.normalize();
  std::vector<double> o;
  for (const SurfacePoint& q : side) o.push_back(q.p.dot(n));
  const double off = median(o);
  double cost = 0;
  for (const SurfacePoint& q : side) {
    const double e = q.p.dot(n) - off;
    cost += e * e < band * band && std::abs(q.n.dot(n)) >= kFacing ? e * e : band * band;
  }
  return cost / double(side.size());
}

/// Both bones' surfaces (parent, child), centred on one common origin.
using Sides = std::array<std::vector<SurfacePoint>, 2>;

/// A hinge's two articular surfaces share its axis: one direction, a cross-section circle per
/// side (each its own centre and radius: cartilage and the joint space part them).
struct Cylinder {
  V3 d{1, 0, 0};
  std::array<Circle, 2> circle;
  double cost = kInf;  // the MSAC cost pooled over both sides' points
  double inliers = 0, rms = 0;
};

/// `flat`: each side's plane cost. A side costs at most that, so a nearly flat side (a tibial
/// plateau that some wide circle fits within the band) cannot steer the axis: the curved side
/// does.
Cylinder cylinderOf(const Sides& sides, const std::array<double, 2>& flat, const V3& d, double band,
                    double maxRadius, int rounds, const Cylinder* warm = nullptr, const V3* warmD = nullptr) {
  Cylinder c;
  c.d = d;
  double cost = 0, inl = 0, sq = 0, n = 0;
  for (int s = 0; s < 2; ++s) {
    if (sides[s].empty()) continue;
    Circle w;
    if (warm && warm->circle[s].ok) {  // the same circle in the turned plane's basis
      V3 u, v, eu, ev;
      basisAcross(*warmD, u, v);
      basisAcross(d, eu, ev);
      const V3 centre = warm->circle[s].c.x() * u + warm->circle[s].c.y() * v;
      w = warm->circle[s];
      w.c = {centre.dot(eu), centre.dot(ev)};
    }
    c.circle[s] = cylinderAlong(sides[s], d, band, maxRadius, rounds, w.ok ? &w : nullptr);
    const double m = double(sides[s].size());
    n += m;
    if (c.circle[s].ok) {
      cost += std::min(c.circle[s].cost, flat[s]) * m;
      inl += c.circle[s].inliers * m;
      sq += c.circle[s].rms * c.circle[s].rms * c.circle[s].inliers * m;
    } else {
      cost += flat[s] * m;
    }
  }
  c.cost = cost / n;
  c.inliers = inl / n;
  c.rms = inl > 0 ? std::sqrt(sq / inl) : 0;
  return c;
}

/// Robust cylinder: the normals vote for the axis (directions on a Fibonacci hemisphere, ~3°
/// apart, scored by how many normals lie within 20° of perpendicular to them); from the best
/// few distinct directions a pattern search (3° down to 0.02°) on the pooled MSAC cost.
Cylinder fitCylinder(const Sides& sides, double band, double maxRadius) {
  std::array<double, 2> flat{band * band, band * band};
  for (int s = 0; s < 2; ++s)
    if (!sides[s].empty()) flat[s] = planeCost(sides[s], band);
  std::vector<SurfacePoint> all = sides[0];
  all.insert(all.end(), sides[1].begin(), sides[1].end());
  const std::vector<SurfacePoint> coarse = thinned(all, 3000);
  constexpr int kDirections = 2000;
  const double s2 = std::pow(std::sin(20 * kDeg), 2);
  std::vector<std::pair<double, V3>> scored;
  scored.reserve(kDirections);
  for (const V3& d : axis::hemisphereDirections(kDirections)) {
    double vote = 0;
    for (const SurfacePoint& s : coarse) vote += std::max(0.0, 1 - std::pow(s.n.dot(d), 2) / s2);
    scored.push_back({-vote, d});
  }
  // Starts: the best distinct directions by the vote, and by the MSAC cost itself on a coarser
  // hemisphere (~6° apart): big flat facets (malleoli) can outvote a short hinge's wall.
  const Sides few = {thinned(sides[0], 1000), thinned(sides[1], 1000)};
  constexpr int kCostDirections = 400;
  std::vector<std::pair<double, V3>> costed;
  for (const V3& d : axis::hemisphereDirections(kCostDirections))
    costed.push_back({cylinderOf(few, flat, d, band, maxRadius, 3).cost, d});
  std::vector<V3> starts;
  for (auto* list : {&scored, &costed}) {
    std::sort(list->begin(), list->end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    int taken = 0;
    for (const auto& [score, d] : *list) {
      if (taken >= 3) break;
      bool distinct = true;
      for (const V3& s : starts) distinct = distinct && std::abs(s.dot(d)) < std::cos(15 * kDeg);
      if (distinct) starts.push_back(d), ++taken;
    }
  }
  const Sides fine = {thinned(sides[0], 10000), thinned(sides[1], 10000)};
  Cylinder best;
  for (V3 d : starts) {
    Cylinder c = cylinderOf(fine, flat, d, band, maxRadius, 4);
    if (!(c.circle[0].ok || c.circle[1].ok)) continue;
    for (double step = 3 * kDeg; step > 0.02 * kDeg;) {
      V3 u, v;
      basisAcross(d, u, v);
      bool moved = false;
      for (const V3& t : {u, V3(-u), v, V3(-v)}) {
        const V3 e = (d + std::tan(step) * t).normalized();
        const Cylinder ce = cylinderOf(fine, flat, e, band, maxRadius, 2, &c, &d);
        if (ce.cost < c.cost - 1e-12) {
          c = ce, d = e, moved = true;
          break;
        }
      }
      if (!moved) step /= 2;
    }
    if (c.cost < best.cost) best = c;
  }
  return best;
}

/// Robust sphere: started where the normals meet, then MSAC Gauss-Newton rounds.
Sphere fitSphere(const std::vector<SurfacePoint>& pts, double band, double maxRadius) {
  std::vector<V3> lp, ln;
  for (const SurfacePoint& s : pts) lp.push_back(s.p), ln.push_back(s.n);
  V3 c;
  if (!nearestToLines<3>(lp, ln, c)) return {};
  std::vector<double> rs;
  for (const V3& x : lp) rs.push_back((x - c).norm());
  double r = median(rs);
  if (!(r <= maxRadius)) return {};
  return fitRound<3>(lp, ln, c, r, band, 4, maxRadius);
}

std::string fmt(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

/// What a fitted circle's inliers on one side look like: the arc they span about the axis,
/// their length along it, and whether the surface bulges away from the axis (convex: its
/// outward normals point away from the axis, the talar dome) or wraps it (concave: the plafond).
struct CircleShape {
  double arcDeg = 0, lengthMm = 0;
  bool convex = false;
};

CircleShape shapeOf(const std::vector<SurfacePoint>& side, const Circle& c, const V3& axis, double band) {
  V3 u, v;
  basisAcross(axis, u, v);
  std::vector<double> ang, along;
  int outward = 0;
  for (const SurfacePoint& q : side) {
    const V2 d = V2{q.p.dot(u), q.p.dot(v)} - c.c, m{q.n.dot(u), q.n.dot(v)};
    if (!inlier<V2>(d, m, d.norm() - c.r, band * band)) continue;
    ang.push_back(std::atan2(d.y(), d.x()));
    along.push_back(q.p.dot(axis));
    outward += m.dot(d) > 0;
  }
  CircleShape out;
  if (ang.empty()) return out;
  std::sort(ang.begin(), ang.end());  // the arc: 360° minus the largest empty gap
  double gap = ang.front() + 2 * std::numbers::pi - ang.back();
  for (size_t i = 1; i < ang.size(); ++i) gap = std::max(gap, ang[i] - ang[i - 1]);
  out.arcDeg = 360.0 - gap / kDeg;
  std::sort(along.begin(), along.end());  // the 5–95 % span: a stray voxel does not lengthen it
  out.lengthMm = along[along.size() * 95 / 100] - along[along.size() * 5 / 100];
  out.convex = 2 * outward > int(ang.size());
  return out;
}

/// Why a hinge fit is not a joint's axis, though curved surfaces fit it: an articular surface is
/// a wide roller (its radius comparable to its length along the axis: the talar dome's ~20 mm
/// over ~30 mm), not a thin edge (a bone's lip or rim that touches a neighbour: a few mm of
/// radius along a long line); the two sides of one hinge nest (one convex, one concave) about
/// one axis. `main`: the side whose circle gives the axis.
std::vector<std::string> hingeRefusals(const Cylinder& cyl, const bool counts[2], const CircleShape shape[2], int main,
                                       double axisGapMm) {
  std::vector<std::string> why;
  const char* sideName[2] = {"parent", "child"};
  const double r = cyl.circle[main].r;
  if (r < 0.2 * shape[main].lengthMm)
    why.push_back(std::string("the ") + sideName[main] + "'s surface is an edge, not a joint surface: radius " + fmt(r, 1) +
                  " mm along " + fmt(shape[main].lengthMm, 0) + " mm of axis");
  if (counts[0] && counts[1]) {
    if (shape[0].convex == shape[1].convex)
      why.push_back(std::string("the two surfaces do not nest (both ") + (shape[0].convex ? "convex" : "concave") + ")");
    if (axisGapMm > 0.5 * std::min(cyl.circle[0].r, cyl.circle[1].r))
      why.push_back("the two surfaces' axes lie " + fmt(axisGapMm, 1) + " mm apart (more than half a radius: not one hinge)");
  }
  return why;
}

Vec3 toVec(const V3& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

AxisEstimate fitArticularSurfaces(const std::vector<Vec3>& parentMm, const std::vector<Vec3>& parentNormals,
                                   const std::vector<Vec3>& childMm, const std::vector<Vec3>& childNormals,
                                   double bandMm) {
  AxisEstimate out;
  const std::vector<Vec3>* pts[2] = {&parentMm, &childMm};
  const std::vector<Vec3>* nrm[2] = {&parentNormals, &childNormals};
  out.fit.surfacePoints = static_cast<int64_t>(parentMm.size() + childMm.size());
  // Centred on one origin (numerics; the sides' circles stay comparable), and the patch's
  // extent: a hinge's surface of radius r spans a chord of r or more (an arc of 60° or more),
  // so a fitted radius beyond 1.5 patch widths is a flat patch, not a hinge.
  V3 mean = V3::Zero();
  for (int s = 0; s < 2; ++s)
    for (const Vec3& q : *pts[s]) mean += V3{q.x, q.y, q.z};
  if (out.fit.surfacePoints < 30) return out;  // too few to fit anything
  mean /= double(out.fit.surfacePoints);
  Sides sides;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int s = 0; s < 2; ++s)
    for (size_t i = 0; i < pts[s]->size(); ++i) {
      const Vec3& q = (*pts[s])[i];
      const V3 n{(*nrm[s])[i].x, (*nrm[s])[i].y, (*nrm[s])[i].z};
      if (!(n.norm() > 0.5)) continue;  // no clear outward direction (a one-voxel sliver)
      sides[s].push_back({V3{q.x, q.y, q.z} - mean, n.normalized()});
      cov += sides[s].back().p * sides[s].back().p.transpose();
    }
  for (auto& side : sides)
    if (side.size() < 30) side.clear();  // too few to be a surface
  const double n = double(sides[0].size() + sides[1].size());
  if (n < 30) return out;
  cov /= n;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const V3 widest = es.eigenvectors().col(2);
  const double extent = 4 * std::sqrt(std::max(es.eigenvalues()[2], 0.0));  // ~ the patch's width
  const double maxRadius = 1.5 * extent;

  const Cylinder cyl = fitCylinder(sides, bandMm, maxRadius);
  // Sphere: each side its own, pooled like the cylinder.
  Sphere sph[2];
  double sphCost = 0;
  for (int s = 0; s < 2; ++s) {
    if (sides[s].empty()) continue;
    sph[s] = fitSphere(thinned(sides[s], 10000), bandMm, maxRadius);
    sphCost += (sph[s].ok ? sph[s].cost : bandMm * bandMm) * double(sides[s].size());
  }
  sphCost /= n;

  // Each side is judged on its own: a hinge often has one curved surface against a nearly flat
  // one (the femoral condyles on the tibial plateau). A side's cylinder counts when a good
  // share of its voxels lie on it (30 %), over an arc of 30° or more whose sagitta (how far the
  // arc bows from its chord) is at least two bands, and clearly better than a plane (cost
  // under 0.7 x the plane's): a flat face that a wide circle fits within the band is no hinge.
  V3 u, v;
  basisAcross(cyl.d, u, v);
  bool cylSide[2] = {false, false}, sphSide[2] = {false, false};
  double arcs[2] = {0, 0}, flats[2] = {bandMm * bandMm, bandMm * bandMm};
  CircleShape shape[2];
  for (int s = 0; s < 2; ++s) {
    if (sides[s].empty()) continue;
    flats[s] = planeCost(sides[s], bandMm);
    const Circle& c = cyl.circle[s];
    if (c.ok) {
      shape[s] = shapeOf(sides[s], c, cyl.d, bandMm);
      arcs[s] = shape[s].arcDeg;
      const double sagitta = c.r * (1 - std::cos(std::min(arcs[s], 180.0) * kDeg / 2));
      cylSide[s] = c.inliers >= 0.3 && arcs[s] >= 30 && sagitta >= 2 * bandMm && c.cost < 0.7 * flats[s];
    }
    sphSide[s] = sph[s].ok && sph[s].inliers >= 0.3 && sph[s].cost < 0.7 * flats[s];
  }
  const bool cylOk = cylSide[0] || cylSide[1], sphOk = sphSide[0] || sphSide[1];
  // Over the sides that count: the share of their voxels on the model, and its RMS.
  const auto pooled = [&](const bool ok[2], auto inl, auto rms, double& fraction, double& rmsOut) {
    double m = 0, in = 0, sq = 0;
    for (int s = 0; s < 2; ++s)
      if (ok[s]) {
        const double k = double(sides[s].size());
        m += k, in += inl(s) * k, sq += rms(s) * rms(s) * inl(s) * k;
      }
    fraction = m > 0 ? in / m : 0;
    rmsOut = in > 0 ? std::sqrt(sq / in) : 0;
  };
  const auto surfaceName = [](const bool ok[2]) { return ok[0] && ok[1] ? "both" : ok[1] ? "child" : "parent"; };
  if (sphOk && (!cylOk || sphCost < 0.8 * cyl.cost)) {  // clearly a ball
    const int sm = sphSide[1] ? 1 : 0;
    out.fit.method = "sphere";
    out.fit.surface = surfaceName(sphSide);
    out.point = toVec(sph[sm].c + mean);
    out.direction = toVec(widest);
    out.fit.radiusMm = sph[sm].r;
    pooled(sphSide, [&](int s) { return sph[s].inliers; }, [&](int s) { return sph[s].rms; }, out.fit.inlierFraction,
           out.fit.rmsMm);
    if (sphSide[0] && sphSide[1]) out.fit.axisGapMm = (sph[0].c - sph[1].c).norm();
    out.fit.confidence = sph[sm].inliers * std::clamp(2 * (1 - sph[sm].cost / flats[sm]), 0.0, 1.0);
  } else if (cylOk) {
    const int main = cylSide[1] ? 1 : 0;  // the child's, if it counts
    out.fit.method = "cylinder";
    out.fit.surface = surfaceName(cylSide);
    const Circle& c = cyl.circle[main];
    // The axis point nearest the surfaces' centroid (the origin here).
    out.point = toVec(c.c.x() * u + c.c.y() * v + mean);
    out.direction = toVec(cyl.d);
    out.fit.radiusMm = c.r;
    pooled(cylSide, [&](int s) { return cyl.circle[s].inliers; }, [&](int s) { return cyl.circle[s].rms; },
           out.fit.inlierFraction, out.fit.rmsMm);
    out.fit.arcDeg = std::max(cylSide[0] ? arcs[0] : 0.0, cylSide[1] ? arcs[1] : 0.0);
    if (cylSide[0] && cylSide[1]) out.fit.axisGapMm = (cyl.circle[0].c - cyl.circle[1].c).norm();
    out.fit.refusals = hingeRefusals(cyl, cylSide, shape, main, out.fit.axisGapMm);
    out.fit.confidence = std::min(1.0, arcs[main] / 90) * c.inliers * std::clamp(2 * (1 - c.cost / flats[main]), 0.0, 1.0);
  } else {
    return out;
  }
  if (!out.fit.refusals.empty()) {  // estimateAxes() falls back, and says why
    out.fit.method.clear();
    out.fit.confidence = 0;
    return out;
  }
  if (out.fit.inlierFraction < 0.5)
    out.fit.warning = "only " + fmt(100 * out.fit.inlierFraction, 0) + " % of the " +
                      std::to_string(out.fit.surfacePoints) + " contact surface voxels lie on the fitted " +
                      out.fit.method + " (within " + fmt(bandMm, 1) + " mm, facing along it): check the axis, or give it as two points";
  else if (out.fit.axisGapMm > 3)
    out.fit.warning = "the parent's and the child's surfaces do not share an axis (" + fmt(out.fit.axisGapMm, 1) +
                      " mm apart): check the axis, or give it as two points";
  else if (out.fit.method == "cylinder" && out.fit.arcDeg < 45)
    out.fit.warning = "the fitted surfaces span only " + fmt(out.fit.arcDeg, 0) + " deg about the axis (a shallow hinge: check the axis)";
  return out;
}

}  // namespace vellum::deformation
