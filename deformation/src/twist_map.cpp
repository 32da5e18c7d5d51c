// The twist map: a pose's backward map, fold-free by construction (see twist_map.hpp).
// Per stage (one joint, proximal first): group the bodies by where they sit, classify the output
// voxels (still, moving, fixed, free), blend the weight from the distances to both sides, relax
// it under the slope bound, lock blended voxels whose source lies in a bone, soften bone rims
// where bones touch along the turn; then one pass composes the stages into the map.
#include "vellum/deformation/twist_map.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

#include "vellum/core/distance_transform.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/rotation.hpp"

namespace vellum::deformation {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

/// A voxel's role in one stage's weight field. Still and fixed voxels hold w = 0, moving ones
/// w = 1; free voxels are blended; soft ones are bone rims unlocked where bones touch along the
/// turn (blended like free ones, never locked again). Fixed regions never soften.
enum Side : uint8_t { kFree = 0, kStill = 1, kMoving = 2, kFixed = 3, kSoft = 4 };
inline bool isFree(uint8_t s) { return s == kFree || s == kSoft; }
inline bool isStill(uint8_t s) { return s == kStill || s == kFixed; }

/// Strictly inside (0, 1): exactly 0 and 1 mark the locked voxels. The bounds are the floats
/// next to 0 and 1 (nextafter, as constants: it was a libm call per voxel).
inline float openUnit(double v) {
  constexpr float kAboveZero = std::numeric_limits<float>::denorm_min();
  constexpr float kBelowOne = 1.f - std::numeric_limits<float>::epsilon() / 2;
  return std::clamp(static_cast<float>(v), kAboveZero, kBelowOne);
}

/// std::llround inline (half away from zero; |x| < 2^52): a libm call per voxel otherwise.
inline int64_t roundIndex(double x) { return static_cast<int64_t>(x + std::copysign(0.5, x)); }

/// The output grid's indexing, shared by the stages.
struct Grid {
  Geometry g;
  Dims d;
  int64_t n = 0, sy = 0, sz = 0;
  Geometry::ToIndex toIndex;
  Mat3 mmToIdx;  ///< linear part of mm -> index
  double minSpacing = 1;
  double detIdx = 1;  ///< det of index -> mm

  explicit Grid(const Geometry& output) : g(output), d(output.dims), toIndex(output.physicalToIndexMap()) {
    n = d.voxelCount();
    sy = d.x;
    sz = d.x * d.y;
    const Mat3 toMm = output.direction * Mat3::fromColumns({output.spacing.x, 0, 0}, {0, output.spacing.y, 0},
                                                           {0, 0, output.spacing.z});
    if (!toMm.inverse(mmToIdx)) throw Error("twist map: singular geometry");
    detIdx = toMm.determinant();
    minSpacing = output.minSpacing();
  }
  int64_t index(int64_t i, int64_t j, int64_t k) const { return (k * d.y + j) * d.x + i; }
  Vec3 mm(int64_t t) const { return g.indexToPhysical({double(t % d.x), double((t / d.x) % d.y), double(t / sz)}); }
  /// The nearest voxel of a continuous index, or -1 outside the grid.
  int64_t nearest(const Vec3& idx) const {
    const int64_t i = roundIndex(idx.x), j = roundIndex(idx.y), k = roundIndex(idx.z);
    if (i < 0 || j < 0 || k < 0 || i >= d.x || j >= d.y || k >= d.z) return -1;
    return index(i, j, k);
  }
  Vec3 clamp(const Vec3& idx) const {
    return Vec3{std::clamp(idx.x, 0.0, double(d.x - 1)), std::clamp(idx.y, 0.0, double(d.y - 1)),
                std::clamp(idx.z, 0.0, double(d.z - 1))};
  }
  template <class F>
  void neighbours(int64_t t, F&& fn) const {  // the 6 face neighbours
    const int64_t i = t % d.x, j = (t / d.x) % d.y, k = t / sz;
    if (i > 0) fn(t - 1);
    if (i + 1 < d.x) fn(t + 1);
    if (j > 0) fn(t - sy);
    if (j + 1 < d.y) fn(t + sy);
    if (k > 0) fn(t - sz);
    if (k + 1 < d.z) fn(t + sz);
  }
  template <class F>
  void shell(int64_t t, F&& fn) const {  // the 26 neighbours
    const int64_t i = t % d.x, j = (t / d.x) % d.y, k = t / sz;
    for (int64_t c = std::max<int64_t>(k - 1, 0); c <= std::min(k + 1, d.z - 1); ++c)
      for (int64_t b = std::max<int64_t>(j - 1, 0); b <= std::min(j + 1, d.y - 1); ++b)
        for (int64_t a = std::max<int64_t>(i - 1, 0); a <= std::min(i + 1, d.x - 1); ++a)
          if (a != i || b != j || c != k) fn(index(a, b, c));
  }
};

/// One joint as the map applies it: the kernel's stage (the child turns forward by +angleRad
/// about `axis` through `pointMm`; the backward map by -angleRad * w, `turned`).
struct Stage : TwistKernel::Stage {
  int joint = -1;
};

/// The bodies that sit at one place in a stage's space: their stage transform (forward: rest
/// -> stage space), and whether the stage's joint moves them.
struct Group {
  RigidTransform forward;  ///< rest -> stage space
  RigidTransform backward;
  bool identity = true;
  bool moving = false;
  std::array<int64_t, 6> box{std::numeric_limits<int64_t>::max(), std::numeric_limits<int64_t>::max(),
                             std::numeric_limits<int64_t>::max(), -1, -1, -1};  ///< classes index box of its bodies
};
struct Grouping {
  std::vector<Group> groups;
  std::vector<int> bodyGroup;  ///< per body
};

/// Where every body sits in stage `s`'s space (the joints before it undone): its chain's joints
/// from this stage on, composed proximal outermost. Bodies with the same transform form one
/// group; the stage's joint moves the groups whose first remaining joint is its own.
Grouping groupBodies(const RigidBodies& bodies, const std::vector<std::vector<int>>& chain,
                     const std::vector<int>& position, const std::vector<RigidTransform>& own, size_t s, int joint) {
  Grouping out;
  const size_t nb = bodies.bodies().size();
  out.bodyGroup.assign(nb, -1);
  std::map<std::vector<int>, size_t> groupOf;
  for (size_t b = 0; b < nb; ++b) {
    std::vector<int> rest;
    for (int j : chain[b])
      if (position[static_cast<size_t>(j)] >= static_cast<int>(s)) rest.push_back(j);
    auto [it, added] = groupOf.try_emplace(rest, out.groups.size());
    if (added) {
      Group g;
      for (int j : rest) g.forward = compose(g.forward, own[static_cast<size_t>(j)]);
      g.backward = g.forward.inverse();
      g.identity = rest.empty();
      g.moving = !rest.empty() && rest.front() == joint;
      out.groups.push_back(g);
    }
    out.bodyGroup[b] = static_cast<int>(it->second);
    const auto& bx = bodies.boxes()[b];
    auto& gb = out.groups[it->second].box;
    for (size_t q = 0; q < 3; ++q) {
      gb[q] = std::min(gb[q], bx[q]);
      gb[q + 3] = std::max(gb[q + 3], bx[q + 3]);
    }
  }
  return out;
}

/// The stage's sides on the grid: a voxel is in a group's body when the group's backward
/// transform takes it to a voxel of that body (nearest). Fixed wins, then still (an overlap of
/// a posed moving bone over a still one: a collision, counted), then moving.
std::vector<uint8_t> classifySides(const Grid& grid, const RigidBodies& bodies, const Grouping& grouping,
                                   TwistJointStats& stats) {
  const Dims d = grid.d;
  const uint16_t* cls = bodies.classes().data();
  const auto& list = bodies.bodies();
  std::vector<uint8_t> side;
  resizeHugePaged(side, static_cast<size_t>(grid.n), uint8_t{kFree});
  std::atomic<int64_t> nStill{0}, nMoving{0}, nOverlap{0};
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    int64_t ls = 0, lm = 0, lo = 0;
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int64_t t = grid.index(i, j, k);
          bool still = false, moving = false, fixed = false;
          for (size_t q = 0; q < grouping.groups.size(); ++q) {
            const Group& g = grouping.groups[q];
            int64_t src = t;
            if (!g.identity) {
              const Vec3 u = grid.toIndex(g.backward.apply(grid.g.indexToPhysical({double(i), double(j), double(k)})));
              const int64_t ui = roundIndex(u.x), uj = roundIndex(u.y), uk = roundIndex(u.z);
              if (ui < g.box[0] || uj < g.box[1] || uk < g.box[2] || ui > g.box[3] || uj > g.box[4] || uk > g.box[5])
                continue;
              src = grid.index(ui, uj, uk);
            } else if (i < g.box[0] || j < g.box[1] || k < g.box[2] || i > g.box[3] || j > g.box[4] || k > g.box[5]) {
              continue;
            }
            const uint16_t c = cls[src];
            if (c < 2 || grouping.bodyGroup[c - 2u] != static_cast<int>(q)) continue;
            if (g.moving) moving = true;
            else if (list[c - 2u].fixed) fixed = still = true;
            else still = true;
          }
          if (still) {
            side[static_cast<size_t>(t)] = fixed ? kFixed : kStill;
            ++ls;
            if (moving) ++lo;
          } else if (moving) {
            side[static_cast<size_t>(t)] = kMoving;
            ++lm;
          }
        }
    nStill += ls;
    nMoving += lm;
    nOverlap += lo;
  });
  stats.stillVoxels = nStill;
  stats.movingVoxels = nMoving;
  stats.overlapVoxels = nOverlap;
  return side;
}

/// w = dS^p / (dS^p + dM^p) from the exact distance transforms (squared, mm²); 0 / 1 on the locks.
/// Distances along the axis count `axisStretch` times (when the axis runs along a grid axis): a
/// still region beside a moving one along the axis (the other foot, a fixed box) is a pure shear
/// for the map and should not pull the blend round the moving bone down (the tissue there would
/// show the bone turned by part of the angle).
VolumeF32 blendWeights(const Grid& grid, const Stage& st, const std::vector<uint8_t>& side, double power,
                       double axisStretch, Progress& progress) {
  const Dims d = grid.d;
  Geometry metric = grid.g;
  for (int q = 0; q < 3; ++q)
    if (std::abs(dot(st.axis, grid.g.direction.column(q))) > 0.95) metric.spacing[q] *= axisStretch;
  VolumeU8 feature(metric, 0, 0);
  auto distanceTo = [&](bool moving) {
    parallelFor(d.z, [&](int64_t k0, int64_t k1) {
      for (int64_t t = k0 * grid.sz; t < k1 * grid.sz; ++t) {
        const uint8_t s = side[static_cast<size_t>(t)];
        feature.data()[t] = moving ? s == kMoving : isStill(s);
      }
    });
    return squaredDistanceMm(feature, progress);
  };
  // w takes the still side's distances' place (each voxel reads its own before it writes): one
  // grid-sized buffer fewer to fault in and zero (366 MB at 512² × 350).
  VolumeF32 w = distanceTo(false);
  const VolumeF32 dM2 = distanceTo(true);
  w.setGeometry(grid.g);
  w.setBackground(0.0);  // beyond the grid: the still side (as a fresh weight volume)
  const double half = power / 2;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t t = k0 * grid.sz; t < k1 * grid.sz; ++t) {
      const uint8_t sd = side[static_cast<size_t>(t)];
      float& o = w.data()[t];
      const double ds = o, dm = dM2.data()[t];
      if (isStill(sd)) { o = 0.f; continue; }
      if (sd == kMoving) { o = 1.f; continue; }
      if (!std::isfinite(dm)) { o = 0.f; continue; }
      if (!std::isfinite(ds)) { o = 1.f; continue; }
      // p = 2 (the default): the squared distances themselves (pow costs ~a tenth of a frame's map).
      const double ps = half == 1 ? ds : std::pow(ds, half), pm = half == 1 ? dm : std::pow(dm, half);
      o = openUnit(ps / (ps + pm));
    }
  });
  return w;
}

/// theta * dw/dalpha at voxel t of w (central differences, one-sided at the faces): the
/// derivative of w along a x (v - c), which is the angular derivative per radian; 1 - it is the
/// stage map's det J. Where w steps steeply between neighbours (by over kSteepStep), the
/// central differences of the map itself (what the fold count measures) leave that linear
/// estimate: a steep step of w along r or z is a pure shear for the continuous map, but the
/// difference of two rotations by different angles is not, and one voxel further it can fold
/// (s18 feet: det -0.0005 beside the tibia where the estimate said 0.25). There the slope is
/// 1 - the map's own discrete det when that is larger.
struct Slope {
  static constexpr double kSteepStep = 0.02;
  /// A cell's det counts this much of 1 - det (TwistParams::cellCheck): with the default margin
  /// a cell is relaxed under det -0.25 and its bones' rims soften only under -0.5 (s22 feet
  /// frames: 0.6 kept the folds at ~0 for +0.005-0.04 mm of bone RMS; 1.0 cost +0.13-0.21 mm).
  static constexpr double kCellWeight = 0.6;
  const Grid& grid;
  const float* w;
  const Stage& st;
  bool gridCheck = true;
  bool cellCheck = false;
  bool kernelCheck = false;
  double at(int64_t t) const { return at(t, t % grid.d.x, (t / grid.d.x) % grid.d.y, t / grid.sz); }
  /// The same at voxel t = (i, j, k) (a scan knows them: no divisions).
  double at(int64_t t, int64_t i, int64_t j, int64_t k) const {
    const Dims d = grid.d;
    const int64_t pos[3] = {i, j, k}, step[3] = {1, grid.sy, grid.sz};
    int64_t lo[3], hi[3];
    Vec3 grad{0, 0, 0};
    double steep = 0;
    for (int q = 0; q < 3; ++q) {
      lo[q] = pos[q] > 0 ? -step[q] : 0;
      hi[q] = pos[q] + 1 < d[q] ? step[q] : 0;
      if (lo[q] == hi[q]) continue;
      const double a = w[t + lo[q]], b = w[t + hi[q]], c = w[t];
      grad[q] = (b - a) / double((hi[q] - lo[q]) / step[q]);
      steep = std::max({steep, std::abs(b - c), std::abs(a - c)});
    }
    const Vec3 v = grid.g.indexToPhysical({double(i), double(j), double(k)});
    const Vec3 tangent = grid.mmToIdx * cross(st.axis, v - st.pointMm);  // in index units
    double linear = st.angleRad * dot(grad, tangent);
    if (kernelCheck)  // the twist kernel's det at t, as a corner of each of its 8 cells
      for (int o = 0; o < 8; ++o) {
        Vec3 g{0, 0, 0};
        bool cell = true;
        for (int q = 0; q < 3 && cell; ++q) {
          const int64_t off = (o >> q) & 1 ? hi[q] : lo[q];
          cell = off != 0;
          if (cell) g[q] = ((o >> q) & 1 ? 1.0 : -1.0) * (double(w[t + off]) - double(w[t]));
        }
        if (cell) linear = std::max(linear, st.angleRad * dot(g, tangent));
      }
    if (!gridCheck || steep <= kSteepStep) return linear;
    // The stage map's central-difference det at t (index units, as the fold count's).
    auto mapAt = [&](int64_t n) { return st.turned(grid.mm(n), double(w[n])); };
    Vec3 below[3], above[3], col[3];
    for (int q = 0; q < 3; ++q) {
      if (lo[q] == hi[q]) return linear;
      below[q] = mapAt(t + lo[q]);
      above[q] = mapAt(t + hi[q]);
      col[q] = (above[q] - below[q]) / double((hi[q] - lo[q]) / step[q]);
    }
    const double det = dot(col[0], cross(col[1], col[2])) / grid.detIdx;
    if (!cellCheck) return std::max(linear, 1.0 - det);
    // The 8 cells around t, each at its corner t (one-sided differences): w zigzagging between
    // neighbours can fold a cell that the central differences step over, and an upsampled
    // map (a movie frame's node map) shows that fold inside the cell.
    const Vec3 at = mapAt(t);
    Vec3 side[3][2];
    for (int q = 0; q < 3; ++q) {
      side[q][0] = at - below[q];
      side[q][1] = above[q] - at;
    }
    double cellDet = std::numeric_limits<double>::infinity();
    for (int o = 0; o < 8; ++o) {
      const int sx = o & 1, sy = (o >> 1) & 1, sz = (o >> 2) & 1;
      if ((sx ? hi[0] : lo[0]) == 0 || (sy ? hi[1] : lo[1]) == 0 || (sz ? hi[2] : lo[2]) == 0) continue;  // no cell
      cellDet = std::min(cellDet, dot(side[0][sx], cross(side[1][sy], side[2][sz])) / grid.detIdx);
    }
    return std::max({linear, 1.0 - det, kCellWeight * (1.0 - cellDet)});
  }
};

/// The relaxation of one stage's weight under the bound theta * dw/dalpha <= bound: where it is
/// passed, the free voxels around take Jacobi steps towards their 6 neighbours' mean (first
/// round only) and then a slope limiter along the circles about the axis, over a region that
/// grows by a voxel each round. Locked voxels (bones, fixed regions) keep 0 / 1.
class Relaxation {
 public:
  Relaxation(const Grid& grid, const Stage& st, const std::vector<uint8_t>& side, VolumeF32& w,
             const TwistParams& params, TwistJointStats& stats)
      : grid_(grid), st_(st), side_(side), w_(w), params_(params), stats_(stats),
        slope_{grid, w.data(), st, params.gridCheck, params.cellCheck, params.kernelCheck}, bound_(1.0 - params.margin) {}

  const Slope& slope() const { return slope_; }

  /// Every voxel over `over` (default: the bound); `maxSlope` gets the largest slope.
  std::vector<int64_t> scan(double over = -1, double* maxSlope = nullptr) const {
    if (over < 0) over = bound_;
    const Dims d = grid_.d;
    std::vector<int64_t> bad;
    std::mutex mutex;
    double worst = 0;
    parallelFor(d.z, [&](int64_t k0, int64_t k1) {
      std::vector<int64_t> local;
      double lmax = 0;
      for (int64_t k = k0; k < k1; ++k)
        for (int64_t j = 0; j < d.y; ++j)
          for (int64_t i = 0; i < d.x; ++i) {
            const int64_t t = grid_.index(i, j, k);
            const double sl = slope_.at(t, i, j, k);
            lmax = std::max(lmax, sl);
            if (sl > over) local.push_back(t);
          }
      std::lock_guard lock(mutex);
      bad.insert(bad.end(), local.begin(), local.end());
      worst = std::max(worst, lmax);
    });
    std::sort(bad.begin(), bad.end());  // the same order whatever the threads did
    if (maxSlope) *maxSlope = worst;
    return bad;
  }

  /// The voxels of `candidates` (any order, repeats allowed) over `over`, sorted: scan()'s
  /// answer wherever the slopes elsewhere are known to be under it.
  std::vector<int64_t> over(std::vector<int64_t> candidates, double over) const {
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
    std::vector<int64_t> out;
    for (int64_t t : candidates)
      if (slope_.at(t) > over) out.push_back(t);
    return out;
  }

  double bound() const { return bound_; }

  /// Relax around `bad` for at most `rounds` rounds, stopping after `patience` rounds that cut the
  /// total excess over the bound by under 2 %; `bad` is left holding what is still over it.
  /// `changed` (when set) gets every voxel whose w the steps may have changed (repeats allowed).
  void run(std::vector<int64_t>& bad, int rounds, int patience, bool smoothFirst,
           std::vector<int64_t>* changed = nullptr) {
    if (touched_.empty() && !bad.empty()) resizeHugePaged(touched_, static_cast<size_t>(grid_.n), uint8_t{0});
    double least = std::numeric_limits<double>::infinity();
    int stalled = 0;
    for (int round = 0; round < rounds && !bad.empty(); ++round) {
      ++stats_.rounds;
      const std::vector<int64_t> region = grow(bad, std::min(params_.maxRadius, 2 + round));
      std::vector<int64_t> freeRegion;
      for (int64_t t : region)
        if (isFree(side_[static_cast<size_t>(t)])) freeRegion.push_back(t);
      std::sort(freeRegion.begin(), freeRegion.end());
      // The smoothing in the first round only: later rounds carry the limiter's front on, which
      // smoothing would pull back.
      if (round == 0 && smoothFirst)
        for (int step = 0; step < params_.relaxSteps; ++step) smooth(freeRegion);
      for (int step = 0; step < params_.limitSteps; ++step) limit(freeRegion);
      // The kernel's cells: the limiter works along arcs and never sees a cell's one-sided
      // differences beside a lock, which stuck there and made the bone's rim give; project
      // those cells' free corners onto the bound. One sweep a round: more left no rim to soften
      // where a free node's source lies in the bone, and the voxel snap folded beside it (s25).
      if (slope_.kernelCheck && params_.projectCells)
        for (int64_t t : bad) projectCells(t);
      for (int64_t t : freeRegion) touched_[static_cast<size_t>(t)] = 1;
      if (changed) changed->insert(changed->end(), freeRegion.begin(), freeRegion.end());
      // Recheck the region and its neighbours (the only slopes the steps changed).
      std::vector<int64_t> check = region;
      for (int64_t t : region) grid_.neighbours(t, [&](int64_t q) { check.push_back(q); });
      std::sort(check.begin(), check.end());
      check.erase(std::unique(check.begin(), check.end()), check.end());
      std::vector<int64_t> left;
      double excess = 0;
      for (int64_t t : check)
        if (const double sl = slope_.at(t); sl > bound_) {
          left.push_back(t);
          excess += sl - bound_;
        }
      bad = std::move(left);  // violations outside the region: none, the region holds them all
      // Stop when rounds no longer help: what is left is locked on both sides (a collision).
      if (excess < 0.98 * least) {
        least = excess;
        stalled = 0;
      } else if (++stalled >= patience) {
        break;
      }
    }
  }

  int64_t relaxedVoxels() const {
    int64_t c = 0;
    for (uint8_t x : touched_) c += x;
    return c;
  }

 private:
  /// `seeds` grown by `radius` voxels (6-neighbour steps).
  std::vector<int64_t> grow(const std::vector<int64_t>& seeds, int radius) {
    if (mark_.empty()) resizeHugePaged(mark_, static_cast<size_t>(grid_.n), uint8_t{0});
    std::vector<int64_t> region, frontier;
    for (int64_t t : seeds)
      if (!mark_[static_cast<size_t>(t)]) { mark_[static_cast<size_t>(t)] = 1; frontier.push_back(t); }
    region = frontier;
    for (int r = 0; r < radius; ++r) {
      std::vector<int64_t> next;
      for (int64_t t : frontier)
        grid_.neighbours(t, [&](int64_t q) {
          if (!mark_[static_cast<size_t>(q)]) { mark_[static_cast<size_t>(q)] = 1; next.push_back(q); }
        });
      region.insert(region.end(), next.begin(), next.end());
      frontier = std::move(next);
    }
    for (int64_t t : region) mark_[static_cast<size_t>(t)] = 0;
    return region;
  }

  /// One Jacobi step of the free voxels of `region` towards their 6 neighbours' mean.
  void smooth(const std::vector<int64_t>& region) {
    std::vector<float> next(region.size());
    parallelFor(static_cast<int64_t>(region.size()), [&](int64_t r0, int64_t r1) {
      for (int64_t r = r0; r < r1; ++r) {
        double sum = 0;
        int cnt = 0;
        grid_.neighbours(region[static_cast<size_t>(r)], [&](int64_t q) { sum += w_.data()[q]; ++cnt; });
        next[static_cast<size_t>(r)] = openUnit(sum / cnt);
      }
    }, 4096);
    for (size_t r = 0; r < region.size(); ++r) w_.data()[region[r]] = next[r];
  }

  /// One step of the limiter: along the circle through each free voxel, w may rise by at most
  /// L = bound / theta per radian (it may fall freely: a stretch), so w(v) is held between
  /// w(v ahead) - L delta and w(v behind) + L delta, the neighbours one voxel of arc ahead and
  /// behind (trilinear). Repeated, this carries the bound from the bones into the free space along
  /// the circles, where the smoothing spreads it in r and z too (and stalls where a still and a
  /// moving bone face each other across a short arc). A little under the bound: the check's
  /// central differences read the arc steps' trilinear samples with some spread (the limiter
  /// alone settles at ~1.03 x its L).
  void limit(const std::vector<int64_t>& region) {
    const double lim = 0.85 * bound_ / std::abs(st_.angleRad);
    std::vector<float> next(region.size());
    parallelFor(static_cast<int64_t>(region.size()), [&](int64_t r0, int64_t r1) {
      for (int64_t r = r0; r < r1; ++r) {
        const int64_t t = region[static_cast<size_t>(r)];
        const Vec3 p = grid_.mm(t) - st_.pointMm;
        const double radius = norm(p - st_.axis * dot(st_.axis, p));
        float& o = next[static_cast<size_t>(r)];
        o = w_.data()[t];
        if (radius < 1e-6) continue;
        const double delta = std::min(grid_.minSpacing / radius, 0.5) * (st_.angleRad > 0 ? 1 : -1);
        // Clamped onto the grid: beyond its faces w is unknown, not 0 (a still region there
        // would hold the tissue next to a face still).
        const double ahead = w_.sampleLinear(grid_.clamp(grid_.toIndex(st_.pointMm + rotateAbout(p, st_.axis, delta))));
        const double behind = w_.sampleLinear(grid_.clamp(grid_.toIndex(st_.pointMm + rotateAbout(p, st_.axis, -delta))));
        const double lo = ahead - lim * std::abs(delta), hi = behind + lim * std::abs(delta);
        o = openUnit(lo <= hi ? std::clamp(double(o), lo, hi) : 0.5 * (lo + hi));
      }
    }, 4096);
    for (size_t r = 0; r < region.size(); ++r) w_.data()[region[r]] = next[r];
  }

  /// The twist kernel's det at t's 8 cells (Slope::at, kernelCheck) is linear in the weights of
  /// t and its axis neighbours: where a cell passes the bound, its free corners move by the
  /// least change that brings it back (the locked ones keep 0 / 1), a cell after another.
  void projectCells(int64_t t) {
    const Dims d = grid_.d;
    const int64_t pos[3] = {t % d.x, (t / d.x) % d.y, t / grid_.sz}, step[3] = {1, grid_.sy, grid_.sz};
    const Vec3 v = grid_.g.indexToPhysical({double(pos[0]), double(pos[1]), double(pos[2])});
    const Vec3 tangent = grid_.mmToIdx * cross(st_.axis, v - st_.pointMm);
    float* w = w_.data();
    const double target = 0.98 * bound_;
    for (int o = 0; o < 8; ++o) {
      int64_t nb[3];
      double c[3], ct = 0, value = 0;
      bool cell = true;
      for (int q = 0; q < 3 && cell; ++q) {
        const bool up = (o >> q) & 1;
        cell = up ? pos[q] + 1 < d[q] : pos[q] > 0;
        nb[q] = t + (up ? step[q] : -step[q]);
        c[q] = st_.angleRad * (up ? 1.0 : -1.0) * tangent[q];  // d value / d w[nb[q]]
        ct -= c[q];
      }
      if (!cell) continue;
      for (int q = 0; q < 3; ++q) value += c[q] * (double(w[nb[q]]) - double(w[t]));
      if (!(value > target)) continue;
      double norm2 = 0;
      for (int q = 0; q < 3; ++q)
        if (isFree(side_[static_cast<size_t>(nb[q])])) norm2 += c[q] * c[q];
      const bool freeT = isFree(side_[static_cast<size_t>(t)]);
      if (freeT) norm2 += ct * ct;
      if (!(norm2 > 1e-12)) continue;
      const double lambda = (value - target) / norm2;
      for (int q = 0; q < 3; ++q)
        if (isFree(side_[static_cast<size_t>(nb[q])])) w[nb[q]] = openUnit(w[nb[q]] - lambda * c[q]);
      if (freeT) w[t] = openUnit(w[t] - lambda * ct);
    }
  }

  const Grid& grid_;
  const Stage& st_;
  const std::vector<uint8_t>& side_;
  VolumeF32& w_;
  const TwistParams& params_;
  TwistJointStats& stats_;
  Slope slope_;
  double bound_;
  std::vector<uint8_t> touched_;  ///< 1: relaxed at least once
  std::vector<uint8_t> mark_;     ///< scratch of grow()
};

/// Consistent locks (the last joint's stage, whose output is the source): a blended voxel whose
/// source lands in a bone's voxel (nearest: the cells are not round about the axis) joins that
/// bone's side, w = 0 or 1 exactly; only a short step (the source moves by at most
/// joinMaxVoxels): a long one is a jump next to the other side's lock that no relaxation can
/// spread. Returns the voxels that joined. `only`: the voxels to check (sorted and made unique
/// here), the whole grid when null: a voxel whose w and side are as at the last check does not
/// join now either.
std::vector<int64_t> joinLocks(const Grid& grid, const Stage& st, const RigidBodies& bodies, const Grouping& grouping,
                               const TwistParams& params, std::vector<uint8_t>& side, VolumeF32& w,
                               std::vector<int64_t>* only = nullptr) {
  const uint16_t* cls = bodies.classes().data();
  std::vector<std::pair<int64_t, uint8_t>> joins;
  std::mutex mutex;
  const double maxStep = params.joinMaxVoxels * grid.minSpacing;
  auto tryJoin = [&](int64_t t, const Vec3& v, std::vector<std::pair<int64_t, uint8_t>>& local) {
    const double wt = w.data()[t];
    // The arc a lock would add: to a moving body's (w 1) or a still one's (w 0). Where both are
    // too long the body at the turned place does not matter: no turn, no lookup (most voxels).
    const Vec3 p = v - st.pointMm;
    const double radius = norm(p - st.axis * dot(st.axis, p));
    const double toMoving = std::abs(st.angleRad) * std::abs(1.0 - wt) * radius;
    const double toStill = std::abs(st.angleRad) * std::abs(wt) * radius;
    if (toMoving > maxStep && toStill > maxStep) return;
    const int64_t src = grid.nearest(grid.toIndex(st.turned(v, wt)));
    if (src < 0 || cls[src] < 2) return;
    const bool moving = grouping.groups[static_cast<size_t>(grouping.bodyGroup[cls[src] - 2u])].moving;
    if ((moving ? toMoving : toStill) <= maxStep) local.emplace_back(t, moving ? kMoving : kStill);
  };
  if (only) {
    std::sort(only->begin(), only->end());
    only->erase(std::unique(only->begin(), only->end()), only->end());
  }
  const int64_t count = only ? static_cast<int64_t>(only->size()) : grid.d.z;
  parallelFor(count, [&](int64_t a, int64_t b) {
    std::vector<std::pair<int64_t, uint8_t>> local;
    if (only) {
      for (int64_t r = a; r < b; ++r)
        if (const int64_t t = (*only)[static_cast<size_t>(r)]; side[static_cast<size_t>(t)] == kFree)
          tryJoin(t, grid.mm(t), local);
    } else {
      for (int64_t k = a; k < b; ++k)
        for (int64_t j = 0; j < grid.d.y; ++j)
          for (int64_t i = 0; i < grid.d.x; ++i)
            if (const int64_t t = grid.index(i, j, k); side[static_cast<size_t>(t)] == kFree)
              tryJoin(t, grid.g.indexToPhysical({double(i), double(j), double(k)}), local);
    }
    std::lock_guard lock(mutex);
    joins.insert(joins.end(), local.begin(), local.end());
  });
  std::vector<int64_t> joined;
  joined.reserve(joins.size());
  for (const auto& [t, sd] : joins) {
    side[static_cast<size_t>(t)] = sd;
    w.data()[t] = sd == kMoving ? 1.f : 0.f;
    joined.push_back(t);
  }
  return joined;
}

/// Unlocks the bone voxels (still or moving, never fixed) in the 26-neighbourhood of each of
/// `bad`: they become soft, blended with the tissue; `soft` (the map's record) marks them.
/// Returns how many were unlocked.
int64_t soften(const Grid& grid, const std::vector<int64_t>& bad, std::vector<uint8_t>& side,
               std::vector<uint8_t>& soft) {
  if (soft.empty()) resizeHugePaged(soft, static_cast<size_t>(grid.n), uint8_t{0});
  int64_t count = 0;
  auto unlock = [&](int64_t q) {
    uint8_t& s = side[static_cast<size_t>(q)];
    if (s != kStill && s != kMoving) return;
    s = kSoft;
    soft[static_cast<size_t>(q)] = 1;
    ++count;
  };
  for (int64_t t : bad) {
    unlock(t);
    grid.shell(t, unlock);
  }
  return count;
}

}  // namespace

TwistMap twistMap(const Pose& pose, const std::vector<double>& anglesDeg, const RigidBodies& bodies,
                  const Geometry& output, const TwistParams& params, Progress& progress) {
  const size_t nj = pose.joints.size();
  if (anglesDeg.size() != nj) throw Error("twist map: " + std::to_string(anglesDeg.size()) + " angles for " +
                                          std::to_string(nj) + " joints");
  const VolumeU16& classes = bodies.classes();
  if (!(classes.geometry().dims == output.dims) || !classes.geometry().approxEqual(output, 1e-3))
    throw Error("twist map: the rigid bodies' grid differs from the output grid");
  const Grid grid(output);
  const Dims d = grid.d;
  const int64_t n = grid.n;
  checkMemoryBudget(uint64_t(n) * (3 * sizeof(float) + 2 * sizeof(float) + 2), "twist map");

  // Joints proximal first (linkJoints() guarantees no cycle): the depth along the chain.
  std::vector<int> depth(nj, 0);
  for (size_t j = 0; j < nj; ++j)
    for (int p = pose.joints[j].proximal; p >= 0; p = pose.joints[static_cast<size_t>(p)].proximal) ++depth[j];
  std::vector<int> order;
  for (size_t j = 0; j < nj; ++j)
    if (std::abs(anglesDeg[j]) > 1e-9) order.push_back(static_cast<int>(j));
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return depth[size_t(x)] < depth[size_t(y)]; });
  std::vector<int> position(nj, -1);
  for (size_t s = 0; s < order.size(); ++s) position[static_cast<size_t>(order[s])] = static_cast<int>(s);

  // Each body's chain of joints that turn it (proximal first; empty: it stays).
  const auto& list = bodies.bodies();
  std::vector<std::vector<int>> chain(list.size());
  for (size_t b = 0; b < list.size(); ++b) {
    if (list[b].fixed || list[b].ids.empty()) continue;
    for (int j = pose.jointMoving(list[b].ids.front()); j >= 0; j = pose.joints[static_cast<size_t>(j)].proximal)
      if (position[static_cast<size_t>(j)] >= 0) chain[b].insert(chain[b].begin(), j);
  }
  std::vector<RigidTransform> own(nj);
  for (size_t j = 0; j < nj; ++j) own[j] = rotationAbout(pose.joints[j].axisA, pose.joints[j].axisB, anglesDeg[j]);

  TwistMap result;
  std::vector<Stage> stages;
  std::vector<VolumeF32> weights;
  std::vector<uint8_t> soft;  // output voxels softened in any stage: the snap leaves them blended
  for (size_t s = 0; s < order.size(); ++s) {
    progress.checkCancelled();
    const int jt = order[s];
    const Joint& joint = pose.joints[static_cast<size_t>(jt)];
    Stage st;
    static_cast<TwistKernel::Stage&>(st) = TwistKernel::Stage::about(
        joint.axisA, normalized(joint.axisB - joint.axisA), anglesDeg[static_cast<size_t>(jt)] * kDeg);
    st.joint = jt;
    TwistJointStats stats;
    stats.name = joint.name;
    stats.angleDeg = anglesDeg[static_cast<size_t>(jt)];

    const Grouping grouping = groupBodies(bodies, chain, position, own, s, jt);
    std::vector<uint8_t> side = classifySides(grid, bodies, grouping, stats);
    progress.checkCancelled();
    VolumeF32 w = blendWeights(grid, st, side, params.power, params.axisStretch, progress);
    progress.checkCancelled();

    Relaxation relax(grid, st, side, w, params, stats);
    double maxSlope = 0;
    std::vector<int64_t> bad = relax.scan(-1, &maxSlope);
    stats.violationsBefore = static_cast<int64_t>(bad.size());
    stats.maxSlopeBefore = maxSlope;
    relax.run(bad, params.maxRounds, params.patience, true);
    // The last stage's output is the source: lock blended voxels whose source lies in a bone,
    // and relax again around them (fewer rounds), so the snap has (nearly) nothing left to do.
    // From here on `bad` is every voxel over the bound without scanning the grid again: run()
    // leaves it so (it changes w only inside the region it rechecks), a slope reads w at the
    // voxel and its 6 neighbours only, and softening changes sides, not w.
    if (s + 1 == order.size()) {
      // After the first pass only the voxels the relaxation changed can join.
      std::vector<int64_t> changed;
      for (int pass = 0; pass < params.lockPasses; ++pass) {
        progress.checkCancelled();
        std::vector<int64_t> joined = joinLocks(grid, st, bodies, grouping, params, side, w, pass ? &changed : nullptr);
        changed.clear();
        if (joined.empty()) break;
        stats.joinedVoxels += static_cast<int64_t>(joined.size());
        const size_t nJoined = joined.size();
        for (size_t q = 0; q < nJoined; ++q) grid.neighbours(joined[q], [&](int64_t n) { joined.push_back(n); });
        joined.insert(joined.end(), bad.begin(), bad.end());
        bad = relax.over(std::move(joined), relax.bound());
        relax.run(bad, params.maxRounds / 3, params.patience / 2, true, &changed);
      }
    }
    // Bones that touch along the turn: no w between the two locks keeps det J > 0; their rims
    // give, a voxel's shell deeper each pass, and the tissue's blend is relaxed through them.
    for (int pass = 0; pass < params.softenPasses; ++pass) {
      progress.checkCancelled();
      // Stuck voxels are a part of `bad` unless the margin is under softenBelow (then scanned).
      const double stuckOver = 1.0 - params.softenBelow;
      const std::vector<int64_t> stuck = stuckOver >= relax.bound() ? relax.over(bad, stuckOver) : relax.scan(stuckOver);
      if (stuck.empty()) break;
      const int64_t unlocked = soften(grid, stuck, side, soft);
      if (unlocked == 0) break;
      stats.softenedVoxels += unlocked;
      relax.run(bad, params.maxRounds / 3, params.patience / 2, true);
    }
    stats.relaxedVoxels = relax.relaxedVoxels();
    stats.violationsAfter = static_cast<int64_t>(bad.size());
    for (int64_t t : bad) {
      const double sl = relax.slope().at(t);
      stats.maxSlopeAfter = std::max(stats.maxSlopeAfter, sl);
      if (sl >= 1) ++stats.collisionVoxels;
    }
    result.joints.push_back(stats);
    stages.push_back(st);
    weights.push_back(std::move(w));
  }

  // Each body's whole backward transform (output -> rest): the inverse of its chain's joints
  // composed proximal outermost; the identity for still bodies and the fixed regions.
  std::vector<RigidTransform> bodyBack(list.size());
  for (size_t b = 0; b < list.size(); ++b) {
    RigidTransform f;
    for (int j : chain[b]) f = compose(f, own[static_cast<size_t>(j)]);
    bodyBack[b] = f.inverse();
  }
  // The twist kernel: the stages and their weights, one per stage and node; the map at the
  // nodes is then the kernel's own (as it is upsampled), without the snap. No stage (every
  // angle 0): none.
  std::shared_ptr<TwistKernel> kernel;
  if (params.kernel && !stages.empty() && stages.size() <= size_t(TwistKernel::kMaxStages)) {
    kernel = std::make_shared<TwistKernel>();
    for (const Stage& st : stages) kernel->addStage(st.pointMm, st.axis, st.angleRad);
    const size_t ns = kernel->stride();
    if (ns == 1) {
      kernel->weights = std::move(weights[0].voxels());  // the weights are not read again
    } else {
      resizeHugePaged(kernel->weights, static_cast<size_t>(n) * ns, 0.f);
      for (size_t s = 0; s < ns; ++s) {
        const float* w = weights[s].data();
        float* out = kernel->weights.data() + s;
        parallelFor(n, [&](int64_t t0, int64_t t1) {
          for (int64_t t = t0; t < t1; ++t) out[static_cast<size_t>(t) * ns] = w[t];
        });
      }
    }
    result.kernel = kernel;
  }
  // The map: each output voxel through the stages' backward twists, proximal first. The first
  // stage reads w at the voxel itself; later ones at the moved position (trilinear, or the
  // nearest voxel's exact 0 / 1 when that voxel is locked, so the bones stay exactly rigid).
  const uint16_t* cls = classes.data();
  const double snapReach = params.snapMaxVoxels * grid.minSpacing;
  std::atomic<int64_t> unsnapped{0};
  resizeHugePaged(result.mapMm, static_cast<size_t>(n) * 3);
  float* out = result.mapMm.data();
  // Output voxel t at v (mm): its source through the stages and the snap; 1 when the snap left
  // it off a body it lands in.
  auto composeVoxel = [&](int64_t t, const Vec3& v) -> int64_t {
    if (kernel) {
      const Vec3 x = kernel->sourceAtNode(t, v, grid.toIndex, d);
      out[3 * t] = static_cast<float>(x.x);
      out[3 * t + 1] = static_cast<float>(x.y);
      out[3 * t + 2] = static_cast<float>(x.z);
      return 0;
    }
    Vec3 x = v;
    int64_t unsnappedHere = 0;
    for (size_t s = 0; s < stages.size(); ++s) {
      const Stage& st = stages[s];
      double wk;
      if (s == 0) {
        wk = weights[s].data()[t];
      } else {
        const Vec3 idx = grid.toIndex(x);
        const double nearest = weights[s].sampleNearest(idx);
        wk = (nearest == 0.0 || nearest == 1.0) ? nearest : weights[s].sampleLinear(idx);
      }
      x = st.turned(x, wk);
    }
    // The snap (as the MLS map's, RigidSnap): a blended voxel whose source lands in a body
    // takes that body's transform, so no output voxel shows bone moved non-rigidly (a voxel
    // beside a bone, w just under 1, would show its rim turned a little less). Not on the
    // softened rims, nor where it would jump the source by more than snapMaxVoxels: a jump
    // between neighbours is a fold.
    if (params.snap)
      if (const int64_t src = grid.nearest(grid.toIndex(x)); src >= 0 && cls[src] >= 2) {
        const Vec3 snapped = bodyBack[cls[src] - 2u].apply(v);
        if ((soft.empty() || !soft[static_cast<size_t>(t)]) && norm(snapped - x) <= snapReach) x = snapped;
        else if (norm(snapped - x) > 1e-6) unsnappedHere = 1;
      }
    out[3 * t] = static_cast<float>(x.x);
    out[3 * t + 1] = static_cast<float>(x.y);
    out[3 * t + 2] = static_cast<float>(x.z);
    return unsnappedHere;
  };
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    int64_t local = 0;
    for (int64_t k = k0; k < k1; ++k) {
      progress.checkCancelled();
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i)
          local += composeVoxel(grid.index(i, j, k), grid.g.indexToPhysical({double(i), double(j), double(k)}));
    }
    unsnapped += local;
  });
  result.unsnappedVoxels = unsnapped;
  return result;
}

}  // namespace vellum::deformation
