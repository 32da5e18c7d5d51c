#include "vellum/core/backward_map.hpp"

#include <climits>
#include <mutex>

#include "vellum/core/error.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/rotation.hpp"

namespace vellum {
namespace {

void put(std::array<float, 12>& e, const Mat3& m, const Vec3& b) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) e[static_cast<size_t>(3 * r + c)] = static_cast<float>(m(r, c));
    e[static_cast<size_t>(9 + r)] = static_cast<float>(b[r]);
  }
}

}  // namespace

void TwistKernel::addStage(const Vec3& pointMm, const Vec3& axis, double angleRad) {
  if (stages_.size() >= size_t(kMaxStages))
    throw Error("twist kernel: more than " + std::to_string(kMaxStages) + " stages");
  stages_.push_back(Stage::about(pointMm, axis, angleRad));
}

TwistKernel::Stage TwistKernel::Stage::about(const Vec3& pointMm, const Vec3& axis, double angleRad) {
  return {pointMm, axis, angleRad, rotationMatrix(axis, -angleRad)};
}

double TwistKernel::weightAt(size_t s, const Vec3& q, const Dims& nodes) const {
  double c[3];
  int64_t i0[3], i1[3];
  const int64_t n[3] = {nodes.x, nodes.y, nodes.z};
  for (int a = 0; a < 3; ++a) {
    const double v = std::clamp(q[a], 0.0, double(n[a] - 1));
    i0[a] = std::min(static_cast<int64_t>(v), n[a] - 1);
    i1[a] = std::min(i0[a] + 1, n[a] - 1);
    c[a] = v - double(i0[a]);
  }
  double w = 0;
  for (int k = 0; k < 8; ++k) {
    const double f = ((k & 1) ? c[0] : 1 - c[0]) * ((k & 2) ? c[1] : 1 - c[1]) * ((k & 4) ? c[2] : 1 - c[2]);
    if (f == 0) continue;
    const int64_t node = (((k & 4) ? i1[2] : i0[2]) * nodes.y + ((k & 2) ? i1[1] : i0[1])) * nodes.x + ((k & 1) ? i1[0] : i0[0]);
    w += f * double(weights[static_cast<size_t>(node) * stride() + s]);
  }
  return w;
}

Vec3 TwistKernel::Stage::turned(const Vec3& x, double w) const {
  if (w == 0) return x;
  if (w == 1) return pointMm + whole * (x - pointMm);
  return pointMm + rotateAbout(x - pointMm, axis, -angleRad * w);
}

Vec3 TwistKernel::sourceMm(const Vec3& vMm, const Geometry::ToIndex& mmToNode, const Dims& nodes) const {
  Vec3 x = vMm;
  for (size_t s = 0; s < stages_.size(); ++s) x = turn(s, x, weightAt(s, mmToNode(x), nodes));
  return x;
}

Vec3 TwistKernel::sourceAtNode(int64_t node, const Vec3& vMm, const Geometry::ToIndex& mmToNode,
                               const Dims& nodes) const {
  if (stages_.empty()) return vMm;
  Vec3 x = turn(0, vMm, double(weights[static_cast<size_t>(node) * stride()]));
  for (size_t s = 1; s < stages_.size(); ++s) x = turn(s, x, weightAt(s, mmToNode(x), nodes));
  return x;
}

Mat3 TwistKernel::jacobian(const Vec3& vMm, const Geometry::ToIndex& mmToNode, const Dims& nodes,
                           double stepNodes) const {
  // d(node index)/d(mm) = diag(1 / spacing) * inverse direction: grad_mm w = L^T grad_node w.
  const Mat3 L = Mat3::fromColumns({1 / mmToNode.spacing.x, 0, 0}, {0, 1 / mmToNode.spacing.y, 0},
                                   {0, 0, 1 / mmToNode.spacing.z}) * mmToNode.inverseDirection;
  Mat3 J = Mat3::identity();
  Vec3 x = vMm;
  for (size_t s = 0; s < stages_.size(); ++s) {
    const Vec3 q = mmToNode(x);
    const double w = weightAt(s, q, nodes);
    Vec3 g{0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      Vec3 e{0, 0, 0};
      e[a] = stepNodes;
      g[a] = (weightAt(s, q + e, nodes) - weightAt(s, q - e, nodes)) / (2 * stepNodes);
    }
    if (w == 0 && g == Vec3{0, 0, 0}) continue;
    const Stage& st = stages_[s];
    const Vec3 gradMm = L.transposed() * g, p = x - st.pointMm, t = cross(st.axis, p);
    const Mat3 R = w == 1 ? st.whole : rotationMatrix(st.axis, -st.angleRad * w);
    Mat3 shear;  // I - angle t grad^T
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) shear(r, c) = (r == c ? 1.0 : 0.0) - st.angleRad * t[r] * gradMm[c];
    J = R * shear * J;
    x = st.pointMm + R * p;
  }
  return J;
}

double TwistKernel::chordBoundMm(const Geometry& grid) const {
  // Per stage: the turned point f(x) = R(-angle w(x)) (x - c) + c over a cell; its trilinear
  // interpolant misses it by at most (1/8) sum_q h_q^2 |d2f/dq2|, and per axis q
  // |d2f/dq2| <= r phi_q^2 + 2 phi_q (phi_q = angle |dw/dq| h_q, per cell edge, in rad; r the
  // distance to the axis, h_q the edge). The bound takes the steepest edge and the farthest
  // corner of the grid, so it is loose but cheap.
  const Dims d = grid.dims;
  double rMax = 0;
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner = grid.indexToPhysical({(k & 1) ? double(d.x - 1) : 0.0, (k & 2) ? double(d.y - 1) : 0.0,
                                              (k & 4) ? double(d.z - 1) : 0.0});
    for (const Stage& st : stages_) {
      const Vec3 p = corner - st.pointMm;
      rMax = std::max(rMax, norm(p - st.axis * dot(st.axis, p)));
    }
  }
  // The steepest edge of each stage's w along each axis: one parallel pass over the nodes (a
  // movie frame's renderer prepares every frame's map: 11.5 M nodes at 512^2 x 350).
  const size_t ns = stages_.size();
  std::vector<std::array<double, 3>> stepMax(ns, {0, 0, 0});
  std::mutex m;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    std::vector<std::array<double, 3>> local(ns, {0, 0, 0});
    const int64_t sy = d.x, sz = d.x * d.y;
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const size_t t = static_cast<size_t>((k * d.y + j) * d.x + i) * ns;
          for (size_t s = 0; s < ns; ++s) {
            const float w = weights[t + s];
            auto& l = local[s];
            if (i + 1 < d.x) l[0] = std::max(l[0], double(std::abs(weights[t + ns + s] - w)));
            if (j + 1 < d.y) l[1] = std::max(l[1], double(std::abs(weights[t + size_t(sy) * ns + s] - w)));
            if (k + 1 < d.z) l[2] = std::max(l[2], double(std::abs(weights[t + size_t(sz) * ns + s] - w)));
          }
        }
    std::lock_guard lock(m);
    for (size_t s = 0; s < ns; ++s)
      for (int a = 0; a < 3; ++a) stepMax[s][a] = std::max(stepMax[s][a], local[s][a]);
  });
  double total = 0;
  for (size_t s = 0; s < ns; ++s)
    for (int a = 0; a < 3; ++a) {
      const double phi = std::abs(stages_[s].angleRad) * stepMax[s][a];
      total += 0.125 * (rMax * phi * phi + 2 * phi * grid.spacing[a]);
    }
  return total;
}

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
