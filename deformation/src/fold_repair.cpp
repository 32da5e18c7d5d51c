// Fold repair: relax the free nodes around folding cells until they unfold (fold_repair.hpp).
#include "vellum/deformation/fold_repair.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>

#include "vellum/core/error.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::deformation {
namespace {

struct Grid {
  Dims d;
  Vec3 origin, ax, ay, az;  // node (i, j, k) sits at origin + i ax + j ay + k az (mm)
  double detIdx = 1;        // det of the index -> mm matrix
  explicit Grid(const Geometry& g) : d(g.dims), origin(g.origin) {
    const Mat3 m = indexToMm(g);
    ax = {m(0, 0), m(1, 0), m(2, 0)};
    ay = {m(0, 1), m(1, 1), m(2, 1)};
    az = {m(0, 2), m(1, 2), m(2, 2)};
    detIdx = m.determinant();
  }
  int64_t node(int64_t i, int64_t j, int64_t k) const { return (k * d.y + j) * d.x + i; }
  /// node()'s inverse: the (i, j, k) of node (or cell) index n.
  std::array<int64_t, 3> ijk(int64_t n) const { return {n % d.x, (n / d.x) % d.y, n / (d.x * d.y)}; }
  Vec3 v(int64_t i, int64_t j, int64_t k) const { return origin + ax * double(i) + ay * double(j) + az * double(k); }
  int64_t cells() const { return d.x > 1 && d.y > 1 && d.z > 1 ? d.voxelCount() : 0; }
  bool isCell(int64_t i, int64_t j, int64_t k) const {
    return i >= 0 && j >= 0 && k >= 0 && i + 1 < d.x && j + 1 < d.y && k + 1 < d.z;
  }
};

Vec3 at(const std::vector<float>& u, int64_t n) { return {u[3 * n], u[3 * n + 1], u[3 * n + 2]}; }

double cellMin(const std::vector<float>& u, const Grid& g, int64_t i, int64_t j, int64_t k) {
  Vec3 p[8];
  for (int q = 0; q < 8; ++q) p[q] = at(u, g.node(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1)));
  double worst = std::numeric_limits<double>::infinity();
  // The trilinear Jacobian at each corner: the three edges leaving it (in +i, +j, +k order).
  for (int q = 0; q < 8; ++q) {
    const int a = q & 1, b = (q >> 1) & 1, c = (q >> 2) & 1;
    const Vec3 ex = p[1 + 2 * b + 4 * c] - p[0 + 2 * b + 4 * c];
    const Vec3 ey = p[a + 2 + 4 * c] - p[a + 0 + 4 * c];
    const Vec3 ez = p[a + 2 * b + 4] - p[a + 2 * b + 0];
    worst = std::min(worst, dot(ex, cross(ey, ez)));
  }
  // ... and at the centre (the mean edges).
  Vec3 ex{0, 0, 0}, ey{0, 0, 0}, ez{0, 0, 0};
  for (int q = 0; q < 4; ++q) {
    const int b = q & 1, c = q >> 1;
    ex += p[1 + 2 * b + 4 * c] - p[2 * b + 4 * c];
    ey += p[b + 2 + 4 * c] - p[b + 4 * c];
    ez += p[b + 2 * c + 4] - p[b + 2 * c];
  }
  worst = std::min(worst, dot(ex, cross(ey, ez)) / 64.0);
  return worst / g.detIdx;
}

// Is any cell's smallest Jacobian (cellMin) below `threshold`? The repair's first question on
// every solve (the studio's drag, every movie frame), where the answer is almost always no:
// float arithmetic over rows of cells (each row's four node rows read in order, the corners
// shared with the next cell), parallel over slabs, and every slab stops once one is found.
// A cell near the threshold is passed to the exact (double) scan: float rounding of the
// products cannot hide a fold (the margin is far above it). Returns the smallest cellMin over
// all cells when none is below (what the full scan reports then), nullopt when one is.
std::optional<double> anyCellBelow(const std::vector<float>& u, const Grid& g, double threshold) {
  std::atomic<bool> found{false};
  double smallest = std::numeric_limits<double>::infinity();
  std::mutex mutex;
  // Compared against det(edges) in index units: cellMin's value times detIdx, with a margin.
  const float limit = static_cast<float>((threshold + 0.05) * g.detIdx);
  const int64_t nx = g.d.x, rowStride = g.d.x, sliceStride = g.d.x * g.d.y;
  parallelFor(g.d.z - 1, [&](int64_t k0, int64_t k1) {
    float localMin = std::numeric_limits<float>::infinity();
    using V = std::array<float, 3>;
    auto sub = [](const float* a, const float* b) { return V{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
    auto det = [](const V& x, const V& y, const V& z) {
      return x[0] * (y[1] * z[2] - y[2] * z[1]) + x[1] * (y[2] * z[0] - y[0] * z[2]) + x[2] * (y[0] * z[1] - y[1] * z[0]);
    };
    for (int64_t k = k0; k < k1; ++k) {
      if (found.load(std::memory_order_relaxed)) return;
      for (int64_t j = 0; j + 1 < g.d.y; ++j) {
        // Node rows (j, k), (j+1, k), (j, k+1), (j+1, k+1): corners q = a + 2b + 4c.
        const float* r[4] = {u.data() + 3 * (k * sliceStride + j * rowStride),
                             u.data() + 3 * (k * sliceStride + (j + 1) * rowStride),
                             u.data() + 3 * ((k + 1) * sliceStride + j * rowStride),
                             u.data() + 3 * ((k + 1) * sliceStride + (j + 1) * rowStride)};
        for (int64_t i = 0; i + 1 < nx; ++i) {
          const float* p[8];
          for (int q = 0; q < 4; ++q) {
            p[2 * q] = r[q] + 3 * i;
            p[2 * q + 1] = r[q] + 3 * (i + 1);
          }
          // p index = a + 2 * (b + 2 * c): same corner numbering as cellMin.
          V ex[4], ey[4], ez[4];
          for (int t = 0; t < 4; ++t) {
            const int b = t & 1, c = t >> 1;
            ex[t] = sub(p[1 + 2 * b + 4 * c], p[2 * b + 4 * c]);     // x edge at (b, c)
            ey[t] = sub(p[b + 2 + 4 * c], p[b + 4 * c]);             // y edge at (a = b, c)
            ez[t] = sub(p[b + 2 * c + 4], p[b + 2 * c]);             // z edge at (a = b, b = c)
          }
          float worst = std::numeric_limits<float>::infinity();
          for (int q = 0; q < 8; ++q) {
            const int a = q & 1, b = (q >> 1) & 1, c = (q >> 2) & 1;
            worst = std::min(worst, det(ex[b + 2 * c], ey[a + 2 * c], ez[a + 2 * b]));
          }
          V mx{0, 0, 0}, my{0, 0, 0}, mz{0, 0, 0};
          for (int t = 0; t < 4; ++t)
            for (int a = 0; a < 3; ++a) {
              mx[a] += ex[t][a];
              my[a] += ey[t][a];
              mz[a] += ez[t][a];
            }
          worst = std::min(worst, det(mx, my, mz) / 64.0f);
          if (!(worst >= limit)) {  // NaN counts as below
            found.store(true, std::memory_order_relaxed);
            return;
          }
          localMin = std::min(localMin, worst);
        }
      }
    }
    std::lock_guard lock(mutex);
    smallest = std::min(smallest, double(localMin));
  });
  if (found.load()) return std::nullopt;
  return smallest / g.detIdx;
}

// Does the caller care about cell (i, j, k): any of its corners' source positions (all, when
// `cares` is empty)?
bool caredFor(const std::vector<float>& u, const Grid& g, int64_t i, int64_t j, int64_t k,
              const std::function<bool(const Vec3&)>& cares) {
  if (!cares) return true;
  for (int q = 0; q < 8; ++q)
    if (cares(at(u, g.node(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1))))) return true;
  return false;
}

// Cells below the threshold that the caller cares about, from a list of candidate cells (node
// index of their lowest corner), or from every cell when `candidates` is null.
struct Scan {
  std::vector<int64_t> bad;
  double minDet = std::numeric_limits<double>::infinity();
  double goodMin = std::numeric_limits<double>::infinity();  ///< over the cells at or above the threshold
};
Scan scanCells(const std::vector<float>& u, const Grid& g, const std::vector<int64_t>* candidates, double threshold,
               const std::function<bool(const Vec3&)>& cares) {
  Scan s;
  std::mutex mutex;
  const int64_t n = candidates ? static_cast<int64_t>(candidates->size()) : g.d.z;
  parallelFor(n, [&](int64_t t0, int64_t t1) {
    Scan local;
    auto visit = [&](int64_t i, int64_t j, int64_t k) {
      const double det = cellMin(u, g, i, j, k);
      if (det >= threshold) {
        local.minDet = std::min(local.minDet, det);
        local.goodMin = std::min(local.goodMin, det);
        return;
      }
      if (!caredFor(u, g, i, j, k, cares)) return;
      local.minDet = std::min(local.minDet, det);
      local.bad.push_back(g.node(i, j, k));
    };
    if (candidates) {
      for (int64_t t = t0; t < t1; ++t) {
        const int64_t c = (*candidates)[static_cast<size_t>(t)];
        const auto [i, j, k] = g.ijk(c);
        visit(i, j, k);
      }
    } else {
      for (int64_t k = t0; k < std::min(t1, g.d.z - 1); ++k)
        for (int64_t j = 0; j + 1 < g.d.y; ++j)
          for (int64_t i = 0; i + 1 < g.d.x; ++i) visit(i, j, k);
    }
    std::lock_guard lock(mutex);
    s.bad.insert(s.bad.end(), local.bad.begin(), local.bad.end());
    s.minDet = std::min(s.minDet, local.minDet);
    s.goodMin = std::min(s.goodMin, local.goodMin);
  });
  std::sort(s.bad.begin(), s.bad.end());
  return s;
}

}  // namespace

double cellMinJacobian(const ControlVolume& cv, int64_t i, int64_t j, int64_t k) {
  const Grid g(cv.grid);
  if (!g.isCell(i, j, k)) throw Error("cellMinJacobian: no such cell");
  return cellMin(cv.sourceMm, g, i, j, k);
}

FoldRepairStats repairFolds(ControlVolume& cv, const std::vector<uint8_t>& locked,
                            const std::function<bool(const Vec3&)>& cares, const FoldRepairParams& params,
                            const std::function<bool(const Vec3&)>& forbidden) {
  FoldRepairStats st;
  const Grid g(cv.grid);
  const int64_t nodes = g.d.voxelCount();
  if (cv.sourceMm.size() != 3 * static_cast<size_t>(nodes)) throw Error("fold repair: control volume size does not match its grid");
  if (!locked.empty() && locked.size() != static_cast<size_t>(nodes)) throw Error("fold repair: lock mask size does not match the grid");
  if (g.cells() == 0) return st;
  std::vector<float>& u = cv.sourceMm;
  // Nothing folds (the usual case): one fast pass, no per-cell bookkeeping.
  if (const std::optional<double> least = anyCellBelow(u, g, params.minJacobian)) {
    st.minJacobianBefore = st.minJacobianAfter = *least;
    return st;
  }
  Scan scan = scanCells(u, g, nullptr, params.minJacobian, cares);
  st.cellsBefore = static_cast<int64_t>(scan.bad.size());
  st.minJacobianBefore = scan.minDet;
  st.minJacobianAfter = scan.minDet;
  if (scan.bad.empty()) return st;
  const double untouchedMin = scan.goodMin;  // cells never written around keep their det
  // Every cell that was folding or had a corner moved: the only ones the final count must visit.
  std::vector<uint8_t> visited(static_cast<size_t>(nodes), 0);
  std::vector<int64_t> visitedList = scan.bad;
  for (int64_t c : scan.bad) visited[static_cast<size_t>(c)] = 1;
  // The lock levels, copied: soft locks are released below where a fold is locked all round.
  std::vector<uint8_t> lock = locked;
  auto isLocked = [&](int64_t n) { return !lock.empty() && lock[static_cast<size_t>(n)] != kNodeFree; };
  auto corners = [&](int64_t c, int64_t (&out)[8]) {
    const auto [i, j, k] = g.ijk(c);
    for (int q = 0; q < 8; ++q) out[q] = g.node(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1));
  };
  auto allHard = [&](int64_t c) {
    int64_t n[8];
    corners(c, n);
    for (int q = 0; q < 8; ++q)
      if (lock.empty() || lock[static_cast<size_t>(n[q])] != kNodeHardLock) return false;
    return true;
  };
  // A folding cell whose 8 corners are all locked (two bodies' cores, or a core and a fixed
  // region's margin, meet in it: bones turning differently side by side) gets its soft-locked
  // corners released: a node only has to hold where it lies inside its bone (the voxel snap
  // and the midpoint guard below keep the bone's voxels exact). A cell locked hard all round
  // (two bodies' voxels in one cell) cannot be repaired here and is dropped: growing a region
  // around it would only smooth tissue for nothing.
  auto dropLocked = [&](std::vector<int64_t>& cells) {
    cells.erase(std::remove_if(cells.begin(), cells.end(),
                               [&](int64_t c) {
                                 int64_t n[8];
                                 corners(c, n);
                                 bool anyFree = false;
                                 for (int q = 0; q < 8 && !anyFree; ++q) anyFree = !isLocked(n[q]);
                                 if (anyFree) return false;
                                 bool released = false;
                                 for (int q = 0; q < 8; ++q)
                                   if (lock[static_cast<size_t>(n[q])] == kNodeSoftLock) {
                                     lock[static_cast<size_t>(n[q])] = kNodeFree;
                                     ++st.nodesReleased;
                                     released = true;
                                   }
                                 return !released;
                               }),
                cells.end());
  };
  dropLocked(scan.bad);
  // Each pass moves the free corners of every folding cell so that its Jacobians rise: for
  // every Jacobian of the cell below the threshold (at a corner or the centre: a cubic in the
  // corner positions) the smallest move of the free corners that lifts its linearisation to the
  // threshold (a projection, Kaczmarz); a node in several such terms takes the mean of their
  // moves (Cimmino), at most a fifth of a node spacing per pass. The cells around a moved node
  // are checked next pass, so a fold spreads into a transition just wide enough to stay above
  // the threshold; nodes away from folds are never written.
  std::vector<float> pull(3 * static_cast<size_t>(nodes), 0.f);
  std::vector<uint8_t> count(static_cast<size_t>(nodes), 0), written(static_cast<size_t>(nodes), 0), seen(static_cast<size_t>(nodes), 0);
  std::vector<int64_t> touched, cellMark;
  const double target = params.minJacobian + 0.1;
  auto intoBody = [&](int64_t n, const Vec3& next) {
    if (forbidden(next)) return true;
    const auto [i, j, k] = g.ijk(n);
    for (int64_t c = std::max<int64_t>(k - 1, 0); c <= std::min(k + 1, g.d.z - 1); ++c)
      for (int64_t b = std::max<int64_t>(j - 1, 0); b <= std::min(j + 1, g.d.y - 1); ++b)
        for (int64_t a = std::max<int64_t>(i - 1, 0); a <= std::min(i + 1, g.d.x - 1); ++a)
          if (g.node(a, b, c) != n && forbidden((next + at(u, g.node(a, b, c))) * 0.5)) return true;
    return false;
  };
  constexpr double kWorstFloor = -1.0;
  auto worstAround = [&](int64_t n) {
    const auto [i, j, k] = g.ijk(n);
    double w = std::numeric_limits<double>::infinity();
    for (int q = 0; q < 8; ++q) {
      const int64_t a = i - (q & 1), b = j - ((q >> 1) & 1), c = k - ((q >> 2) & 1);
      if (g.isCell(a, b, c)) w = std::min(w, cellMin(u, g, a, b, c));
    }
    return w;
  };
  const double maxStep = 0.2 * cv.grid.minSpacing();
  // Passes without fewer folding cells after which the repair gives up.
  constexpr int kStallRounds = 50;
  size_t fewest = scan.bad.size();
  int lastGain = 0;
  bool releasedAtStall = false;
  for (; st.rounds < params.maxRounds && !scan.bad.empty(); ++st.rounds) {
    touched.clear();
    for (int64_t c : scan.bad) {
      const auto [i, j, k] = g.ijk(c);
      int64_t corner[8];
      Vec3 p[8];
      bool free[8];
      for (int q = 0; q < 8; ++q) {
        corner[q] = g.node(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1));
        p[q] = at(u, corner[q]);
        free[q] = !isLocked(corner[q]);
      }
      // Corner terms: at corner (a, b, c) the edges leaving it.
      auto addTerm = [&](const Vec3 (&dEdge)[3], const int (&hiq)[3][4], const int (&loq)[3][4], int n, double det) {
        Vec3 grad[8];
        for (auto& v : grad) v = {0, 0, 0};
        for (int e = 0; e < 3; ++e)
          for (int t = 0; t < n; ++t) {
            grad[hiq[e][t]] += dEdge[e] / double(n);
            grad[loq[e][t]] -= dEdge[e] / double(n);
          }
        double norm2 = 0;
        for (int q = 0; q < 8; ++q)
          if (free[q]) norm2 += dot(grad[q], grad[q]);
        if (norm2 <= 1e-30) return;
        const double scale = (target - det) / norm2;
        for (int q = 0; q < 8; ++q) {
          if (!free[q]) continue;
          const Vec3 d = grad[q] * scale;
          float* o = pull.data() + 3 * corner[q];
          o[0] += static_cast<float>(d.x); o[1] += static_cast<float>(d.y); o[2] += static_cast<float>(d.z);
          if (count[static_cast<size_t>(corner[q])]++ == 0) touched.push_back(corner[q]);
        }
      };
      for (int q = 0; q < 8; ++q) {
        const int a = q & 1, b = (q >> 1) & 1, e = (q >> 2) & 1;
        const int hiq[3][4] = {{1 + 2 * b + 4 * e}, {a + 2 + 4 * e}, {a + 2 * b + 4}};
        const int loq[3][4] = {{2 * b + 4 * e}, {a + 4 * e}, {a + 2 * b}};
        const Vec3 ex = p[hiq[0][0]] - p[loq[0][0]], ey = p[hiq[1][0]] - p[loq[1][0]], ez = p[hiq[2][0]] - p[loq[2][0]];
        const double det = dot(ex, cross(ey, ez)) / g.detIdx;
        if (det >= target) continue;
        const Vec3 dEdge[3] = {cross(ey, ez) / g.detIdx, cross(ez, ex) / g.detIdx, cross(ex, ey) / g.detIdx};
        addTerm(dEdge, hiq, loq, 1, det);
      }
      {  // the centre: mean edges
        int hiq[3][4], loq[3][4];
        Vec3 ex{0, 0, 0}, ey{0, 0, 0}, ez{0, 0, 0};
        for (int t = 0; t < 4; ++t) {
          const int b = t & 1, e = t >> 1;
          hiq[0][t] = 1 + 2 * b + 4 * e; loq[0][t] = 2 * b + 4 * e;
          hiq[1][t] = b + 2 + 4 * e;     loq[1][t] = b + 4 * e;
          hiq[2][t] = b + 2 * e + 4;     loq[2][t] = b + 2 * e;
          ex += (p[hiq[0][t]] - p[loq[0][t]]) / 4.0;
          ey += (p[hiq[1][t]] - p[loq[1][t]]) / 4.0;
          ez += (p[hiq[2][t]] - p[loq[2][t]]) / 4.0;
        }
        const double det = dot(ex, cross(ey, ez)) / g.detIdx;
        if (det < target) {
          const Vec3 dEdge[3] = {cross(ey, ez) / g.detIdx, cross(ez, ex) / g.detIdx, cross(ex, ey) / g.detIdx};
          addTerm(dEdge, hiq, loq, 4, det);
        }
      }
    }
    if (touched.empty()) break;
    cellMark.clear();
    for (int64_t n : touched) {
      float* p = pull.data() + 3 * n;
      Vec3 step = Vec3{p[0], p[1], p[2]} / double(count[static_cast<size_t>(n)]);
      if (const double len = norm(step); len > maxStep) step = step * (maxStep / len);
      const Vec3 next = at(u, n) + step;
      p[0] = p[1] = p[2] = 0;
      count[static_cast<size_t>(n)] = 0;
      // A node may not move into a rigid body, nor bring the voxels between it and a neighbour
      // there (the midpoints stand for them): they would show bone moved non-rigidly.
      if (forbidden && intoBody(n, next)) continue;
      // No gross folds made: a move that drops the worst of the node's 8 cells below -1 (or
      // deeper, where it already was) is undone; shallow transient dips are what the
      // projections need to get out of a fold. Without it, nodes released next to two bodies locked hard
      // with very different transforms (the hallux on the feet) were pushed into ever worse cells.
      const double worstBefore = worstAround(n);
      float old[3];
      for (int a = 0; a < 3; ++a) {
        old[a] = u[static_cast<size_t>(3 * n + a)];
        u[static_cast<size_t>(3 * n + a)] = static_cast<float>(next[a]);
      }
      if (const double worstAfter = worstAround(n); worstAfter < worstBefore && worstAfter < kWorstFloor) {
        for (int a = 0; a < 3; ++a) u[static_cast<size_t>(3 * n + a)] = old[a];
        continue;
      }
      if (!written[static_cast<size_t>(n)]) { written[static_cast<size_t>(n)] = 1; ++st.nodesRelaxed; }
      // The 8 cells around the node changed.
      const auto [i, j, k] = g.ijk(n);
      for (int q = 0; q < 8; ++q) {
        const int64_t a = i - (q & 1), b = j - ((q >> 1) & 1), c = k - ((q >> 2) & 1);
        if (!g.isCell(a, b, c)) continue;
        const int64_t cell = g.node(a, b, c);
        if (!seen[static_cast<size_t>(cell)]) { seen[static_cast<size_t>(cell)] = 1; cellMark.push_back(cell); }
      }
    }
    for (int64_t c : cellMark) {
      seen[static_cast<size_t>(c)] = 0;
      if (!visited[static_cast<size_t>(c)]) { visited[static_cast<size_t>(c)] = 1; visitedList.push_back(c); }
    }
    // Once a fold is being repaired its neighbours are checked whether they map to tissue or
    // not: the compression must be free to spread into the air next to the skin.
    scan = scanCells(u, g, &cellMark, params.minJacobian, {});
    dropLocked(scan.bad);
    // Stalled (what is left is held by locked nodes): stop rather than spin.
    if (scan.bad.size() < fewest) {
      fewest = scan.bad.size();
      lastGain = st.rounds;
    } else if (st.rounds - lastGain > kStallRounds) {
      // Stalled: the free corners cannot lift what is left. Once, release the soft locks of
      // every cell still folding (a cell with 4-7 locked corners may need them) and go on.
      bool released = false;
      if (!releasedAtStall)
        for (int64_t c : scan.bad) {
          int64_t n[8];
          corners(c, n);
          for (int q = 0; q < 8; ++q)
            if (!lock.empty() && lock[static_cast<size_t>(n[q])] == kNodeSoftLock) {
              lock[static_cast<size_t>(n[q])] = kNodeFree;
              ++st.nodesReleased;
              released = true;
            }
        }
      releasedAtStall = true;
      if (!released) {
        ++st.rounds;
        break;
      }
      lastGain = st.rounds;
    }
  }
  // Second stage, where the projections stalled: relax the free nodes around each cluster of
  // cells still folding towards the mean of their neighbours (Jacobi steps of a harmonic map:
  // a smooth transition between whatever the locked nodes hold), in a neighbourhood grown one
  // cell at a time; a cluster's relaxation is kept only when it leaves fewer folding cells
  // (det <= 0 first, then below the threshold) among the cells it touched.
  if (params.relaxRadius > 0) {
    std::vector<int64_t> bad = scanCells(u, g, &visitedList, params.minJacobian, cares).bad;
    bad.erase(std::remove_if(bad.begin(), bad.end(), allHard), bad.end());
    std::vector<uint8_t> inRegion(static_cast<size_t>(nodes), 0), cellSeen(static_cast<size_t>(nodes), 0);
    for (int r = 1; r <= params.relaxRadius && !bad.empty(); ++r) {
      // Clusters: folding cells that touch (26-connected). Small clusters are accepted or
      // rejected on their own (a wider grouping, cells within 2r + 1, merged the feet's folds
      // into 4 clusters and kept relaxations that helped one site and hurt another: 0.19 %
      // of tissue voxels folding against 0.13 %, at 40 steps).
      std::vector<uint8_t> isBad(static_cast<size_t>(nodes), 0), done(static_cast<size_t>(nodes), 0);
      for (int64_t c : bad) isBad[static_cast<size_t>(c)] = 1;
      constexpr int64_t reach = 1;
      for (int64_t c0 : bad) {
        if (done[static_cast<size_t>(c0)]) continue;
        std::vector<int64_t> cluster{c0}, stack{c0};
        done[static_cast<size_t>(c0)] = 1;
        while (!stack.empty()) {
          const int64_t c = stack.back();
          stack.pop_back();
          const auto [i, j, k] = g.ijk(c);
          for (int64_t e = std::max<int64_t>(k - reach, 0); e <= std::min(k + reach, g.d.z - 2); ++e)
            for (int64_t b = std::max<int64_t>(j - reach, 0); b <= std::min(j + reach, g.d.y - 2); ++b)
              for (int64_t a = std::max<int64_t>(i - reach, 0); a <= std::min(i + reach, g.d.x - 2); ++a) {
                const int64_t o = g.node(a, b, e);
                if (!isBad[static_cast<size_t>(o)] || done[static_cast<size_t>(o)]) continue;
                done[static_cast<size_t>(o)] = 1;
                cluster.push_back(o);
                stack.push_back(o);
              }
        }
        // The free nodes within r of the cluster's cells, and the cells they touch.
        std::vector<int64_t> region, cells;
        for (int64_t c : cluster) {
          const auto [i, j, k] = g.ijk(c);
          for (int64_t e = std::max<int64_t>(k - r, 0); e <= std::min(k + 1 + r, g.d.z - 1); ++e)
            for (int64_t b = std::max<int64_t>(j - r, 0); b <= std::min(j + 1 + r, g.d.y - 1); ++b)
              for (int64_t a = std::max<int64_t>(i - r, 0); a <= std::min(i + 1 + r, g.d.x - 1); ++a) {
                const int64_t n = g.node(a, b, e);
                if (isLocked(n) || inRegion[static_cast<size_t>(n)]) continue;
                inRegion[static_cast<size_t>(n)] = 1;
                region.push_back(n);
                for (int q = 0; q < 8; ++q) {
                  const int64_t ca = a - (q & 1), cb = b - ((q >> 1) & 1), cc = e - ((q >> 2) & 1);
                  if (!g.isCell(ca, cb, cc)) continue;
                  const int64_t cell = g.node(ca, cb, cc);
                  if (!cellSeen[static_cast<size_t>(cell)]) { cellSeen[static_cast<size_t>(cell)] = 1; cells.push_back(cell); }
                }
              }
        }
        auto score = [&]() {
          std::pair<int64_t, int64_t> sc{0, 0};
          for (int64_t c : cells) {
            const auto [i, j, k] = g.ijk(c);
            const double det = cellMin(u, g, i, j, k);
            if (det >= params.minJacobian) continue;
            if (!caredFor(u, g, i, j, k, cares)) continue;
            if (det <= 0) ++sc.first;
            ++sc.second;
          }
          return sc;
        };
        const auto before = score();
        std::vector<float> saved(3 * region.size()), fresh(3 * region.size());
        for (size_t t = 0; t < region.size(); ++t)
          for (int a = 0; a < 3; ++a) saved[3 * t + static_cast<size_t>(a)] = u[static_cast<size_t>(3 * region[t] + a)];
        for (int it = 0; it < params.relaxSteps; ++it) {
          for (size_t t = 0; t < region.size(); ++t) {
            const int64_t n = region[t];
            const auto [i, j, k] = g.ijk(n);
            Vec3 sum{0, 0, 0};
            int cnt = 0;
            const int64_t nb[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
            for (const auto& q : nb) {
              if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= g.d.x || q[1] >= g.d.y || q[2] >= g.d.z) continue;
              // The neighbour's source position, carried to this node as u - v (a displacement).
              sum += at(u, g.node(q[0], q[1], q[2])) - g.v(q[0], q[1], q[2]);
              ++cnt;
            }
            const Vec3 next = g.v(i, j, k) + sum / double(std::max(cnt, 1));
            for (int a = 0; a < 3; ++a) fresh[3 * t + static_cast<size_t>(a)] = static_cast<float>(next[a]);
          }
          for (size_t t = 0; t < region.size(); ++t)
            if (!forbidden || !intoBody(region[t], {fresh[3 * t], fresh[3 * t + 1], fresh[3 * t + 2]}))
              for (int a = 0; a < 3; ++a) u[static_cast<size_t>(3 * region[t] + a)] = fresh[3 * t + static_cast<size_t>(a)];
        }
        const auto after = score();
        if (after < before) {
          ++st.clustersRelaxed;
          for (int64_t n : region)
            if (!written[static_cast<size_t>(n)]) { written[static_cast<size_t>(n)] = 1; ++st.nodesRelaxed; }
        } else {
          for (size_t t = 0; t < region.size(); ++t)
            for (int a = 0; a < 3; ++a) u[static_cast<size_t>(3 * region[t] + a)] = saved[3 * t + static_cast<size_t>(a)];
        }
        for (int64_t n : region) inRegion[static_cast<size_t>(n)] = 0;
        for (int64_t c : cells) {
          cellSeen[static_cast<size_t>(c)] = 0;
          if (!visited[static_cast<size_t>(c)]) { visited[static_cast<size_t>(c)] = 1; visitedList.push_back(c); }
        }
      }
      bad = scanCells(u, g, &visitedList, params.minJacobian, cares).bad;
      bad.erase(std::remove_if(bad.begin(), bad.end(), allHard), bad.end());
    }
  }
  // The final count over every cell that folded or had a corner moved (a relaxed node may have
  // bent a cell it was not checked in); the others are as the first scan found them.
  const Scan after = scanCells(u, g, &visitedList, params.minJacobian, cares);
  st.cellsAfter = static_cast<int64_t>(after.bad.size());
  st.minJacobianAfter = std::min(after.minDet, untouchedMin);
  st.lockedCells = std::count_if(after.bad.begin(), after.bad.end(), allHard);
  return st;
}

}  // namespace vellum::deformation
