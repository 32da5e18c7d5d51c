#include "vellum/deformation/placement.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "vellum/core/components.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/rotation.hpp"

namespace vellum::deformation {

ControlPoints boxControlPoints(const Geometry& g, int count, double inset) {
  if (count < 1) throw Error("control-point count must be >= 1");
  if (count > 100000) throw Error("control-point count must be <= 100000");
  if (!(inset >= 0 && inset < 0.5)) throw Error("inset fraction must be in [0, 0.5)");
  // Positions as fractions of the inset box per axis (0 = low face, 1 = high face).
  std::vector<Vec3> f;
  const Vec3 ext = g.extent();
  // Axes from longest to shortest extent (ties: x before y before z): extra points go to the
  // longest edges and to the faces across the longest axis first.
  int order[3] = {0, 1, 2};
  std::stable_sort(order, order + 3, [&](int a, int b) { return ext[a] > ext[b] + 1e-9; });
  auto corner = [](int c) { return Vec3{double(c & 1), double((c >> 1) & 1), double((c >> 2) & 1)}; };
  if (count == 1) {
    f.push_back({0.5, 0.5, 0.5});
  } else if (count < 8) {
    // Well-spread corners: two opposite ones, then the rest of a regular tetrahedron, then the
    // other tetrahedron's.
    const int pick[8] = {0, 7, 3, 5, 6, 1, 2, 4};
    for (int t = 0; t < count; ++t) f.push_back(corner(pick[t]));
  } else {
    for (int c = 0; c < 8; ++c) f.push_back(corner(c));
    // The rest on the 12 edges: whole groups of 4 parallel edges (keeps the layout symmetric),
    // apportioned to the axes by edge length (largest remainder), evenly spaced along each
    // edge (1 per edge: the midpoints).
    const int groups = (count - 8) / 4;
    int per[3] = {0, 0, 0};
    const double total = std::max(ext.x + ext.y + ext.z, 1e-9);
    int given = 0;
    double rem[3];
    for (int a = 0; a < 3; ++a) {
      const double want = groups * ext[a] / total;
      per[a] = static_cast<int>(std::floor(want));
      rem[a] = want - per[a];
      given += per[a];
    }
    while (given < groups) {
      int best = order[0];
      for (int t = 0; t < 3; ++t)
        if (rem[order[t]] > rem[best] + 1e-12) best = order[t];
      ++per[best];
      rem[best] = -1;
      ++given;
    }
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      for (int e = 0; e < 4; ++e)
        for (int q = 1; q <= per[a]; ++q) {
          Vec3 p;
          p[a] = double(q) / (per[a] + 1);
          p[b] = double(e & 1);
          p[c] = double(e >> 1);
          f.push_back(p);
        }
    }
    // 1-3 left over: centres of the faces across the longest axis, then the next one.
    const int left = (count - 8) % 4;
    for (int t = 0; t < left; ++t) {
      Vec3 p{0.5, 0.5, 0.5};
      p[order[t / 2]] = double(t % 2);
      f.push_back(p);
    }
  }
  ControlPoints pts;
  for (const Vec3& q : f) {
    Vec3 idx;
    for (int a = 0; a < 3; ++a) idx[a] = (inset + (1 - 2 * inset) * q[a]) * double(g.dims[a] - 1);
    const Vec3 p = g.indexToPhysical(idx);
    pts.push_back({p, p, {}});
  }
  return pts;
}

namespace {

// Voxel count and first and second moments of the voxel positions (mm) of one component.
struct Moments {
  double n = 0;
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  Eigen::Matrix3d ss = Eigen::Matrix3d::Zero();
};

// Moments per component (index label - 1), from one scan in index order.
std::vector<Moments> componentMoments(const Components& parts, const Geometry& g) {
  const Dims d = g.dims;
  std::vector<Moments> acc(static_cast<size_t>(parts.count()));
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const uint32_t l = parts.labels[static_cast<size_t>((k * d.y + j) * d.x + i)];
        if (l == 0) continue;
        const Vec3 pm = g.indexToPhysical({double(i), double(j), double(k)});
        const Eigen::Vector3d v(pm.x, pm.y, pm.z);
        Moments& a = acc[l - 1];
        a.n += 1; a.s += v; a.ss += v * v.transpose();
      }
  return acc;
}

}  // namespace

ControlPoints labelControlPoints(const LabelVolume& labels, double inset) {
  if (!(inset >= 0 && inset < 0.5)) throw Error("inset fraction must be in [0, 0.5)");
  const Geometry& g = labels.geometry();
  const Dims d = g.dims;
  // Per 26-connected component of each label (one label can hold several separate parts,
  // e.g. the phantom's cancellous cores, 11, of both the fibula and the patella): a centroid
  // between two parts would lie in neither.
  const Components parts = connectedRegions(labels.ids(), Connectivity::Vertex26);
  const std::vector<Moments> acc = componentMoments(parts, g);
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
    const Moments& a = acc[ci];
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
    const double stepMm = g.minSpacing() * 0.5;
    const double reach = 2.5 * std::sqrt(std::max(es.eigenvalues()(2), 0.0)) + 4 * stepMm;
    for (double sgn : {-1.0, 1.0}) {
      Vec3 last = c;
      bool found = false;
      for (double t = 0; t <= reach; t += stepMm) {
        const Vec3 p = c + ax * (sgn * t);
        const Vec3 idx = g.physicalToIndex(p);
        const int64_t i = std::llround(idx.x), j = std::llround(idx.y), k = std::llround(idx.z);
        if (i < 0 || j < 0 || k < 0 || i >= d.x || j >= d.y || k >= d.z) continue;
        if (parts.labels[static_cast<size_t>((k * d.y + j) * d.x + i)] == ci + 1) {
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
      p.target = pivot + rotateAbout(r, axis, a);  // +a moves the foot posteriorly, +y
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
