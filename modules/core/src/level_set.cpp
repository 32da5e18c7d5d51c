// Narrow-band level-set evolution (see level_set.hpp).
#include "vellum/core/level_set.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>

#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum {
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

double sq(double v) { return v * v; }

}  // namespace

double LevelSetStencil::upwindGradient(double F) const {
  if (F > 0)
    return std::sqrt(sq(std::max(dm[0], 0.0)) + sq(std::min(dp[0], 0.0)) + sq(std::max(dm[1], 0.0)) +
                     sq(std::min(dp[1], 0.0)) + sq(std::max(dm[2], 0.0)) + sq(std::min(dp[2], 0.0)));
  if (F < 0)
    return std::sqrt(sq(std::min(dm[0], 0.0)) + sq(std::max(dp[0], 0.0)) + sq(std::min(dm[1], 0.0)) +
                     sq(std::max(dp[1], 0.0)) + sq(std::min(dm[2], 0.0)) + sq(std::max(dp[2], 0.0)));
  return 0;
}

bool LevelSetStencil::curvatureRate(double weight, double& rate) const {
  const float* f = phi;
  const int64_t xm = lo[0], xp = hi[0], ym = lo[1], yp = hi[1], zm = lo[2], zp = hi[2];
  const double hx = h[0], hy = h[1], hz = h[2];
  const double px = 0.5 * (dm[0] + dp[0]), py = 0.5 * (dm[1] + dp[1]), pz = 0.5 * (dm[2] + dp[2]);
  const double pxx = (dp[0] - dm[0]) / hx, pyy = (dp[1] - dm[1]) / hy, pzz = (dp[2] - dm[2]) / hz;
  const double pxy = (f[xp + yp] - f[xp + ym] - f[xm + yp] + f[xm + ym]) / (4 * hx * hy);
  const double pxz = (f[xp + zp] - f[xp + zm] - f[xm + zp] + f[xm + zm]) / (4 * hx * hz);
  const double pyz = (f[yp + zp] - f[yp + zm] - f[ym + zp] + f[ym + zm]) / (4 * hy * hz);
  const double n2 = px * px + py * py + pz * pz;
  if (!(n2 > 1e-12)) return false;
  const double num = pxx * (py * py + pz * pz) + pyy * (px * px + pz * pz) + pzz * (px * px + py * py) -
                     2 * (px * py * pxy + px * pz * pxz + py * pz * pyz);
  rate = weight * num / n2;
  return true;
}

double LevelSetStencil::upwindAdvection(double vx, double vy, double vz) const {
  return vx * (vx > 0 ? dm[0] : dp[0]) + vy * (vy > 0 ? dm[1] : dp[1]) + vz * (vz > 0 ? dm[2] : dp[2]);
}

double LevelSetStencil::centralDifference(const float* field, int a) const {
  const int64_t steps = (hi[a] - lo[a]) / stride[a];  // 2 inside, 1 at a face, 0 on a 1-voxel axis
  return (double(field[index + hi[a]]) - field[index + lo[a]]) / (h[a] * double(steps == 0 ? 1 : steps));
}

NarrowBandLevelSet::NarrowBandLevelSet(const Geometry& grid, double cflNumber)
    : grid_(grid), d_(grid.dims), cfl_(cflNumber) {
  if (!(cflNumber > 0 && cflNumber <= 1)) throw Error("level set: CFL number must be in (0, 1]");
  sy_ = d_.x;
  sz_ = d_.x * d_.y;
  h_[0] = grid.spacing.x; h_[1] = grid.spacing.y; h_[2] = grid.spacing.z;
  hmin_ = std::min({h_[0], h_[1], h_[2]});
  hmax_ = std::max({h_[0], h_[1], h_[2]});
  // Any voxel the contour can reach before the next rebuild, plus one voxel on the coarsest axis.
  activeWidth_ = kActiveSteps * cfl_ * hmin_ + hmax_;
  expandWidth_ = activeWidth_;  // one more layer beyond the active voxels covers their stencils
  clamp_ = static_cast<float>(expandWidth_ + 2.0 * hmax_);
  checkMemoryBudget(static_cast<uint64_t>(d_.voxelCount()) * 5, "level set");
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

void NarrowBandLevelSet::initialise() {
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


void NarrowBandLevelSet::initialiseFrom(const NarrowBandLevelSet& coarse, double shrinkMm) {
  if (coarse.d_.x != (d_.x + 1) / 2 || coarse.d_.y != (d_.y + 1) / 2 || coarse.d_.z != (d_.z + 1) / 2)
    throw Error("level set: the coarse grid is not this grid downsampled by 2");
  const float shrink = static_cast<float>(shrinkMm);
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


NarrowBandLevelSet::Change NarrowBandLevelSet::step(const LevelSetRate& rate) {
  const size_t n = active_.size();
  rate_.resize(n);
  const LevelSetBounds mx = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 1024), LevelSetBounds{},
      [&](const tbb::blocked_range<size_t>& r, LevelSetBounds m) {
        for (size_t a = r.begin(); a < r.end(); ++a) rate_[a] = rate(stencil(active_[a]), m);
        return m;
      },
      [](LevelSetBounds a, const LevelSetBounds& b) {
        return LevelSetBounds{std::max(a.speed, b.speed), std::max(a.curvature, b.curvature)};
      });
  double dt = std::numeric_limits<double>::infinity();
  if (mx.speed > 0) dt = cfl_ * hmin_ / mx.speed;
  if (mx.curvature > 0) dt = std::min(dt, hmin_ * hmin_ / (6.0 * mx.curvature));
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
            c.net += nv <= 0 ? 1 : -1;
            c.leftActive = c.leftActive || !neighboursActive(q);
          }
          v = nv;
        }
        return c;
      },
      std::plus<>());
}

void NarrowBandLevelSet::rebuild() {
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


/// phi at a continuous index (clamped to the grid), trilinear.
float NarrowBandLevelSet::sampleTrilinear(double x, double y, double z) const {
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
void NarrowBandLevelSet::neighbourOffsets(int64_t q, int64_t off[3][2]) const {
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
bool NarrowBandLevelSet::neighboursActive(int64_t q) const {
  int64_t off[3][2];
  neighbourOffsets(q, off);
  for (int a = 0; a < 3; ++a)
    for (int s = 0; s < 2; ++s)
      if (!(code_[q + off[a][s]] & kActive)) return false;
  return true;
}

/// True when a 6-neighbour lies on the other side of the zero level.
bool NarrowBandLevelSet::crossing(int64_t q) const {
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
float NarrowBandLevelSet::interfaceDistance(int64_t q) const {
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
float NarrowBandLevelSet::eikonal(int64_t q, uint8_t maxCode) const {
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

void NarrowBandLevelSet::buildBand(const std::vector<int64_t>& iface) {
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
  for (uint8_t code = 2; code < kLayer && !layer.empty(); ++code) {
    next = growLayer(layer, code);
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

/// The voxels next to `layer` (within expandWidth_) that are not in the band yet, marked with
/// layer `code`.
std::vector<int64_t> NarrowBandLevelSet::growLayer(const std::vector<int64_t>& layer, uint8_t code) {
  const int64_t st[3] = {1, sy_, sz_};
  tbb::enumerable_thread_specific<std::vector<int64_t>> local;
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
  std::vector<int64_t> next;
  for (auto& l : local) next.insert(next.end(), l.begin(), l.end());
  return next;
}

/// Ascending order by an LSD radix sort over the bits the grid needs (O(n), a few passes;
/// several times faster than a comparison sort on the ~10^6 band voxels of a 256³ grid).
void NarrowBandLevelSet::sortByIndex(std::vector<int64_t>& v) {
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

LevelSetStencil NarrowBandLevelSet::stencil(int64_t q) const {
  // Neighbour offsets, clamped at the border of the grid (zero normal derivative there).
  int64_t off[3][2];
  neighbourOffsets(q, off);
  LevelSetStencil s;
  s.index = q;
  s.phi = phi_.data() + q;
  const double c = s.phi[0];
  const int64_t st[3] = {1, sy_, sz_};
  for (int a = 0; a < 3; ++a) {
    s.lo[a] = off[a][0];
    s.hi[a] = off[a][1];
    s.stride[a] = st[a];
    s.h[a] = h_[a];
    s.dm[a] = (c - s.phi[s.lo[a]]) / h_[a];
    s.dp[a] = (s.phi[s.hi[a]] - c) / h_[a];
  }
  return s;
}

LevelSetRunResult NarrowBandLevelSet::run(const LevelSetRate& rate, const LevelSetStopping& stop,
                                          const std::string& stage, Progress& progress, bool redistanceAtEnd,
                                          const std::function<void(const NarrowBandLevelSet&, int)>& observe,
                                          int observeEvery) {
  const auto t0 = std::chrono::steady_clock::now();
  LevelSetRunResult r;
  std::deque<int64_t> window;
  int64_t windowSum = 0;
  progress.begin(stage, static_cast<uint64_t>(std::max(stop.maxIterations, 1)));
  int sinceRebuild = 0;
  bool leftActive = false;
  // Inside voxel count per step, for the settle test (one dense count per run).
  std::deque<int64_t> insideHistory;
  int64_t insideCount = 0;
  if (stop.settleFraction > 0)
    insideCount = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, phi_.size(), 1 << 16), int64_t{0},
        [&](const tbb::blocked_range<size_t>& b, int64_t n) {
          for (size_t q = b.begin(); q < b.end(); ++q) n += phi_[q] <= 0;
          return n;
        },
        std::plus<>());
  for (int it = 0; it < stop.maxIterations; ++it) {
    // Re-distance at least every kMaxStepsBetweenRebuilds steps (phi drifts from a distance
    // function), and at once when the front reached the edge of the active voxels.
    if (it > 0 && (leftActive || sinceRebuild >= kMaxStepsBetweenRebuilds)) {
      rebuild();
      sinceRebuild = 0;
    }
    const Change change = step(rate);
    leftActive = change.leftActive;
    ++sinceRebuild;
    ++r.iterations;
    progress.advance();
    if (observe && observeEvery > 0 && r.iterations % observeEvery == 0) observe(*this, r.iterations);
    window.push_back(change.changed);
    windowSum += change.changed;
    if (static_cast<int>(window.size()) > stop.window) {
      windowSum -= window.front();
      window.pop_front();
    }
    if (static_cast<int>(window.size()) >= stop.window &&
        static_cast<double>(windowSum) / stop.window <=
            stop.fraction * static_cast<double>(std::max<size_t>(interfaceCount_, 1))) {
      r.converged = true;
      break;
    }
    if (stop.settleFraction > 0) {
      insideCount += change.net;
      insideHistory.push_back(insideCount);
      if (static_cast<int>(insideHistory.size()) > stop.settleWindow + 1) insideHistory.pop_front();
      if (static_cast<int>(insideHistory.size()) == stop.settleWindow + 1 && insideCount > 0) {
        const auto [lo, hi] = std::minmax_element(insideHistory.begin(), insideHistory.end());
        if (static_cast<double>(*hi - *lo) <= stop.settleFraction * static_cast<double>(insideCount)) {
          r.converged = r.settled = true;
          break;
        }
      }
    }
  }
  if (redistanceAtEnd) rebuild();
  progress.end();
  r.contourVoxels = static_cast<int64_t>(interfaceCount_);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace vellum
