// Narrow-band level-set evolution for the 3D snake (see snake.hpp for the equation).
//
// phi is stored densely (float, mm) but only a band of voxels around the zero level is ever
// read or written: the band is a list, rebuilt from the voxels next to a sign change
// (sub-voxel distances from the crossings), then grown outward breadth-first with a local
// Eikonal update. Voxels beyond the band hold +-clamp, so their sign (inside/outside) is
// always right. Each iteration updates only the "active" part of the band (|phi| within two
// steps of motion plus a voxel). The band is rebuilt every kMaxStepsBetweenRebuilds steps, or
// right after a step in which a voxel changed side next to a non-active voxel (the front
// reached the edge of what is updated), so the front never runs out of active voxels.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <memory>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <numeric>

#include "vellum/core/parallel.hpp"
#include "vellum/segmentation/snake.hpp"

namespace vellum::segmentation {
namespace {

/// The active voxels cover this many steps of front motion (at the CFL limit) plus a voxel.
constexpr int kActiveSteps = 2;
/// phi is re-distanced at least this often (it drifts from a distance function between
/// rebuilds); sooner when the front touches the edge of the active voxels. 2 (a rebuild every
/// other step) gave the same Dice on the phantom snakes and took 1.5-2x longer.
constexpr int kMaxStepsBetweenRebuilds = 5;
constexpr uint8_t kBorder = 0x80;  ///< bit in code_: voxel on a face of the grid
constexpr uint8_t kActive = 0x40;  ///< bit in code_: voxel in the active list
constexpr uint8_t kLayer = 0x3f;   ///< bits in code_: 0 = not in band, 1 = interface, n = n-1 steps out

class Evolver {
 public:
  Evolver(const VolumeF32& speed, bool edge, const SnakeParams& p)
      : d_(speed.dims()), g_(speed.geometry()), S_(speed.data()), edge_(edge), p_(p),
        advection_(resolvedAdvection(p, edge ? SpeedType::Edge : SpeedType::Threshold)) {
    sy_ = d_.x;
    sz_ = d_.x * d_.y;
    h_[0] = g_.spacing.x; h_[1] = g_.spacing.y; h_[2] = g_.spacing.z;
    hmin_ = std::min({h_[0], h_[1], h_[2]});
    hmax_ = std::max({h_[0], h_[1], h_[2]});
    // Any voxel the contour can reach before the next rebuild, plus one voxel on the coarsest axis.
    activeWidth_ = kActiveSteps * p_.cflNumber * hmin_ + hmax_;
    expandWidth_ = activeWidth_;  // one more layer beyond the active voxels covers their stencils
    clamp_ = static_cast<float>(expandWidth_ + 2.0 * hmax_);
    checkMemoryBudget(static_cast<uint64_t>(d_.voxelCount()) * 5, "snake level set");
    phi_.resize(static_cast<size_t>(d_.voxelCount()));  // every caller fills it densely
    code_.assign(static_cast<size_t>(d_.voxelCount()), 0);
    // Flag the voxels on the faces of the grid once (faces only, not a volume scan): only
    // they need bounds checks.
    parallelFor(d_.z, [&](int64_t k0, int64_t k1) {
      for (int64_t k = k0; k < k1; ++k) {
        uint8_t* slice = code_.data() + k * sz_;
        if (k == 0 || k == d_.z - 1) {
          std::fill(slice, slice + sz_, kBorder);
          continue;
        }
        std::fill(slice, slice + d_.x, kBorder);
        std::fill(slice + (d_.y - 1) * sy_, slice + sz_, kBorder);
        for (int64_t j = 1; j + 1 < d_.y; ++j) slice[j * sy_] = slice[j * sy_ + d_.x - 1] = kBorder;
      }
    });
  }

  float clampValue() const { return clamp_; }
  std::vector<float>& phi() { return phi_; }

  /// Sets phi from a dense initial function (already in mm) and builds the band. Used on the
  /// coarsest level only (the grid is small there).
  void initialise() {
    for (auto& v : phi_) v = std::clamp(v, -clamp_, clamp_);
    // Dense scan for the first interface.
    std::vector<std::vector<int64_t>> perSlab(static_cast<size_t>(d_.z));
    parallelFor(d_.z, [&](int64_t k0, int64_t k1) {
      for (int64_t k = k0; k < k1; ++k)
        for (int64_t j = 0; j < d_.y; ++j)
          for (int64_t i = 0; i < d_.x; ++i) {
            const int64_t q = k * sz_ + j * sy_ + i;
            if (crossing(q)) perSlab[k].push_back(q);
          }
    });
    std::vector<int64_t> iface;
    for (auto& s : perSlab) iface.insert(iface.end(), s.begin(), s.end());
    band_.clear();
    buildBand(iface);
  }

  /// Starts from the converged level at half this resolution (its grid = this one
  /// downsampled by downsample2). Only voxels near the coarse band are interpolated and
  /// scanned; the rest of the grid takes the sign of its coarse parent (one cheap write pass),
  /// so the set-up cost follows the surface like the iterations do.
  void initialiseFrom(const Evolver& coarse, double shrinkMm) {
    const float shrink = static_cast<float>(shrinkMm);
    const Dims cd = coarse.d_;
    const int64_t csy = coarse.sy_, csz = coarse.sz_;
    const float* cphi = coarse.phi_.data();
    // Fine index i has coarse coordinate (i - 0.5) / 2, whose nearest coarse voxel is i / 2.
    parallelFor(d_.z, [&](int64_t k0, int64_t k1) {
      for (int64_t k = k0; k < k1; ++k)
        for (int64_t j = 0; j < d_.y; ++j) {
          const float* crow = cphi + (k / 2) * csz + (j / 2) * csy;
          float* row = phi_.data() + k * sz_ + j * sy_;
          for (int64_t i = 0; i < d_.x; ++i) row[i] = crow[i / 2] + shrink <= 0 ? -clamp_ : clamp_;
        }
    });
    // Trilinear values for the children of the coarse band; the children of the coarse
    // active voxels are the candidates for the first interface.
    const std::vector<int64_t>& cband = coarse.band_;
    std::vector<std::array<int64_t, 8>> kids(cband.size());
    std::vector<uint8_t> near(cband.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cband.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t b = r.begin(); b < r.end(); ++b) {
        const int64_t cq = cband[b];
        const int64_t ck = cq / csz, cj = (cq - ck * csz) / csy, ci = cq - ck * csz - cj * csy;
        near[b] = std::abs(cphi[cq] + shrink) <= coarse.activeWidth_;
        int n = 0;
        for (int64_t k = 2 * ck; k <= 2 * ck + 1; ++k)
          for (int64_t j = 2 * cj; j <= 2 * cj + 1; ++j)
            for (int64_t i = 2 * ci; i <= 2 * ci + 1; ++i) {
              if (i >= d_.x || j >= d_.y || k >= d_.z) { kids[b][n++] = -1; continue; }
              const int64_t q = k * sz_ + j * sy_ + i;
              kids[b][n++] = q;
              phi_[q] = std::clamp(coarse.sampleTrilinear((i - 0.5) / 2, (j - 0.5) / 2, (k - 0.5) / 2) + shrink, -clamp_, clamp_);
            }
      }
    });
    (void)cd;
    std::vector<uint8_t> isIface(cband.size() * 8, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cband.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t b = r.begin(); b < r.end(); ++b)
        if (near[b])
          for (int n = 0; n < 8; ++n) isIface[b * 8 + n] = kids[b][n] >= 0 && crossing(kids[b][n]);
    });
    std::vector<int64_t> iface;
    for (size_t b = 0; b < cband.size(); ++b)
      for (int n = 0; n < 8; ++n)
        if (isIface[b * 8 + n]) iface.push_back(kids[b][n]);
    sortByIndex(iface);
    band_.clear();
    buildBand(iface);
    // Interpolated voxels that did not join the band go back to +-clamp, like every voxel
    // outside the band.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cband.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t b = r.begin(); b < r.end(); ++b)
        for (int n = 0; n < 8; ++n) {
          const int64_t q = kids[b][n];
          if (q >= 0 && (code_[q] & kLayer) == 0) phi_[q] = phi_[q] <= 0 ? -clamp_ : clamp_;
        }
    });
  }

  /// What one step did: voxels that changed side, and whether one of them touches a voxel
  /// outside the active list (then the band must be rebuilt before the front can go on).
  struct Change {
    int64_t changed = 0;
    bool leftActive = false;
    Change operator+(const Change& o) const { return {changed + o.changed, leftActive || o.leftActive}; }
  };

  /// One explicit step over the active voxels.
  Change step() {
    const size_t n = active_.size();
    rate_.resize(n);
    struct Max { double speed = 0, curv = 0; };
    const Max mx = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, n, 1024), Max{},
        [&](const tbb::blocked_range<size_t>& r, Max m) {
          for (size_t a = r.begin(); a < r.end(); ++a) rate_[a] = rate(active_[a], m.speed, m.curv);
          return m;
        },
        [](Max a, const Max& b) { return Max{std::max(a.speed, b.speed), std::max(a.curv, b.curv)}; });
    double dt = std::numeric_limits<double>::infinity();
    if (mx.speed > 0) dt = p_.cflNumber * hmin_ / mx.speed;
    if (mx.curv > 0) dt = std::min(dt, hmin_ * hmin_ / (6.0 * mx.curv));
    if (!std::isfinite(dt)) return {};  // nothing moves
    return tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, n, 4096), Change{},
        [&](const tbb::blocked_range<size_t>& r, Change c) {
          for (size_t a = r.begin(); a < r.end(); ++a) {
            const int64_t q = active_[a];
            float& v = phi_[q];
            const float nv = std::clamp(static_cast<float>(v + dt * rate_[a]), -clamp_, clamp_);
            if ((v <= 0) != (nv <= 0)) {
              ++c.changed;
              c.leftActive = c.leftActive || !neighboursActive(q);
            }
            v = nv;
          }
          return c;
        },
        std::plus<>());
  }

  /// Re-distances the band around the current zero level.
  void rebuild() {
    // Interface voxels are in the active part of the old band (the front cannot leave it).
    std::vector<uint8_t> flag(active_.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active_.size(), 4096),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t a = r.begin(); a < r.end(); ++a) flag[a] = crossing(active_[a]);
                      });
    std::vector<int64_t> iface;
    for (size_t a = 0; a < active_.size(); ++a)
      if (flag[a]) iface.push_back(active_[a]);
    buildBand(iface);
  }

  size_t interfaceCount() const { return interfaceCount_; }
  size_t activeCount() const { return active_.size(); }
  double maxSpacing() const { return hmax_; }

 private:
  bool inside(int64_t q) const { return phi_[q] <= 0; }

  /// phi at a continuous index (clamped to the grid), trilinear.
  float sampleTrilinear(double x, double y, double z) const {
    const double c[3] = {std::clamp(x, 0.0, double(d_.x - 1)), std::clamp(y, 0.0, double(d_.y - 1)),
                         std::clamp(z, 0.0, double(d_.z - 1))};
    int64_t i0[3], i1[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
      i0[a] = std::min(static_cast<int64_t>(c[a]), d_[a] - 1);
      i1[a] = std::min(i0[a] + 1, d_[a] - 1);
      t[a] = c[a] - double(i0[a]);
    }
    auto at = [&](int64_t i, int64_t j, int64_t k) { return double(phi_[k * sz_ + j * sy_ + i]); };
    const double x00 = at(i0[0], i0[1], i0[2]) * (1 - t[0]) + at(i1[0], i0[1], i0[2]) * t[0];
    const double x10 = at(i0[0], i1[1], i0[2]) * (1 - t[0]) + at(i1[0], i1[1], i0[2]) * t[0];
    const double x01 = at(i0[0], i0[1], i1[2]) * (1 - t[0]) + at(i1[0], i0[1], i1[2]) * t[0];
    const double x11 = at(i0[0], i1[1], i1[2]) * (1 - t[0]) + at(i1[0], i1[1], i1[2]) * t[0];
    const double y0 = x00 * (1 - t[1]) + x10 * t[1], y1 = x01 * (1 - t[1]) + x11 * t[1];
    return static_cast<float>(y0 * (1 - t[2]) + y1 * t[2]);
  }

  /// Offsets to the lower/upper neighbour along each axis; 0 where it is outside the grid.
  void neighbourOffsets(int64_t q, int64_t off[3][2]) const {
    off[0][0] = -1; off[0][1] = 1;
    off[1][0] = -sy_; off[1][1] = sy_;
    off[2][0] = -sz_; off[2][1] = sz_;
    if (!(code_[q] & kBorder)) return;
    const int64_t k = q / sz_, j = (q - k * sz_) / sy_, i = q - k * sz_ - j * sy_;
    if (i == 0) off[0][0] = 0;
    if (i == d_.x - 1) off[0][1] = 0;
    if (j == 0) off[1][0] = 0;
    if (j == d_.y - 1) off[1][1] = 0;
    if (k == 0) off[2][0] = 0;
    if (k == d_.z - 1) off[2][1] = 0;
  }

  /// True when every 6-neighbour inside the grid is in the active list.
  bool neighboursActive(int64_t q) const {
    int64_t off[3][2];
    neighbourOffsets(q, off);
    for (int a = 0; a < 3; ++a)
      for (int s = 0; s < 2; ++s)
        if (!(code_[q + off[a][s]] & kActive)) return false;
    return true;
  }

  /// True when a 6-neighbour lies on the other side of the zero level.
  bool crossing(int64_t q) const {
    const bool in = inside(q);
    if (!(code_[q] & kBorder))
      return inside(q - 1) != in || inside(q + 1) != in || inside(q - sy_) != in ||
             inside(q + sy_) != in || inside(q - sz_) != in || inside(q + sz_) != in;
    const int64_t k = q / sz_, j = (q - k * sz_) / sy_, i = q - k * sz_ - j * sy_;
    return (i > 0 && inside(q - 1) != in) || (i + 1 < d_.x && inside(q + 1) != in) ||
           (j > 0 && inside(q - sy_) != in) || (j + 1 < d_.y && inside(q + sy_) != in) ||
           (k > 0 && inside(q - sz_) != in) || (k + 1 < d_.z && inside(q + sz_) != in);
  }

  /// Signed distance of an interface voxel from the crossings on its axes (mm).
  float interfaceDistance(int64_t q) const {
    int64_t off[3][2];
    neighbourOffsets(q, off);
    const double v = phi_[q];
    const bool in = v <= 0;
    double inv = 0;
    for (int a = 0; a < 3; ++a) {
      double best = std::numeric_limits<double>::infinity();
      for (int s = 0; s < 2; ++s) {
        if (off[a][s] == 0) continue;
        const double w = phi_[q + off[a][s]];
        if ((w <= 0) == in) continue;
        const double t = v / (v - w);  // fraction of the way to the neighbour
        best = std::min(best, t * h_[a]);
      }
      if (best == 0) return in ? -0.0f : 0.0f;
      if (std::isfinite(best)) inv += 1.0 / (best * best);
    }
    const double dist = inv > 0 ? 1.0 / std::sqrt(inv) : hmin_;
    return static_cast<float>(in ? -dist : dist);
  }

  /// Eikonal update from the neighbours already in the band (codes 1..maxCode).
  float eikonal(int64_t q, uint8_t maxCode) const {
    int64_t off[3][2];
    neighbourOffsets(q, off);
    double m[3], hh[3];
    int n = 0;
    for (int a = 0; a < 3; ++a) {
      double best = std::numeric_limits<double>::infinity();
      for (int s = 0; s < 2; ++s) {
        if (off[a][s] == 0) continue;
        const int64_t r = q + off[a][s];
        const uint8_t layer = code_[r] & kLayer;
        if (layer == 0 || layer > maxCode) continue;
        best = std::min(best, static_cast<double>(std::abs(phi_[r])));
      }
      if (std::isfinite(best)) { m[n] = best; hh[n] = h_[a]; ++n; }
    }
    // Sort by value and add axes while the solution stays above the next neighbour value.
    for (int x = 0; x < n; ++x)
      for (int y = x + 1; y < n; ++y)
        if (m[y] < m[x]) { std::swap(m[x], m[y]); std::swap(hh[x], hh[y]); }
    double u = m[0] + hh[0];
    double A = 0, B = 0, C = -1;
    for (int t = 0; t < n; ++t) {
      if (t > 0 && u <= m[t]) break;
      const double w = 1.0 / (hh[t] * hh[t]);
      A += w; B += -2.0 * m[t] * w; C += m[t] * m[t] * w;
      const double disc = B * B - 4 * A * C;
      u = (-B + std::sqrt(std::max(disc, 0.0))) / (2 * A);
    }
    const float mag = std::min(static_cast<float>(u), clamp_);
    return inside(q) ? -mag : mag;
  }

  void buildBand(const std::vector<int64_t>& iface) {
    // Distances of the interface voxels first (reads the old phi).
    std::vector<float> ifaceValue(iface.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, iface.size(), 1024),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t a = r.begin(); a < r.end(); ++a) ifaceValue[a] = interfaceDistance(iface[a]);
                      });
    // Clear the old band to +-clamp (keeping the sign).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, band_.size(), 4096),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t a = r.begin(); a < r.end(); ++a) {
                          const int64_t q = band_[a];
                          code_[q] &= kBorder;
                          phi_[q] = phi_[q] <= 0 ? -clamp_ : clamp_;
                        }
                      });
    band_.clear();
    active_.clear();
    for (size_t a = 0; a < iface.size(); ++a) {
      phi_[iface[a]] = ifaceValue[a];
      code_[iface[a]] |= 1 | kActive;
    }
    interfaceCount_ = iface.size();
    band_ = iface;
    active_ = iface;
    // Grow outward layer by layer while values stay below expandWidth_.
    std::vector<int64_t> layer = iface, next;
    const int64_t st[3] = {1, sy_, sz_};
    tbb::enumerable_thread_specific<std::vector<int64_t>> local;
    for (uint8_t code = 2; code < kLayer && !layer.empty(); ++code) {
      for (auto& l : local) l.clear();
      tbb::parallel_for(tbb::blocked_range<size_t>(0, layer.size(), 2048),
                        [&](const tbb::blocked_range<size_t>& rg) {
        auto& out = local.local();
        auto claim = [&](int64_t r) {
          // Several threads may reach the same voxel: the first to set its layer owns it.
          std::atomic_ref<uint8_t> c(code_[r]);
          uint8_t old = c.load(std::memory_order_relaxed);
          while ((old & kLayer) == 0) {
            if (c.compare_exchange_weak(old, static_cast<uint8_t>(old | code), std::memory_order_relaxed)) {
              out.push_back(r);
              return;
            }
          }
        };
        for (size_t a = rg.begin(); a < rg.end(); ++a) {
          const int64_t q = layer[a];
          if (std::abs(phi_[q]) > expandWidth_) continue;
          if (!(code_[q] & kBorder)) {
            claim(q - 1); claim(q + 1); claim(q - sy_); claim(q + sy_); claim(q - sz_); claim(q + sz_);
            continue;
          }
          const int64_t k = q / sz_, j = (q - k * sz_) / sy_, i = q - k * sz_ - j * sy_;
          const int64_t c[3] = {i, j, k};
          for (int ax = 0; ax < 3; ++ax)
            for (int sgn = -1; sgn <= 1; sgn += 2) {
              const int64_t nb = c[ax] + sgn;
              if (nb >= 0 && nb < d_[ax]) claim(q + sgn * st[ax]);
            }
        }
      });
      next.clear();
      for (auto& l : local) next.insert(next.end(), l.begin(), l.end());
      const uint8_t prev = static_cast<uint8_t>(code - 1);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, next.size(), 1024),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t a = r.begin(); a < r.end(); ++a) phi_[next[a]] = eikonal(next[a], prev);
                        });
      for (int64_t q : next) {
        band_.push_back(q);
        if (std::abs(phi_[q]) <= activeWidth_) {
          active_.push_back(q);
          code_[q] |= kActive;
        }
      }
      std::swap(layer, next);
    }
    // Scan order keeps neighbouring voxels close in memory during the updates.
    sortByIndex(active_);
  }

  /// Ascending order by an LSD radix sort over the bits the grid needs (O(n), a few passes;
  /// several times faster than a comparison sort on the ~10^6 band voxels of a 256³ grid).
  void sortByIndex(std::vector<int64_t>& v) {
    if (v.size() < 2) return;
    if (v.size() < 4096) { std::sort(v.begin(), v.end()); return; }
    constexpr int kBits = 11;
    constexpr size_t kBuckets = size_t{1} << kBits;
    const uint64_t maxIndex = static_cast<uint64_t>(d_.voxelCount());
    sortScratch_.resize(v.size());
    std::vector<size_t> count(kBuckets);
    for (int shift = 0; shift < 64 && (maxIndex >> shift) != 0; shift += kBits) {
      std::fill(count.begin(), count.end(), 0);
      for (int64_t x : v) ++count[(static_cast<uint64_t>(x) >> shift) & (kBuckets - 1)];
      size_t sum = 0;
      for (auto& c : count) { const size_t t = c; c = sum; sum += t; }
      for (int64_t x : v) sortScratch_[count[(static_cast<uint64_t>(x) >> shift) & (kBuckets - 1)]++] = x;
      v.swap(sortScratch_);
    }
  }

  /// d(phi)/dt at voxel q; updates the maxima that bound the time step.
  float rate(int64_t q, double& maxSpeed, double& maxCurv) const {
    // Neighbour offsets, clamped at the border of the grid (zero normal derivative there).
    int64_t off[3][2];
    neighbourOffsets(q, off);
    const int64_t xm = off[0][0], xp = off[0][1], ym = off[1][0], yp = off[1][1], zm = off[2][0], zp = off[2][1];
    const float* f = phi_.data() + q;
    const double c = f[0];
    const double hx = h_[0], hy = h_[1], hz = h_[2];
    const double dxm = (c - f[xm]) / hx, dxp = (f[xp] - c) / hx;
    const double dym = (c - f[ym]) / hy, dyp = (f[yp] - c) / hy;
    const double dzm = (c - f[zm]) / hz, dzp = (f[zp] - c) / hz;
    const double s = S_[q];
    double out = 0;

    // Propagation (upwind, Osher-Sethian): outward speed F = alpha * S.
    const double F = p_.propagation * s;
    if (F > 0) {
      const double g2 = sq(std::max(dxm, 0.0)) + sq(std::min(dxp, 0.0)) + sq(std::max(dym, 0.0)) +
                        sq(std::min(dyp, 0.0)) + sq(std::max(dzm, 0.0)) + sq(std::min(dzp, 0.0));
      out -= F * std::sqrt(g2);
    } else if (F < 0) {
      const double g2 = sq(std::min(dxm, 0.0)) + sq(std::max(dxp, 0.0)) + sq(std::min(dym, 0.0)) +
                        sq(std::max(dyp, 0.0)) + sq(std::min(dzm, 0.0)) + sq(std::max(dzp, 0.0));
      out -= F * std::sqrt(g2);
    }
    double speedBound = std::abs(F);

    // Curvature: kappa * |grad phi| from central differences.
    if (p_.curvature != 0) {
      const double px = 0.5 * (dxm + dxp), py = 0.5 * (dym + dyp), pz = 0.5 * (dzm + dzp);
      const double pxx = (dxp - dxm) / hx, pyy = (dyp - dym) / hy, pzz = (dzp - dzm) / hz;
      const double pxy = (f[xp + yp] - f[xp + ym] - f[xm + yp] + f[xm + ym]) / (4 * hx * hy);
      const double pxz = (f[xp + zp] - f[xp + zm] - f[xm + zp] + f[xm + zm]) / (4 * hx * hz);
      const double pyz = (f[yp + zp] - f[yp + zm] - f[ym + zp] + f[ym + zm]) / (4 * hy * hz);
      const double n2 = px * px + py * py + pz * pz;
      if (n2 > 1e-12) {
        const double num = pxx * (py * py + pz * pz) + pyy * (px * px + pz * pz) + pzz * (px * px + py * py) -
                           2 * (px * py * pxy + px * pz * pxz + py * pz * pyz);
        const double w = p_.curvature * (edge_ ? s : 1.0);
        out += w * num / n2;
        maxCurv = std::max(maxCurv, std::abs(w));
      }
    }

    // Advection towards low speed: + gamma * grad S . grad phi, upwind per axis.
    if (advection_ != 0) {
      const double sx = (double(S_[q + xp]) - S_[q + xm]) / (hx * double(xp - xm == 0 ? 1 : xp - xm));
      const double syv = (double(S_[q + yp]) - S_[q + ym]) / (hy * double((yp - ym) / sy_ == 0 ? 1 : (yp - ym) / sy_));
      const double szv = (double(S_[q + zp]) - S_[q + zm]) / (hz * double((zp - zm) / sz_ == 0 ? 1 : (zp - zm) / sz_));
      // As motion with velocity V = -gamma * grad S: d(phi)/dt = -V . grad phi (upwind).
      const double vx = -advection_ * sx, vy = -advection_ * syv, vz = -advection_ * szv;
      out -= vx * (vx > 0 ? dxm : dxp) + vy * (vy > 0 ? dym : dyp) + vz * (vz > 0 ? dzm : dzp);
      speedBound += std::abs(vx) + std::abs(vy) + std::abs(vz);
    }
    maxSpeed = std::max(maxSpeed, speedBound);
    return static_cast<float>(out);
  }

  static double sq(double v) { return v * v; }

  Dims d_;
  Geometry g_;
  const float* S_;
  bool edge_;
  SnakeParams p_;
  double advection_;
  int64_t sy_, sz_;
  double h_[3];
  double hmin_, hmax_, activeWidth_, expandWidth_;
  float clamp_;
  std::vector<float> phi_;
  std::vector<uint8_t> code_;  ///< 0 = not in band, 1 = interface, n = n-1 steps from it
  std::vector<int64_t> band_, active_;
  std::vector<float> rate_;
  std::vector<int64_t> sortScratch_;
  size_t interfaceCount_ = 0;
};

/// Downsamples by 2 per axis taking the MINIMUM speed of each 2x2x2 block (the coarse voxel
/// centre sits at the centre of its block). The minimum keeps thin barriers (a cortex one voxel
/// thick) closed at the coarse level, so the coarse contour never leaks through them; it may
/// stop short of narrow passages, which the finer level then fills.
VolumeF32 downsample2(const VolumeF32& v) {
  const Dims d = v.dims();
  Geometry g = v.geometry();
  g.dims = {(d.x + 1) / 2, (d.y + 1) / 2, (d.z + 1) / 2};
  g.origin = v.geometry().indexToPhysical({0.5, 0.5, 0.5});
  g.spacing = v.geometry().spacing * 2.0;
  VolumeF32 out(g, 0.0f, v.background());
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          float lo = std::numeric_limits<float>::infinity();
          for (int64_t c = 2 * k; c <= std::min(2 * k + 1, d.z - 1); ++c)
            for (int64_t b = 2 * j; b <= std::min(2 * j + 1, d.y - 1); ++b)
              for (int64_t a = 2 * i; a <= std::min(2 * i + 1, d.x - 1); ++a) lo = std::min(lo, v(a, b, c));
          out(i, j, k) = lo;
        }
  });
  return out;
}

struct LevelRun {
  int iterations = 0;
  bool converged = false;
  double seconds = 0;
  int64_t contour = 0;
};

/// Iterates one level to convergence. `redistanceAtEnd`: re-distance the band afterwards (a
/// coarse level hands a clean distance function to the next; the finest level needs signs only).
LevelRun run(Evolver& ev, const SnakeParams& p, const std::string& stage, Progress& progress, bool redistanceAtEnd) {
  const auto t0 = std::chrono::steady_clock::now();
  LevelRun r;
  std::deque<int64_t> window;
  int64_t windowSum = 0;
  progress.begin(stage, static_cast<uint64_t>(std::max(p.maxIterations, 1)));
  int sinceRebuild = 0;
  bool leftActive = false;
  for (int it = 0; it < p.maxIterations; ++it) {
    // Re-distance at least every kMaxStepsBetweenRebuilds steps (phi drifts from a distance
    // function), and at once when the front reached the edge of the active voxels.
    if (it > 0 && (leftActive || sinceRebuild >= kMaxStepsBetweenRebuilds)) {
      ev.rebuild();
      sinceRebuild = 0;
    }
    const auto step = ev.step();
    const int64_t changed = step.changed;
    leftActive = step.leftActive;
    ++sinceRebuild;
    ++r.iterations;
    progress.advance();
    window.push_back(changed);
    windowSum += changed;
    if (static_cast<int>(window.size()) > p.convergenceWindow) {
      windowSum -= window.front();
      window.pop_front();
    }
    if (static_cast<int>(window.size()) >= p.convergenceWindow &&
        static_cast<double>(windowSum) / p.convergenceWindow <=
            p.convergenceFraction * static_cast<double>(std::max<size_t>(ev.interfaceCount(), 1))) {
      r.converged = true;
      break;
    }
  }
  if (redistanceAtEnd) ev.rebuild();
  progress.end();
  r.contour = static_cast<int64_t>(ev.interfaceCount());
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

/// Dense signed distance (mm) to the union of the bubbles, clamped.
void bubblePhi(const Geometry& g, const std::vector<Bubble>& bubbles, std::vector<float>& phi, float clamp) {
  const Dims d = g.dims;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const Vec3 x = g.indexToPhysical({double(i), double(j), double(k)});
          double best = std::numeric_limits<double>::infinity();
          for (const Bubble& b : bubbles) best = std::min(best, norm(x - b.centerMm) - b.radiusMm);
          phi[static_cast<size_t>((k * d.y + j) * d.x + i)] = static_cast<float>(std::clamp<double>(best, -clamp, clamp));
        }
  });
}

int autoLevels(const Dims& d) {
  int64_t m = std::min({d.x, d.y, d.z});
  int levels = 0;
  while (levels < 2 && m / 2 >= 64) { m /= 2; ++levels; }
  return levels;
}

}  // namespace

SnakeResult evolveSnake(const SpeedImage& speed, const std::vector<Bubble>& bubbles,
                        const SnakeParams& p, Progress& progress) {
  if (bubbles.empty()) throw Error("snake: at least one seed bubble is needed");
  if (p.maxIterations < 1) throw Error("snake: iterations must be >= 1");
  if (!(p.cflNumber > 0 && p.cflNumber <= 1)) throw Error("snake: CFL number must be in (0, 1]");
  if (p.curvature < 0) throw Error("snake: curvature weight must be >= 0");
  const Geometry& g = speed.values.geometry();
  for (const Bubble& b : bubbles) {
    seedsToVoxels(g, {b.centerMm});  // throws for a centre outside the grid
    if (!(b.radiusMm > 0)) throw Error("snake: bubble radius must be > 0 mm");
  }
  const auto t0 = std::chrono::steady_clock::now();
  const bool edge = speed.type == SpeedType::Edge;
  // Coarse levels: min-pooling keeps barriers (thin walls, edges) closed at the coarse level;
  // for edge speed each finer level starts inside the coarse contour (see below).
  const int levels = p.coarseLevels < 0 ? autoLevels(g.dims) : std::min(p.coarseLevels, 4);

  // Speed pyramid: pyramid[0] = finest.
  std::vector<VolumeF32> pyramid;
  for (int l = 0; l < levels; ++l) pyramid.push_back(downsample2(l == 0 ? speed.values : pyramid.back()));

  SnakeResult res;
  std::unique_ptr<Evolver> coarser;  // the converged level below, until the next one starts from it
  for (int l = levels; l >= 0; --l) {
    const VolumeF32& S = l == 0 ? speed.values : pyramid[l - 1];
    auto ev = std::make_unique<Evolver>(S, edge, p);
    if (!coarser) {
      bubblePhi(S.geometry(), bubbles, ev->phi(), ev->clampValue());
      ev->initialise();
    } else {
      // Edge speed only expands, so a coarse contour that crossed a thin wall (its position is
      // only known to about a coarse voxel) could never come back: start the finer level one
      // coarse voxel inside it and let it expand to the edges at full detail.
      ev->initialiseFrom(*coarser, edge ? coarser->maxSpacing() : 0.0);
      coarser.reset();
    }
    const std::string stage = l == 0 ? "snake" : "snake (1/" + std::to_string(1 << l) + " resolution)";
    const LevelRun r = run(*ev, p, stage, progress, l > 0);
    if (l > 0) {
      res.coarseIterations += r.iterations;
      coarser = std::move(ev);
      continue;
    }
    res.iterations = r.iterations;
    res.converged = r.converged;
    res.secondsPerIteration = r.iterations > 0 ? r.seconds / r.iterations : 0;
    res.finalContourVoxels = r.contour;
    res.phi = VolumeF32(g, 0.0f, ev->clampValue());
    res.phi.voxels() = std::move(ev->phi());
  }
  res.mask = Mask(g, 0, 0.0);
  const float* ph = res.phi.data();
  uint8_t* m = res.mask.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, res.mask.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) m[i] = ph[i] <= 0;
                    });
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace vellum::segmentation
