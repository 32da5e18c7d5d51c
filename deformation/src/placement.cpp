#include "vellum/deformation/placement.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"

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
  if (!(inset >= 0 && inset < 0.5)) throw Error("inset fraction must be in [0, 0.5)");
  const Geometry& g = labels.geometry();
  const Dims d = g.dims;
  // Per 26-connected component of each label (one label can hold several separate parts,
  // e.g. the phantom's cancellous cores, 11, of both the fibula and the patella): a centroid
  // between two parts would lie in neither.
  checkMemoryBudget(d, sizeof(int32_t), "label components");
  std::vector<int32_t> comp(static_cast<size_t>(d.voxelCount()), -1);
  struct Acc {
    uint16_t id = 0;
    double n = 0;
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    Eigen::Matrix3d ss = Eigen::Matrix3d::Zero();
  };
  std::vector<Acc> acc;
  std::vector<int64_t> queue;
  const int64_t nx = d.x, nxy = d.x * d.y, total = d.voxelCount();
  const uint16_t* ids = labels.ids().data();
  for (int64_t start = 0; start < total; ++start) {
    const uint16_t id = ids[start];
    if (id == 0 || comp[static_cast<size_t>(start)] >= 0) continue;
    const int32_t c = static_cast<int32_t>(acc.size());
    Acc a;
    a.id = id;
    queue.assign(1, start);
    comp[static_cast<size_t>(start)] = c;
    for (size_t h = 0; h < queue.size(); ++h) {
      const int64_t p = queue[h];
      const int64_t i = p % nx, j = (p / nx) % d.y, k = p / nxy;
      const Vec3 pm = g.indexToPhysical({double(i), double(j), double(k)});
      const Eigen::Vector3d v(pm.x, pm.y, pm.z);
      a.n += 1; a.s += v; a.ss += v * v.transpose();
      for (int64_t dk = -1; dk <= 1; ++dk) {
        if (k + dk < 0 || k + dk >= d.z) continue;
        for (int64_t dj = -1; dj <= 1; ++dj) {
          if (j + dj < 0 || j + dj >= d.y) continue;
          for (int64_t di = -1; di <= 1; ++di) {
            if (i + di < 0 || i + di >= d.x) continue;
            const int64_t q = p + dk * nxy + dj * nx + di;
            if (ids[q] == id && comp[static_cast<size_t>(q)] < 0) {
              comp[static_cast<size_t>(q)] = c;
              queue.push_back(q);
            }
          }
        }
      }
    }
    acc.push_back(a);
  }
  ControlPoints pts;
  // Two points closer than a voxel (a core's centroid on its shell's) would be redundant.
  const double minGap = std::max({g.spacing.x, g.spacing.y, g.spacing.z});
  auto add = [&](const Vec3& p) {
    for (const auto& q : pts)
      if (norm(q.source - p) < minGap) return;
    pts.push_back({p, p, {}});
  };
  for (int c = 0; c < 8; ++c) {
    const Vec3 idx{((c & 1) ? 1 - inset : inset) * double(d.x - 1),
                   ((c & 2) ? 1 - inset : inset) * double(d.y - 1),
                   ((c & 4) ? 1 - inset : inset) * double(d.z - 1)};
    add(g.indexToPhysical(idx));
  }
  for (size_t ci = 0; ci < acc.size(); ++ci) {
    const Acc& a = acc[ci];
    if (a.n < 8) continue;
    const Eigen::Vector3d mean = a.s / a.n;
    const Eigen::Matrix3d cov = a.ss / a.n - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    const Eigen::Vector3d axis = es.eigenvectors().col(2);
    const Vec3 c{mean.x(), mean.y(), mean.z()};
    add(c);
    // Walk from the centroid along the main axis to the last voxel of the component: surface
    // points.
    const Vec3 ax{axis.x(), axis.y(), axis.z()};
    const double stepMm = std::min({g.spacing.x, g.spacing.y, g.spacing.z}) * 0.5;
    const double reach = 2.5 * std::sqrt(std::max(es.eigenvalues()(2), 0.0)) + 4 * stepMm;
    for (double sgn : {-1.0, 1.0}) {
      Vec3 last = c;
      bool found = false;
      for (double t = 0; t <= reach; t += stepMm) {
        const Vec3 p = c + ax * (sgn * t);
        const Vec3 idx = g.physicalToIndex(p);
        const int64_t i = std::llround(idx.x), j = std::llround(idx.y), k = std::llround(idx.z);
        if (i < 0 || j < 0 || k < 0 || i >= d.x || j >= d.y || k >= d.z) continue;
        if (comp[static_cast<size_t>((k * d.y + j) * d.x + i)] == static_cast<int32_t>(ci)) {
          last = p;
          found = true;
        }
      }
      if (found && norm(last - c) > stepMm) add(last);
    }
  }
  return pts;
}

KeyframeTrack kneeBendTrack(const Geometry& g, double angleDeg, double seconds,
                            std::optional<Vec3> pivotMm) {
  const ControlPoints rest = boxControlPoints(g, 16, 0.1);
  const Vec3 pivot = pivotMm ? *pivotMm : g.center();
  // Flexion axis: the volume's first index axis (x, medio-lateral in LPS) through the pivot.
  const Vec3 axis = normalized(g.direction.column(0));
  const Vec3 up = normalized(g.direction.column(2));
  auto bend = [&](double deg) {
    ControlPoints pts = rest;
    for (auto& p : pts) {
      const Vec3 r = p.source - pivot;
      if (dot(r, up) >= 0) continue;  // the thigh stays; the calf swings about the joint
      const double a = deg * 3.14159265358979323846 / 180.0;
      // Rodrigues rotation of r about `axis` by a (+a moves the foot posteriorly, +y).
      const Vec3 rot = r * std::cos(a) + cross(axis, r) * std::sin(a) + axis * (dot(axis, r) * (1 - std::cos(a)));
      p.target = pivot + rot;
    }
    return pts;
  };
  KeyframeTrack t;
  t.interpolation = Interpolation::Smooth;
  t.loop = true;
  const double seg = seconds / 3.0;
  t.keyframes = {{seg, rest}, {seg, bend(angleDeg)}, {seg, bend(0.5 * angleDeg)}};
  return t;
}

}  // namespace vellum::deformation
