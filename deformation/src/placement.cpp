#include "vellum/deformation/placement.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>

#include "vellum/core/error.hpp"

namespace vellum::deformation {

ControlPoints boxControlPoints(const Geometry& g, int count, double inset) {
  if (count < 1) throw Error("control-point count must be >= 1");
  if (!(inset >= 0 && inset < 0.5)) throw Error("inset fraction must be in [0, 0.5)");
  const Vec3 ext = g.extent();
  const double gm = std::cbrt(std::max(ext.x, 1e-9) * std::max(ext.y, 1e-9) * std::max(ext.z, 1e-9));
  const double c3 = std::cbrt(static_cast<double>(count));
  int best[3] = {count, 1, 1};
  double bestErr = 1e300;
  for (int a = 1; a <= count; ++a)
    for (int b = 1; a * b <= count; ++b) {
      if (count % (a * b)) continue;
      const int c = count / (a * b);
      const int n[3] = {a, b, c};
      double err = 0;
      for (int i = 0; i < 3; ++i) {
        const double ideal = c3 * std::max(ext[i], 1e-9) / gm;
        err += (n[i] - ideal) * (n[i] - ideal);
      }
      if (err < bestErr - 1e-12) { bestErr = err; best[0] = a; best[1] = b; best[2] = c; }
    }
  ControlPoints pts;
  auto frac = [&](int i, int n) { return n == 1 ? 0.5 : inset + (1 - 2 * inset) * i / (n - 1.0); };
  for (int k = 0; k < best[2]; ++k)
    for (int j = 0; j < best[1]; ++j)
      for (int i = 0; i < best[0]; ++i) {
        const Vec3 idx{frac(i, best[0]) * double(g.dims.x - 1), frac(j, best[1]) * double(g.dims.y - 1),
                       frac(k, best[2]) * double(g.dims.z - 1)};
        const Vec3 p = g.indexToPhysical(idx);
        pts.push_back({p, p, {}});
      }
  return pts;
}

ControlPoints labelControlPoints(const LabelVolume& labels, double inset) {
  const Geometry& g = labels.geometry();
  struct Acc {
    double n = 0;
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    Eigen::Matrix3d ss = Eigen::Matrix3d::Zero();
  };
  std::map<uint16_t, Acc> acc;
  const Dims d = g.dims;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const uint16_t id = labels(i, j, k);
        if (id == 0) continue;
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        const Eigen::Vector3d v(p.x, p.y, p.z);
        auto& a = acc[id];
        a.n += 1; a.s += v; a.ss += v * v.transpose();
      }
  ControlPoints pts;
  for (int c = 0; c < 8; ++c) {
    const Vec3 idx{((c & 1) ? 1 - inset : inset) * double(d.x - 1),
                   ((c & 2) ? 1 - inset : inset) * double(d.y - 1),
                   ((c & 4) ? 1 - inset : inset) * double(d.z - 1)};
    const Vec3 p = g.indexToPhysical(idx);
    pts.push_back({p, p, {}});
  }
  for (const auto& [id, a] : acc) {
    if (a.n < 8) continue;
    const Eigen::Vector3d mean = a.s / a.n;
    const Eigen::Matrix3d cov = a.ss / a.n - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    const Eigen::Vector3d axis = es.eigenvectors().col(2);
    const Vec3 c{mean.x(), mean.y(), mean.z()};
    pts.push_back({c, c, {}});
    // Walk from the centroid along the main axis to the last voxel of the label: surface points.
    const Vec3 ax{axis.x(), axis.y(), axis.z()};
    const double stepMm = std::min({g.spacing.x, g.spacing.y, g.spacing.z}) * 0.5;
    const double reach = 2.5 * std::sqrt(std::max(es.eigenvalues()(2), 0.0)) + 4 * stepMm;
    for (double sgn : {-1.0, 1.0}) {
      Vec3 last = c;
      bool found = false;
      for (double t = 0; t <= reach; t += stepMm) {
        const Vec3 p = c + ax * (sgn * t);
        const Vec3 idx = g.physicalToIndex(p);
        const auto v = labels.ids().sampleNearest(idx);
        if (static_cast<uint16_t>(v) == id) { last = p; found = true; }
      }
      if (found && norm(last - c) > stepMm) pts.push_back({last, last, {}});
    }
  }
  return pts;
}

KeyframeTrack kneeBendTrack(const Geometry& g, double angleDeg, double seconds) {
  const ControlPoints rest = boxControlPoints(g, 16, 0.1);
  const Vec3 centre = g.center();
  // Medio-lateral axis: the volume's first index axis (x, patient left in LPS).
  const Vec3 axis = normalized(g.direction.column(0));
  const Vec3 up = normalized(g.direction.column(2));
  auto bend = [&](double deg) {
    ControlPoints pts = rest;
    for (auto& p : pts) {
      const Vec3 r = p.source - centre;
      const double side = dot(r, up) >= 0 ? 1.0 : -1.0;  // above or below the knee
      const double a = side * deg * 0.5 * 3.14159265358979323846 / 180.0;
      // Rodrigues rotation of r about `axis` by a.
      const Vec3 rot = r * std::cos(a) + cross(axis, r) * std::sin(a) + axis * (dot(axis, r) * (1 - std::cos(a)));
      p.target = centre + rot;
    }
    return pts;
  };
  KeyframeTrack t;
  t.interpolation = Interpolation::Smooth;
  t.loop = true;
  const double seg = seconds / 3.0;
  t.keyframes = {{seg, rest}, {seg, bend(angleDeg)}, {seg, bend(-0.5 * angleDeg)}};
  return t;
}

}  // namespace vellum::deformation
