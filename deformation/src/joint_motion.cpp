// The motion search of a hinge's axis (joint_motion.hpp): contact voxels turned about a
// candidate axis, their signed distance to the other bone looked up before and after.
#include "vellum/deformation/joint_motion.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>
#include <numbers>
#include <tuple>

#include "axis_geometry.hpp"
#include "vellum/core/cropped_geometry.hpp"
#include "vellum/core/distance_transform.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::deformation {
namespace {

using V3 = Eigen::Vector3d;
constexpr double kDeg = std::numbers::pi / 180.0;
V3 eig(const Vec3& v) { return {v.x, v.y, v.z}; }
Vec3 vec(const V3& v) { return {v.x(), v.y(), v.z()}; }

/// The voxel box (clipped to the grid) holding every point of `pts` grown by `marginMm`.
VoxelBox boxAround(const Geometry& g, const std::vector<Vec3>& pts, double marginMm) {
  const Geometry::ToIndex toIndex = g.physicalToIndexMap();
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3& p : pts) {
    const Vec3 q = toIndex(p);
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], q[a]), hi[a] = std::max(hi[a], q[a]);
  }
  VoxelBox box;
  const int64_t dims[3] = {g.dims.x, g.dims.y, g.dims.z};
  for (int a = 0; a < 3; ++a) {
    const double m = marginMm / g.spacing[a];
    box.lo[a] = std::clamp<int64_t>(int64_t(std::floor(lo[a] - m)), 0, dims[a] - 1);
    box.hi[a] = std::clamp<int64_t>(int64_t(std::ceil(hi[a] + m)), 0, dims[a] - 1);
  }
  return box;
}

/// The distance fields' grid on `box`: every step-th voxel per axis, the step making the grid
/// no finer than kMinFieldSpacingMm (the score is a millimetre measure: a 0.35 mm scan need not
/// be matched) and no larger than kMaxFieldVoxels (a whole limb turning at a hip).
constexpr double kMinFieldSpacingMm = 0.7;
constexpr double kMaxFieldVoxels = 16e6;
Geometry fieldGrid(const Geometry& g, const VoxelBox& box, std::array<int64_t, 3>& step) {
  const Dims bd = box.dims();
  const int64_t n[3] = {bd.x, bd.y, bd.z};
  for (double h = kMinFieldSpacingMm;; h *= 1.25) {
    double count = 1;
    for (int a = 0; a < 3; ++a) {
      step[a] = std::max<int64_t>(1, int64_t(std::floor(h / g.spacing[a] + 1e-9)));
      count *= double((n[a] - 1) / step[a] + 1);
    }
    if (count <= kMaxFieldVoxels) break;
  }
  Geometry fg = croppedGeometry(g, box);
  fg.spacing = {g.spacing.x * double(step[0]), g.spacing.y * double(step[1]), g.spacing.z * double(step[2])};
  fg.dims = {(n[0] - 1) / step[0] + 1, (n[1] - 1) / step[1] + 1, (n[2] - 1) / step[2] + 1};
  return fg;
}

/// Signed distance (mm, negative inside) to the voxels whose id `in` marks, on `grid` (every
/// `step`-th voxel of the labels from the box's first).
VolumeF32 distanceTo(const LabelVolume& labels, const std::vector<uint8_t>& in, const VoxelBox& box,
                     const Geometry& grid, const std::array<int64_t, 3>& step, Progress& progress) {
  VolumeU8 mask(grid);
  const Dims d = grid.dims;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i)
          mask(i, j, k) = in[labels(box.lo[0] + i * step[0], box.lo[1] + j * step[1], box.lo[2] + k * step[2])];
  });
  // Cancellation is checked here, not inside the transform: that would begin and end its own
  // stage on the caller's progress (the studio's "joint axes" bar).
  progress.checkCancelled();
  return signedDistanceMm(mask);
}

/// A field's value at `mm`, the index clamped into the box: beyond it the contact has moved far
/// from the joint, and the clipped change says as much.
double fieldAt(const VolumeF32& f, const Geometry::ToIndex& toIndex, const Vec3& mm) {
  const Dims& d = f.geometry().dims;
  Vec3 q = toIndex(mm);
  q.x = std::clamp(q.x, 0.0, double(d.x - 1));
  q.y = std::clamp(q.y, 0.0, double(d.y - 1));
  q.z = std::clamp(q.z, 0.0, double(d.z - 1));
  return f.sampleLinear(q);
}

}  // namespace

std::array<VoxelBox, 2> axis::markedBoxes(const LabelVolume& labels, const std::vector<uint8_t>& table) {
  const Dims d = labels.geometry().dims;
  const VoxelBox none{{d.x, d.y, d.z}, {-1, -1, -1}};
  std::array<VoxelBox, 2> boxes{none, none};
  std::mutex m;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    std::array<VoxelBox, 2> b{none, none};
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i)
          if (const uint8_t t = table[labels(i, j, k)]; t == 1 || t == 2) {
            VoxelBox& x = b[t - 1];
            x.lo = {std::min(x.lo[0], i), std::min(x.lo[1], j), std::min(x.lo[2], k)};
            x.hi = {std::max(x.hi[0], i), std::max(x.hi[1], j), std::max(x.hi[2], k)};
          }
    std::lock_guard lock(m);
    for (int s = 0; s < 2; ++s)
      for (int a = 0; a < 3; ++a)
        boxes[s].lo[a] = std::min(boxes[s].lo[a], b[s].lo[a]), boxes[s].hi[a] = std::max(boxes[s].hi[a], b[s].hi[a]);
  });
  return boxes;
}

HingeMotion::HingeMotion(const LabelVolume& labels, const std::vector<uint16_t>& parentIds,
                         const std::vector<uint16_t>& movingIds,
                         std::vector<Vec3> parentContactMm, std::vector<Vec3> childContactMm,
                         std::vector<double> anglesDeg, double reachMm, Progress& progress) {
  const Geometry& g = labels.geometry();
  voxelMm_ = (g.spacing.x + g.spacing.y + g.spacing.z) / 3.0;
  contact_[0] = std::move(parentContactMm);
  contact_[1] = std::move(childContactMm);
  for (double a : anglesDeg)
    if (a != 0) angles_.push_back(a);
  std::vector<Vec3> all = contact_[0];
  all.insert(all.end(), contact_[1].begin(), contact_[1].end());
  if (all.empty() || angles_.empty()) return;
  double most = 0;
  for (double a : angles_) most = std::max(most, std::abs(a));
  const double chord = 2 * std::sin(std::min(most, 180.0) * kDeg / 2);  // travel per mm from the axis
  Vec3 centre{0, 0, 0};
  for (const Vec3& p : all) centre = centre + p;
  centre = centre * (1.0 / double(all.size()));
  centre_ = centre;
  // The box: every moving voxel and the contact, grown by the furthest travel (a voxel at D mm
  // from the axis moves D x chord; D <= its distance from the contact + the reach).
  std::vector<uint8_t> moving(65536, 0);
  for (uint16_t id : movingIds) moving[id] = 1;
  const VoxelBox mb = axis::markedBoxes(labels, moving)[0];
  const std::array<int64_t, 3>& lo = mb.lo, &hi = mb.hi;
  std::vector<Vec3> corners = all;
  double furthest = 0;
  if (hi[0] >= 0)
    for (int c = 0; c < 8; ++c) {
      const Vec3 q =
          g.indexToPhysical({double(c & 1 ? hi[0] : lo[0]), double(c & 2 ? hi[1] : lo[1]), double(c & 4 ? hi[2] : lo[2])});
      corners.push_back(q);
      furthest = std::max(furthest, norm(q - centre));
    }
  const double maxTravel = std::min((furthest + reachMm) * chord, 80.0);
  const VoxelBox box = boxAround(g, corners, maxTravel + 2 * voxelMm_);
  std::vector<uint8_t> parent(65536, 0);
  for (uint16_t id : parentIds) parent[id] = 1;
  std::array<int64_t, 3> step{};
  const Geometry grid = fieldGrid(g, box, step);
  field_[0] = distanceTo(labels, parent, box, grid, step, progress);
  field_[1] = distanceTo(labels, moving, box, grid, step, progress);
  const Geometry& fg = field_[0].geometry();
  const Geometry::ToIndex toIndex = fg.physicalToIndexMap();
  for (int s = 0; s < 2; ++s)
    for (const Vec3& p : contact_[s]) restDistance_[s].push_back(float(fieldAt(field_[1 - s], toIndex, p)));
  // Near voxels: each side's boundary layer (inside, a face-neighbour outside: the signed
  // distance is minus one spacing there) that its travel could carry into the other side.
  const Dims fd = fg.dims;
  const float layer = float(1.01 * std::max({fg.spacing.x, fg.spacing.y, fg.spacing.z}));
  for (int s = 0; s < 2; ++s) {
    for (int64_t k = 0; k < fd.z; ++k)
      for (int64_t j = 0; j < fd.y; ++j)
        for (int64_t i = 0; i < fd.x; ++i) {
          const float own = field_[s](i, j, k);
          if (own >= 0 || own < -layer) continue;
          const Vec3 p = fg.indexToPhysical({double(i), double(j), double(k)});
          if (field_[1 - s](i, j, k) > (norm(p - centre) + reachMm) * chord + voxelMm_) continue;
          near_[s].push_back(p);
        }
    near_[s] = axis::thinned(near_[s], kMaxNearVoxels);
  }
}

double HingeMotion::Tally::score() const {
  return (contact ? change / double(contact) : 0) + (near ? depth / double(near) : 0);
}

HingeMotion::Tally HingeMotion::tally(const Vec3& point, const Vec3& direction, size_t stride) const {
  Tally t;
  if (field_[0].geometry().dims.x == 0) return t;
  const Geometry::ToIndex toIndex = field_[0].geometry().physicalToIndexMap();
  const V3 p = eig(point), d = eig(direction).normalized();
  const double clip = kMotionClipMm;
  for (double a : angles_) {
    // The child turns by +a about the axis; relative to it the parent turns by -a.
    for (int s = 0; s < 2; ++s) {
      const Eigen::Matrix3d r = Eigen::AngleAxisd((s == 1 ? a : -a) * kDeg, d).toRotationMatrix();
      const auto turned = [&](const Vec3& x) { return fieldAt(field_[1 - s], toIndex, vec(p + r * (eig(x) - p))); };
      const std::vector<Vec3>& contact = contact_[s];
      for (size_t i = 0; i < contact.size(); i += stride) {
        const double change = std::clamp(turned(contact[i]) - restDistance_[s][i], -clip, clip);
        t.change += change * change;
        ++t.contact;
      }
      const std::vector<Vec3>& near = near_[s];
      for (size_t i = 0; i < near.size(); i += stride) {
        const double now = turned(near[i]);
        const double depth = std::clamp(-now, 0.0, clip);
        t.depth += depth * depth;
        t.inside += now < -voxelMm_;
        ++t.near;
      }
    }
  }
  return t;
}

double HingeMotion::score(const Vec3& point, const Vec3& direction) const { return tally(point, direction, 1).score(); }

double HingeMotion::insideFraction(const Vec3& point, const Vec3& direction) const {
  return tally(point, direction, 1).insideFraction();
}

MotionFit HingeMotion::search(Vec3& point, Vec3& direction, double coneDeg, double reachMm, Progress& progress) const {
  MotionFit fit;
  fit.coneDeg = coneDeg;
  fit.reachMm = reachMm;
  fit.anglesDeg = angles_;
  fit.contactPoints = int64_t(contact_[0].size() + contact_[1].size());
  fit.nearPoints = int64_t(near_[0].size() + near_[1].size());
  const V3 d0 = eig(direction).normalized();
  // The search is centred where the start line passes the contact (a hint's points may lie
  // anywhere on it).
  const V3 p0 = eig(point) + (eig(centre_) - eig(point)).dot(d0) * d0;
  const Tally start = tally(point, direction, 1);
  fit.startRmsMm = std::sqrt(start.score());
  fit.startInsideFraction = start.insideFraction();
  if (contact_[0].size() + contact_[1].size() < 10 || angles_.empty()) {
    fit.rmsMm = fit.startRmsMm, fit.insideFraction = fit.startInsideFraction;
    return fit;
  }
  fit.searched = true;
  // An axis: a direction and the point where its line crosses the plane through p0 across it.
  struct Candidate {
    V3 d, p;
    double cost;
  };
  // Coarse: directions within the cone ~5° apart, positions 3 mm apart within the reach,
  // ~3000 voxels; the best distinct few refined on every voxel.
  std::vector<V3> dirs{d0};
  const int hemisphere = int(std::ceil(2 * std::numbers::pi / std::pow(5 * kDeg, 2)));
  for (const V3& d : axis::hemisphereDirections(hemisphere))
    if (std::abs(d.dot(d0)) >= std::cos(coneDeg * kDeg) && std::abs(d.dot(d0)) < std::cos(1 * kDeg))
      dirs.push_back(d.dot(d0) < 0 ? V3(-d) : d);
  const size_t total = contact_[0].size() + contact_[1].size() + near_[0].size() + near_[1].size();
  const size_t stride = std::max<size_t>(1, total / 3000);
  const double step = 3.0;
  const int steps = int(std::floor(reachMm / step));
  std::vector<Candidate> coarse;
  std::mutex m;
  parallelFor(int64_t(dirs.size()), [&](int64_t b, int64_t e) {
    std::vector<Candidate> found;
    for (int64_t di = b; di < e; ++di) {
      progress.checkCancelled();
      const V3 d = dirs[size_t(di)];
      V3 u, v;
      axis::basisAcross(d, u, v);
      for (int a = -steps; a <= steps; ++a)
        for (int c = -steps; c <= steps; ++c) {
          if (a * a + c * c > steps * steps) continue;
          const V3 p = p0 + (a * step) * u + (c * step) * v;
          found.push_back({d, p, tally(vec(p), vec(d), stride).score()});
        }
    }
    std::lock_guard lock(m);
    coarse.insert(coarse.end(), found.begin(), found.end());
  });
  std::sort(coarse.begin(), coarse.end(), [](const Candidate& x, const Candidate& y) {
    // Ties in a deterministic order (the candidates arrive in the threads' order).
    return std::tie(x.cost, x.p.x(), x.p.y(), x.p.z(), x.d.x(), x.d.y()) <
           std::tie(y.cost, y.p.x(), y.p.y(), y.p.z(), y.d.x(), y.d.y());
  });
  std::vector<Candidate> starts;
  for (const Candidate& c : coarse) {
    if (starts.size() >= 4) break;
    bool distinct = true;
    for (const Candidate& s : starts) {
      const V3 off = c.p - s.p;
      const double across = (off - off.dot(s.d) * s.d).norm();
      distinct = distinct && (across > 4.0 || std::abs(c.d.dot(s.d)) < std::cos(8 * kDeg));
    }
    if (distinct) starts.push_back(c);
  }
  // Pattern search on (two tilts of the direction, two shifts across it), all voxels.
  std::vector<Candidate> refined(starts.size());
  parallelFor(int64_t(starts.size()), [&](int64_t b, int64_t e) {
    for (int64_t si = b; si < e; ++si) {
      Candidate c = starts[size_t(si)];
      c.cost = score(vec(c.p), vec(c.d));
      double shift = 1.5, tilt = 2.5 * kDeg;
      while (shift > 0.05 || tilt > 0.05 * kDeg) {
        progress.checkCancelled();
        V3 u, v;
        axis::basisAcross(c.d, u, v);
        bool moved = false;
        for (int k = 0; k < 8 && !moved; ++k) {
          Candidate t = c;
          const double sign = k % 2 ? -1.0 : 1.0;
          if (k < 4 && shift > 0.05) {
            t.p += sign * shift * (k < 2 ? u : v);
          } else if (k >= 4 && tilt > 0.05 * kDeg) {
            t.d = (c.d + sign * std::tan(tilt) * (k < 6 ? u : v)).normalized();
            if (std::abs(t.d.dot(d0)) < std::cos(coneDeg * kDeg)) continue;
          } else {
            continue;
          }
          if ((t.p - p0 - (t.p - p0).dot(t.d) * t.d).norm() > reachMm) continue;
          t.cost = score(vec(t.p), vec(t.d));
          if (t.cost < c.cost - 1e-12) c = t, moved = true;
        }
        if (!moved) shift /= 2, tilt /= 2;
      }
      refined[size_t(si)] = c;
    }
  });
  Candidate best{d0, p0, start.score()};
  for (const Candidate& c : refined)
    if (c.cost < best.cost) best = c;
  // The found line's point nearest the search's centre.
  const V3 p = best.p + (p0 - best.p).dot(best.d) * best.d;
  fit.shiftMm = (p - p0).norm();
  fit.turnDeg = std::acos(std::clamp(std::abs(best.d.dot(d0)), 0.0, 1.0)) / kDeg;
  point = vec(p);
  direction = vec(best.d);
  fit.rmsMm = std::sqrt(best.cost);
  fit.insideFraction = tally(point, direction, 1).insideFraction();
  return fit;
}

}  // namespace vellum::deformation
