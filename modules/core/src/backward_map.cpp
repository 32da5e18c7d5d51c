#include "vellum/core/backward_map.hpp"

#include <climits>

#include "vellum/core/error.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum {
namespace {

void put(std::array<float, 12>& e, const Mat3& m, const Vec3& b) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) e[static_cast<size_t>(3 * r + c)] = static_cast<float>(m(r, c));
    e[static_cast<size_t>(9 + r)] = static_cast<float>(b[r]);
  }
}

}  // namespace

const params::EnumTable<Upsampling>& upsamplings() {
  static const params::EnumTable<Upsampling> t{"upsampling", {"trilinear", "gaussian"}};
  return t;
}

// Trilinear: the two nodes around o / s.
void linearTap(double o, int64_t nodes, int s, std::array<int32_t, 2>& idx, std::array<float, 2>& w) {
  const int64_t n0 = std::min(static_cast<int64_t>(std::floor(o / s)), nodes - 1);
  const int64_t n1 = std::min(n0 + 1, nodes - 1);
  const float f = static_cast<float>(o - static_cast<double>(n0 * s)) / static_cast<float>(s);
  idx = {static_cast<int32_t>(n0), static_cast<int32_t>(n1)};
  w = {1.f - f, f};
}

// Gaussian: the 4 nodes around o / s (gaussianUpsamplingWeights), taps beyond the grid folded
// onto the edge nodes.
void gaussianTap(double o, int64_t nodes, int s, std::array<int32_t, 4>& id, std::array<float, 4>& wf) {
  const int64_t n0 = static_cast<int64_t>(std::floor(o / s));
  const double f = (o - static_cast<double>(n0 * s)) / s;
  const std::array<double, 4> w = gaussianUpsamplingWeights(f);
  std::array<double, 4> wd{};
  for (int q = 0; q < 4; ++q) id[q] = static_cast<int32_t>(std::clamp<int64_t>(n0 - 1 + q, 0, nodes - 1));
  auto add = [&](int64_t node, double weight) {
    for (int q = 0; q < 4; ++q)
      if (id[q] == node) { wd[q] += weight; return; }
  };
  for (int q = 0; q < 4; ++q) {
    const NodeTap t = extendedNode(n0 - 1 + q, nodes);
    add(t.i0, w[q] * t.w0);
    if (t.w1 != 0) add(t.i1, w[q] * t.w1);
  }
  for (int q = 0; q < 4; ++q) wf[q] = static_cast<float>(wd[q]);
}

namespace {

template <int Taps, class TapFn>
Vec3 separable(const float* nodes, const Dims& nd, int s, const Vec3& o, TapFn tap) {
  std::array<int32_t, Taps> ix, iy, iz;
  std::array<float, Taps> wx, wy, wz;
  tap(o.x, nd.x, s, ix, wx);
  tap(o.y, nd.y, s, iy, wy);
  tap(o.z, nd.z, s, iz, wz);
  float u[3] = {0, 0, 0};
  for (int a = 0; a < Taps; ++a) {
    float row[3] = {0, 0, 0};
    for (int b = 0; b < Taps; ++b) {
      if (wy[b] == 0.f) continue;
      float plane[3] = {0, 0, 0};
      for (int c = 0; c < Taps; ++c) {
        if (wz[c] == 0.f) continue;
        const float* p = nodes + 3 * ((int64_t(iz[c]) * nd.y + iy[b]) * nd.x + ix[a]);
        for (int q = 0; q < 3; ++q) plane[q] += wz[c] * p[q];
      }
      for (int q = 0; q < 3; ++q) row[q] += wy[b] * plane[q];
    }
    for (int q = 0; q < 3; ++q) u[q] += wx[a] * row[q];
  }
  return {u[0], u[1], u[2]};
}

}  // namespace

Vec3 interpolateNodes(const float* nodes, const Dims& nd, Upsampling kernel, int s, const Vec3& o) {
  return kernel == Upsampling::Trilinear ? separable<2>(nodes, nd, s, o, linearTap)
                                         : separable<4>(nodes, nd, s, o, gaussianTap);
}

std::vector<float> identityNodes(const Geometry& grid) {
  const Dims d = grid.dims;
  checkMemoryBudget(d, 3 * sizeof(float), "backward map nodes");
  std::vector<float> out(static_cast<size_t>(d.voxelCount()) * 3);
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const Vec3 p = grid.indexToPhysical({double(i), double(j), double(k)});
          float* o = out.data() + 3 * ((k * d.y + j) * d.x + i);
          o[0] = static_cast<float>(p.x); o[1] = static_cast<float>(p.y); o[2] = static_cast<float>(p.z);
        }
  });
  return out;
}

SnapFrame snapFrame(const RigidSnap& rs, const Geometry& pointGrid, const Mat3& uToMm, const Vec3& uOriginMm) {
  if (!rs.classes || rs.classes->size() != static_cast<size_t>(rs.classGrid.dims.voxelCount()))
    throw Error("rigid snap: the class volume does not match its grid");
  if (!std::isfinite(rs.maxSnapMm) || rs.maxSnapMm < 0) throw Error("rigid snap: the distance must be finite and >= 0");
  rs.classGrid.validate("rigid snap class grid");
  Mat3 cInv, lInv;
  if (!indexToMm(rs.classGrid).inverse(cInv) || !uToMm.inverse(lInv)) throw Error("rigid snap: singular geometry");
  SnapFrame p;
  p.classes = rs.classes->data();
  p.classDims = rs.classGrid.dims;
  put(p.toClass, cInv * uToMm, cInv * (uOriginMm - rs.classGrid.origin));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p.deltaToMm[static_cast<size_t>(3 * r + c)] = static_cast<float>(uToMm(r, c));
  const Mat3 G = indexToMm(pointGrid);
  for (const auto& f : rs.fits) {
    for (double v : f)
      if (!std::isfinite(v)) throw Error("rigid snap: a fit is not finite");
    const Mat3 R = Mat3::fromColumns({f[0], f[3], f[6]}, {f[1], f[4], f[7]}, {f[2], f[5], f[8]});
    const Vec3 t{f[9], f[10], f[11]};
    std::array<float, 12> e{};
    put(e, lInv * R * G, lInv * (R * pointGrid.origin + t - uOriginMm));
    p.body.push_back(e);
  }
  p.valid = rs.valid;
  p.valid.resize(p.body.size(), 0);
  if (!rs.held.empty()) {
    if (rs.held.size() != rs.fits.size()) throw Error("rigid snap: one held flag per body is needed");
    p.held.assign(rs.held.size(), 0);
    for (size_t c = 0; c < rs.held.size(); ++c) {
      if (!rs.held[c] || !p.valid[c]) continue;
      // Held = stays where it is: only the identity may be held (u = v at its voxels).
      const auto& f = rs.fits[c];
      for (int i = 0; i < 12; ++i)
        if (std::abs(f[static_cast<size_t>(i)] - ((i == 0 || i == 4 || i == 8) ? 1.0 : 0.0)) > 1e-9)
          throw Error("rigid snap: a held body must have the identity transform");
      p.held[c] = 1;
      p.anyHeld = true;
    }
    put(p.pointToClass, cInv * G, cInv * (pointGrid.origin - rs.classGrid.origin));
  }
  p.maxSnap2 = static_cast<float>(rs.maxSnapMm * rs.maxSnapMm);
  if (rs.reachMm.size() == rs.fits.size()) {
    // Point-index bounds of each body's reach box (its 8 corners through mm -> index); the held
    // bodies' together bound heldAt() (a held body's reach holds its own voxels).
    p.heldBox = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};
    for (size_t c = 0; c < rs.reachMm.size(); ++c) {
      const auto& b = rs.reachMm[c];
      if (b[3] < b[0]) continue;
      std::array<int64_t, 6> r{INT64_MAX, INT64_MAX, INT64_MAX, INT64_MIN, INT64_MIN, INT64_MIN};
      for (int q = 0; q < 8; ++q) {
        const Vec3 idx = pointGrid.physicalToIndex({(q & 1) ? b[3] : b[0], (q & 2) ? b[4] : b[1], (q & 4) ? b[5] : b[2]});
        for (int a = 0; a < 3; ++a) {
          const double lo = std::clamp(std::floor(idx[a]), -1.0, 1e15), hi = std::clamp(std::ceil(idx[a]), -1.0, 1e15);
          r[static_cast<size_t>(a)] = std::min(r[static_cast<size_t>(a)], static_cast<int64_t>(lo));
          r[static_cast<size_t>(a + 3)] = std::max(r[static_cast<size_t>(a + 3)], static_cast<int64_t>(hi));
        }
      }
      p.reach.push_back(r);
      if (c < p.held.size() && p.held[c])
        for (size_t a = 0; a < 3; ++a) {
          p.heldBox[a] = std::min(p.heldBox[a], static_cast<float>(r[a]));
          p.heldBox[a + 3] = std::max(p.heldBox[a + 3], static_cast<float>(r[a + 3]));
        }
    }
  } else {
    p.reach.push_back({0, 0, 0, INT64_MAX / 2, INT64_MAX / 2, INT64_MAX / 2});  // everywhere
  }
  if (!p.anyHeld) p.heldBox = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};  // empty: nothing held
  return p;
}

bool SnapFrame::reaches(const Vec3& v) const {
  double lo = 1e300, hi = -1e300;
  for (const auto& r : reach)
    if (v.y >= double(r[1]) && v.y <= double(r[4]) && v.z >= double(r[2]) && v.z <= double(r[5])) {
      lo = std::min(lo, double(r[0]));
      hi = std::max(hi, double(r[3]));
    }
  return v.x >= lo && v.x <= hi;
}

void SnapFrame::applyRow(int64_t j, int64_t k, int64_t n, float* ux, float* uy, float* uz) const {
  int64_t lo = n, hi = -1;
  for (const auto& r : reach)
    if (j >= r[1] && j <= r[4] && k >= r[2] && k <= r[5]) {
      lo = std::min(lo, std::max<int64_t>(r[0], 0));
      hi = std::max(hi, std::min<int64_t>(r[3], n - 1));
    }
  for (int64_t i = lo; i <= hi; ++i) {
    const float v[3] = {static_cast<float>(i), static_cast<float>(j), static_cast<float>(k)};
    float u[3] = {ux[i], uy[i], uz[i]};
    if (apply(v, u) < 0) continue;
    ux[i] = u[0]; uy[i] = u[1]; uz[i] = u[2];
  }
}

}  // namespace vellum
