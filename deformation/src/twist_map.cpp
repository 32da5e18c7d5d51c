// The twist map: a pose's backward map, fold-free by construction (see twist_map.hpp).
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

namespace vellum::deformation {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr uint8_t kFree = 0, kStill = 1, kMoving = 2;

/// Rotation by `rad` about unit `a` (Rodrigues), applied to `p` (relative to a point on the axis).
inline Vec3 turn(const Vec3& p, const Vec3& a, double rad) {
  const double c = std::cos(rad), s = std::sin(rad);
  return p * c + cross(a, p) * s + a * (dot(a, p) * (1 - c));
}

/// One joint as the map applies it.
struct Stage {
  int joint = -1;
  Vec3 c{0, 0, 0}, a{1, 0, 0};
  double theta = 0;  ///< rad, forward (the child turns by +theta about a)
  Mat3 backFull;     ///< rotation by -theta (w = 1)
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

RigidTransform inverse(const RigidTransform& t) {
  const Mat3 rt = t.rotation.transposed();
  return RigidTransform{rt, rt * (-t.translation)};
}
RigidTransform compose(const RigidTransform& outer, const RigidTransform& inner) {
  return RigidTransform{outer.rotation * inner.rotation, outer.rotation * inner.translation + outer.translation};
}

/// theta * dw/dalpha at voxel t of w (central differences, one-sided at the faces): the
/// derivative of w along a x (v - c), which is the angular derivative per radian.
struct Slope {
  const float* w;
  Dims d;
  Geometry g;
  Vec3 c, a;
  double theta;
  Mat3 mmToIdx;  ///< linear part of mm -> index
  double at(int64_t i, int64_t j, int64_t k) const {
    const int64_t t = (k * d.y + j) * d.x + i;
    auto diff = [&](int64_t n, int64_t dim, int64_t step) {
      const int64_t lo = n > 0 ? -step : 0, hi = n + 1 < dim ? step : 0;
      if (lo == hi) return 0.0;
      return (double(w[t + hi]) - double(w[t + lo])) / double((hi - lo) / step);
    };
    const Vec3 grad{diff(i, d.x, 1), diff(j, d.y, d.x), diff(k, d.z, d.x * d.y)};
    const Vec3 v = g.indexToPhysical({double(i), double(j), double(k)});
    const Vec3 tangent = mmToIdx * cross(a, v - c);  // in index units
    return theta * dot(grad, tangent);
  }
};

}  // namespace

TwistMap twistMap(const Pose& pose, const std::vector<double>& anglesDeg, const RigidBodies& bodies,
                  const Geometry& output, const TwistParams& params, Progress& progress) {
  const size_t nj = pose.joints.size();
  if (anglesDeg.size() != nj) throw Error("twist map: " + std::to_string(anglesDeg.size()) + " angles for " +
                                          std::to_string(nj) + " joints");
  const VolumeU16& classes = bodies.classes();
  if (!(classes.geometry().dims == output.dims) || !classes.geometry().approxEqual(output, 1e-3))
    throw Error("twist map: the rigid bodies' grid differs from the output grid");
  const Dims d = output.dims;
  const int64_t n = d.voxelCount();
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

  const Mat3 toMm = output.direction * Mat3::fromColumns({output.spacing.x, 0, 0}, {0, output.spacing.y, 0},
                                                         {0, 0, output.spacing.z});
  Mat3 mmToIdx;
  if (!toMm.inverse(mmToIdx)) throw Error("twist map: singular geometry");
  const Geometry::ToIndex toIndex = output.physicalToIndexMap();
  auto clampIndex = [&](const Vec3& idx) {
    return Vec3{std::clamp(idx.x, 0.0, double(d.x - 1)), std::clamp(idx.y, 0.0, double(d.y - 1)),
                std::clamp(idx.z, 0.0, double(d.z - 1))};
  };
  const double minSpacing = std::min({output.spacing.x, output.spacing.y, output.spacing.z});
  const uint16_t* cls = classes.data();

  TwistMap result;
  std::vector<Stage> stages;
  std::vector<VolumeF32> weights;
  for (size_t s = 0; s < order.size(); ++s) {
    progress.checkCancelled();
    const int jt = order[s];
    const Joint& joint = pose.joints[static_cast<size_t>(jt)];
    Stage st;
    st.joint = jt;
    st.c = joint.axisA;
    st.a = normalized(joint.axisB - joint.axisA);
    st.theta = anglesDeg[static_cast<size_t>(jt)] * kDeg;
    st.backFull = rotationAbout(joint.axisA, joint.axisB, -anglesDeg[static_cast<size_t>(jt)]).rotation;
    TwistJointStats stats;
    stats.name = joint.name;
    stats.angleDeg = anglesDeg[static_cast<size_t>(jt)];

    // Where every body sits in this stage's space (the joints before it undone): its chain's
    // joints from this stage on, composed proximal outermost. Bodies with the same transform
    // form one group; the joint moves the groups whose first remaining joint is its own.
    std::map<std::vector<int>, size_t> groupOf;
    std::vector<Group> groups;
    std::vector<int> bodyGroup(list.size(), -1);
    for (size_t b = 0; b < list.size(); ++b) {
      std::vector<int> rest;
      for (int j : chain[b])
        if (position[static_cast<size_t>(j)] >= static_cast<int>(s)) rest.push_back(j);
      auto [it, added] = groupOf.try_emplace(rest, groups.size());
      if (added) {
        Group g;
        for (int j : rest) g.forward = compose(g.forward, own[static_cast<size_t>(j)]);
        g.backward = inverse(g.forward);
        g.identity = rest.empty();
        g.moving = !rest.empty() && rest.front() == jt;
        groups.push_back(g);
      }
      bodyGroup[b] = static_cast<int>(it->second);
      const auto& bx = bodies.boxes()[b];
      auto& gb = groups[it->second].box;
      for (int q = 0; q < 3; ++q) {
        gb[static_cast<size_t>(q)] = std::min(gb[static_cast<size_t>(q)], bx[static_cast<size_t>(q)]);
        gb[static_cast<size_t>(q + 3)] = std::max(gb[static_cast<size_t>(q + 3)], bx[static_cast<size_t>(q + 3)]);
      }
    }
    // The still and moving sets on the grid: a voxel is in a group's body when the group's
    // backward transform takes it to a voxel of that body (nearest). Still wins an overlap.
    std::vector<uint8_t> side(static_cast<size_t>(n), kFree);
    std::atomic<int64_t> nStill{0}, nMoving{0}, nOverlap{0};
    parallelFor(d.z, [&](int64_t k0, int64_t k1) {
      int64_t ls = 0, lm = 0, lo = 0;
      for (int64_t k = k0; k < k1; ++k)
        for (int64_t j = 0; j < d.y; ++j)
          for (int64_t i = 0; i < d.x; ++i) {
            const int64_t t = (k * d.y + j) * d.x + i;
            bool still = false, moving = false;
            for (const Group& g : groups) {
              int64_t src = t;
              if (!g.identity) {
                const Vec3 u = toIndex(g.backward.apply(output.indexToPhysical({double(i), double(j), double(k)})));
                const int64_t ui = std::llround(u.x), uj = std::llround(u.y), uk = std::llround(u.z);
                if (ui < g.box[0] || uj < g.box[1] || uk < g.box[2] || ui > g.box[3] || uj > g.box[4] || uk > g.box[5])
                  continue;
                src = (uk * d.y + uj) * d.x + ui;
              } else if (i < g.box[0] || j < g.box[1] || k < g.box[2] || i > g.box[3] || j > g.box[4] || k > g.box[5]) {
                continue;
              }
              const uint16_t c = cls[src];
              if (c < 2 || &groups[static_cast<size_t>(bodyGroup[c - 2u])] != &g) continue;
              (g.moving ? moving : still) = true;
            }
            if (still) { side[static_cast<size_t>(t)] = kStill; ++ls; if (moving) ++lo; }
            else if (moving) { side[static_cast<size_t>(t)] = kMoving; ++lm; }
          }
      nStill += ls; nMoving += lm; nOverlap += lo;
    });
    stats.stillVoxels = nStill; stats.movingVoxels = nMoving; stats.overlapVoxels = nOverlap;
    progress.checkCancelled();

    // w = dS^p / (dS^p + dM^p) from the exact distance transforms (squared, mm²).
    VolumeF32 w(output, 0.f, 0.f);
    {
      VolumeU8 feature(output, 0, 0);
      auto distanceTo = [&](uint8_t which) {
        parallelFor(d.z, [&](int64_t k0, int64_t k1) {
          for (int64_t t = k0 * d.x * d.y; t < k1 * d.x * d.y; ++t)
            feature.data()[t] = side[static_cast<size_t>(t)] == which;
        });
        return squaredDistanceMm(feature, progress);
      };
      VolumeF32 dS2 = distanceTo(kStill);
      const VolumeF32 dM2 = distanceTo(kMoving);
      const double half = params.power / 2;
      parallelFor(d.z, [&](int64_t k0, int64_t k1) {
        for (int64_t t = k0 * d.x * d.y; t < k1 * d.x * d.y; ++t) {
          const uint8_t sd = side[static_cast<size_t>(t)];
          float& o = w.data()[t];
          if (sd == kStill) { o = 0.f; continue; }
          if (sd == kMoving) { o = 1.f; continue; }
          const double ds = dS2.data()[t], dm = dM2.data()[t];
          if (!std::isfinite(dm)) { o = 0.f; continue; }
          if (!std::isfinite(ds)) { o = 1.f; continue; }
          const double ps = std::pow(ds, half), pm = std::pow(dm, half);
          // Strictly inside (0, 1): exactly 0 and 1 mark the locked voxels (see below).
          o = std::clamp(static_cast<float>(ps / (ps + pm)), std::nextafter(0.f, 1.f), std::nextafter(1.f, 0.f));
        }
      });
    }
    progress.checkCancelled();

    // The bound: theta * dw/dalpha <= 1 - margin. Where it is passed, the free voxels around
    // take Jacobi steps towards their 6 neighbours' mean (w's bones and fixed regions stay
    // 0 / 1), over a region that grows by a voxel each round.
    const Slope slope{w.data(), d, output, st.c, st.a, st.theta, mmToIdx};
    const double bound = 1.0 - params.margin;
    double maxSlope = 0;
    auto scan = [&] {
      std::vector<int64_t> bad;
      std::mutex mutex;
      maxSlope = 0;
      parallelFor(d.z, [&](int64_t k0, int64_t k1) {
        std::vector<int64_t> local;
        double lmax = 0;
        for (int64_t k = k0; k < k1; ++k)
          for (int64_t j = 0; j < d.y; ++j)
            for (int64_t i = 0; i < d.x; ++i) {
              const double sl = slope.at(i, j, k);
              lmax = std::max(lmax, sl);
              if (sl > bound) local.push_back((k * d.y + j) * d.x + i);
            }
        std::lock_guard lock(mutex);
        bad.insert(bad.end(), local.begin(), local.end());
        maxSlope = std::max(maxSlope, lmax);
      });
      return bad;
    };
    std::vector<int64_t> bad = scan();
    stats.violationsBefore = static_cast<int64_t>(bad.size());
    stats.maxSlopeBefore = maxSlope;
    std::vector<uint8_t> touched;  // 1: relaxed at least once
    if (!bad.empty()) touched.assign(static_cast<size_t>(n), 0);
    std::vector<uint8_t> mark;
    const int64_t sy = d.x, sz = d.x * d.y;
    auto neighbours = [&](int64_t t, auto&& fn) {
      const int64_t i = t % d.x, j = (t / d.x) % d.y, k = t / sz;
      if (i > 0) fn(t - 1);
      if (i + 1 < d.x) fn(t + 1);
      if (j > 0) fn(t - sy);
      if (j + 1 < d.y) fn(t + sy);
      if (k > 0) fn(t - sz);
      if (k + 1 < d.z) fn(t + sz);
    };
    const bool lastStage = s + 1 == order.size();
    for (int pass = 0;; ++pass) {
      // Progress: the total excess over the bound (the count alone rises while the limiter's
      // front spreads a few large excesses into many small ones).
      double least = std::numeric_limits<double>::infinity();
      int stalled = 0;
      // Later passes only relax around the joined voxels: fewer rounds.
      const int rounds = pass == 0 ? params.maxRounds : params.maxRounds / 3;
      for (int round = 0; round < rounds && !bad.empty(); ++round) {
        progress.checkCancelled();
        ++stats.rounds;
        // The region: the violations grown by `radius` voxels (6-neighbour steps), free voxels only.
        const int radius = std::min(params.maxRadius, 2 + round);
        if (mark.empty()) mark.assign(static_cast<size_t>(n), 0);
        std::vector<int64_t> region, frontier = bad;
        for (int64_t t : frontier) mark[static_cast<size_t>(t)] = 1;
        region = frontier;
        for (int r = 0; r < radius; ++r) {
          std::vector<int64_t> next;
          for (int64_t t : frontier)
            neighbours(t, [&](int64_t q) {
              if (!mark[static_cast<size_t>(q)]) { mark[static_cast<size_t>(q)] = 1; next.push_back(q); }
            });
          region.insert(region.end(), next.begin(), next.end());
          frontier = std::move(next);
        }
        for (int64_t t : region) mark[static_cast<size_t>(t)] = 0;
        std::vector<int64_t> freeRegion;
        for (int64_t t : region)
          if (side[static_cast<size_t>(t)] == kFree) freeRegion.push_back(t);
        std::sort(freeRegion.begin(), freeRegion.end());
        std::vector<float> next(freeRegion.size());
        const int64_t nr = static_cast<int64_t>(freeRegion.size());
        // The smoothing in the first round only: later rounds carry the limiter's front on, which
        // smoothing would pull back.
        for (int step = 0; step < (round == 0 ? params.relaxSteps : 0); ++step) {
          parallelFor(nr, [&](int64_t r0, int64_t r1) {
            for (int64_t r = r0; r < r1; ++r) {
              double sum = 0;
              int cnt = 0;
              neighbours(freeRegion[static_cast<size_t>(r)], [&](int64_t q) { sum += w.data()[q]; ++cnt; });
              // Strictly inside (0, 1), as the free voxels always are.
              next[static_cast<size_t>(r)] = std::clamp(static_cast<float>(sum / cnt), std::nextafter(0.f, 1.f),
                                                         std::nextafter(1.f, 0.f));
            }
          }, 4096);
          for (int64_t r = 0; r < nr; ++r) w.data()[freeRegion[static_cast<size_t>(r)]] = next[static_cast<size_t>(r)];
        }
        // Then the limiter: along the circle through each free voxel, w may rise by at most
        // L = (1 - margin) / theta per radian (it may fall freely: a stretch), so w(v) is held
        // between w(v ahead) - L delta and w(v behind) + L delta, the neighbours one voxel of arc
        // ahead and behind (trilinear). Repeated, this carries the bound from the bones into the
        // free space along the circles, where the isotropic smoothing above spreads it in r and z
        // too (and stalls where a still and a moving bone face each other across a short arc).
        // A little under the bound: the check's central differences on the grid read the arc
        // steps' trilinear samples with some spread (the limiter alone settles at ~1.03 x its L).
        const double lim = 0.85 * bound / std::abs(st.theta);
        for (int step = 0; step < params.limitSteps; ++step) {
          parallelFor(nr, [&](int64_t r0, int64_t r1) {
            for (int64_t r = r0; r < r1; ++r) {
              const int64_t t = freeRegion[static_cast<size_t>(r)];
              const Vec3 v = output.indexToPhysical({double(t % d.x), double((t / d.x) % d.y), double(t / sz)});
              const Vec3 p = v - st.c;
              const double radius = norm(p - st.a * dot(st.a, p));
              float& o = next[static_cast<size_t>(r)];
              o = w.data()[t];
              if (radius < 1e-6) continue;
              const double delta = std::min(minSpacing / radius, 0.5) * (st.theta > 0 ? 1 : -1);
              // Clamped onto the grid: beyond its faces w is unknown, not 0 (a still region there
              // would hold the tissue next to a face still).
              const double ahead = w.sampleLinear(clampIndex(toIndex(st.c + turn(p, st.a, delta))));
              const double behind = w.sampleLinear(clampIndex(toIndex(st.c + turn(p, st.a, -delta))));
              const double lo = ahead - lim * std::abs(delta), hi = behind + lim * std::abs(delta);
              const double val = lo <= hi ? std::clamp(double(o), lo, hi) : 0.5 * (lo + hi);
              o = std::clamp(static_cast<float>(val), std::nextafter(0.f, 1.f), std::nextafter(1.f, 0.f));
            }
          }, 4096);
          for (int64_t r = 0; r < nr; ++r) w.data()[freeRegion[static_cast<size_t>(r)]] = next[static_cast<size_t>(r)];
        }
        for (int64_t t : freeRegion) touched[static_cast<size_t>(t)] = 1;
        // Recheck the region and its neighbours (the only slopes the steps changed).
        std::vector<int64_t> check = region;
        for (int64_t t : region)
          neighbours(t, [&](int64_t q) { check.push_back(q); });
        std::sort(check.begin(), check.end());
        check.erase(std::unique(check.begin(), check.end()), check.end());
        std::vector<int64_t> still;
        double excess = 0;
        for (int64_t t : check)
          if (const double sl = slope.at(t % d.x, (t / d.x) % d.y, t / sz); sl > bound) {
            still.push_back(t);
            excess += sl - bound;
          }
        // Violations outside the region stay as they were (none: the region holds them all).
        bad = std::move(still);
        // Stop when rounds no longer help: what is left is locked on both sides (a collision).
        if (excess < 0.98 * least) { least = excess; stalled = 0; }
        else if (++stalled >= (pass == 0 ? params.patience : params.patience / 2)) break;
      }
      // Consistent locks (the last joint's stage, whose output is the source): a blended voxel
      // whose source lands in a bone's voxel (nearest: the cells are not round about the axis)
      // joins that bone's side, w = 0 or 1 exactly, and the blend is relaxed again around it;
      // so the snap below has (nearly) nothing left to do, and no jump is left unrelaxed.
      if (!lastStage || pass >= params.lockPasses) break;
      std::vector<std::pair<int64_t, uint8_t>> joins;
      {
        std::mutex mutex;
        parallelFor(d.z, [&](int64_t k0, int64_t k1) {
          std::vector<std::pair<int64_t, uint8_t>> local;
          for (int64_t k = k0; k < k1; ++k)
            for (int64_t j = 0; j < d.y; ++j)
              for (int64_t i = 0; i < d.x; ++i) {
                const int64_t t = (k * d.y + j) * d.x + i;
                if (side[static_cast<size_t>(t)] != kFree) continue;
                const Vec3 v = output.indexToPhysical({double(i), double(j), double(k)});
                const double wt = w.data()[t];
                const Vec3 ui = toIndex(st.c + turn(v - st.c, st.a, -st.theta * wt));
                const int64_t si = std::llround(ui.x), sj = std::llround(ui.y), sk = std::llround(ui.z);
                if (si < 0 || sj < 0 || sk < 0 || si >= d.x || sj >= d.y || sk >= d.z) continue;
                const uint16_t c = cls[(sk * d.y + sj) * d.x + si];
                if (c < 2) continue;
                const bool moving = groups[static_cast<size_t>(bodyGroup[c - 2u])].moving;
                // Only a short step (the source moves by at most joinMaxVoxels): a long one is a
                // jump next to the other side's lock that no relaxation can spread (a collision).
                const Vec3 p = v - st.c;
                const double radius = norm(p - st.a * dot(st.a, p));
                const double step = std::abs(st.theta) * std::abs((moving ? 1.0 : 0.0) - wt) * radius;
                if (step > params.joinMaxVoxels * minSpacing)
                  continue;
                local.emplace_back(t, moving ? kMoving : kStill);
              }
          std::lock_guard lock(mutex);
          joins.insert(joins.end(), local.begin(), local.end());
        });
      }
      if (joins.empty()) break;
      for (const auto& [t, sd] : joins) {
        side[static_cast<size_t>(t)] = sd;
        w.data()[t] = sd == kMoving ? 1.f : 0.f;
      }
      stats.joinedVoxels += static_cast<int64_t>(joins.size());
      bad = scan();
      if (!bad.empty() && touched.empty()) touched.assign(static_cast<size_t>(n), 0);
    }
    mark.clear();
    mark.shrink_to_fit();
    for (uint8_t x : touched) stats.relaxedVoxels += x;
    stats.violationsAfter = static_cast<int64_t>(bad.size());
    for (int64_t t : bad) {
      const double sl = slope.at(t % d.x, (t / d.x) % d.y, t / sz);
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
    bodyBack[b] = inverse(f);
  }
  // The map: each output voxel through the stages' backward twists, proximal first. The first
  // stage reads w at the voxel itself; later ones at the moved position (trilinear, or the
  // nearest voxel's exact 0 / 1 when that voxel is locked, so the bones stay exactly rigid).
  result.mapMm.resize(static_cast<size_t>(n) * 3);
  float* out = result.mapMm.data();
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      progress.checkCancelled();
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int64_t t = (k * d.y + j) * d.x + i;
          Vec3 x = output.indexToPhysical({double(i), double(j), double(k)});
          for (size_t s = 0; s < stages.size(); ++s) {
            const Stage& st = stages[s];
            double wk;
            if (s == 0) {
              wk = weights[s].data()[t];
            } else {
              const Vec3 idx = toIndex(x);
              const double nearest = weights[s].sampleNearest(idx);
              wk = (nearest == 0.0 || nearest == 1.0) ? nearest : weights[s].sampleLinear(idx);
            }
            if (wk == 0.0) continue;
            x = wk == 1.0 ? st.c + st.backFull * (x - st.c) : st.c + turn(x - st.c, st.a, -st.theta * wk);
          }
          // The snap (as the MLS map's, RigidSnap): a blended voxel whose source lands in a body
          // takes that body's transform, so no output voxel shows bone moved non-rigidly (a
          // voxel beside a bone, w just under 1, would show its rim turned a little less).
          if (params.snap) {
            const Vec3 ui = toIndex(x);
            const int64_t si = std::llround(ui.x), sj = std::llround(ui.y), sk = std::llround(ui.z);
            if (si >= 0 && sj >= 0 && sk >= 0 && si < d.x && sj < d.y && sk < d.z)
              if (const uint16_t c = cls[(sk * d.y + sj) * d.x + si]; c >= 2)
                x = bodyBack[c - 2u].apply(output.indexToPhysical({double(i), double(j), double(k)}));
          }
          out[3 * t] = static_cast<float>(x.x);
          out[3 * t + 1] = static_cast<float>(x.y);
          out[3 * t + 2] = static_cast<float>(x.z);
        }
    }
  });
  return result;
}

}  // namespace vellum::deformation
