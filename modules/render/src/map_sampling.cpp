#include "map_sampling.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "render_common.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/gaussian_upsampling.hpp"

namespace vellum::render::detail {
namespace {

Mat3 indexToMm(const Geometry& g) {
  return g.direction * Mat3::fromColumns({g.spacing.x, 0, 0}, {0, g.spacing.y, 0}, {0, 0, g.spacing.z});
}

// Node m in [-1, n + 1] of an axis of n nodes as up to two real nodes: beyond the grid the map
// is extrapolated linearly from the two edge nodes, as CPU synthesis' Gaussian taps fold it.
struct AxisTap {
  int64_t i0 = 0, i1 = 0;
  double w0 = 1, w1 = 0;
};
AxisTap extendedNode(int64_t m, int64_t n) {
  if (n < 2 || (m >= 0 && m < n)) return {std::clamp<int64_t>(m, 0, n - 1), 0, 1, 0};
  if (m < 0) return {0, 1, double(1 - m), double(m)};
  const int64_t e = n - 1;
  return {e, e - 1, double(1 + (m - e)), double(-(m - e))};
}

// The Gaussian kernel reads nodes -1 .. n + 1 per axis: pad the grid so that every tap is a texel.
std::vector<float> padForGaussian(const std::vector<float>& nodes, const Dims& nd, const Dims& pd) {
  std::vector<float> out(static_cast<size_t>(pd.voxelCount()) * 3);
  for (int64_t z = 0; z < pd.z; ++z)
    for (int64_t y = 0; y < pd.y; ++y)
      for (int64_t x = 0; x < pd.x; ++x) {
        const AxisTap tx = extendedNode(x - 1, nd.x), ty = extendedNode(y - 1, nd.y), tz = extendedNode(z - 1, nd.z);
        double acc[3] = {0, 0, 0};
        for (int c = 0; c < 8; ++c) {
          const double w = ((c & 1) ? tx.w1 : tx.w0) * ((c & 2) ? ty.w1 : ty.w0) * ((c & 4) ? tz.w1 : tz.w0);
          if (w == 0) continue;
          const int64_t i = (c & 1) ? tx.i1 : tx.i0, j = (c & 2) ? ty.i1 : ty.i0, k = (c & 4) ? tz.i1 : tz.i0;
          const float* v = nodes.data() + static_cast<size_t>((k * nd.y + j) * nd.x + i) * 3;
          for (int a = 0; a < 3; ++a) acc[a] += w * v[a];
        }
        float* o = out.data() + static_cast<size_t>((z * pd.y + y) * pd.x + x) * 3;
        for (int a = 0; a < 3; ++a) o[a] = static_cast<float>(acc[a]);
      }
  return out;
}

void put(std::array<float, 12>& e, const Mat3& m, const Vec3& b) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) e[static_cast<size_t>(3 * r + c)] = static_cast<float>(m(r, c));
    e[static_cast<size_t>(9 + r)] = static_cast<float>(b[r]);
  }
}

PreparedSnap prepareSnap(const MapRigidSnap& rs, const Geometry& grid, const Geometry& source) {
  if (!rs.classes || rs.classes->size() != static_cast<size_t>(rs.classGrid.dims.voxelCount()))
    throw Error("backward map: the rigid snap's class volume does not match its grid");
  if (rs.fits.size() > static_cast<size_t>(kMaxSnapBodies))
    throw Error("backward map: the rigid snap has " + std::to_string(rs.fits.size()) +
                " bodies; the renderer handles at most " + std::to_string(kMaxSnapBodies));
  if (!std::isfinite(rs.maxSnapMm) || rs.maxSnapMm < 0)
    throw Error("backward map: the rigid snap distance must be finite and >= 0");
  rs.classGrid.validate("rigid snap class grid");
  const Mat3 S = indexToMm(source), C = indexToMm(rs.classGrid), G = indexToMm(grid);
  Mat3 sInv, cInv;
  if (!S.inverse(sInv) || !C.inverse(cInv)) throw Error("backward map: singular rigid snap geometry");
  PreparedSnap p;
  p.classes = rs.classes->data();
  p.classDims = rs.classGrid.dims;
  std::array<float, 12> toClass{};
  put(toClass, cInv * S, cInv * (source.origin - rs.classGrid.origin));
  p.toClass = toClass;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p.deltaToMm[static_cast<size_t>(3 * r + c)] = static_cast<float>(S(r, c));
  for (const auto& f : rs.fits) {
    for (double v : f)
      if (!std::isfinite(v)) throw Error("backward map: a rigid snap fit is not finite");
    const Mat3 R = Mat3::fromColumns({f[0], f[3], f[6]}, {f[1], f[4], f[7]}, {f[2], f[5], f[8]});
    const Vec3 t{f[9], f[10], f[11]};
    std::array<float, 12> e{};
    put(e, sInv * R * G, sInv * (R * grid.origin + t - source.origin));
    p.body.push_back(e);
  }
  p.valid = rs.valid;
  p.valid.resize(p.body.size(), 0);
  p.maxSnap2 = static_cast<float>(rs.maxSnapMm * rs.maxSnapMm);
  p.marginVoxels = rs.maxSnapMm / std::min({source.spacing.x, source.spacing.y, source.spacing.z});
  return p;
}

Vec3 trilinearClamped(const std::vector<float>& grid, const Dims& d, const Vec3& p) {
  const double x = std::clamp(p.x, 0.0, double(d.x - 1)), y = std::clamp(p.y, 0.0, double(d.y - 1)),
               z = std::clamp(p.z, 0.0, double(d.z - 1));
  const auto i0 = std::min<int64_t>(int64_t(x), d.x - 1), j0 = std::min<int64_t>(int64_t(y), d.y - 1),
             k0 = std::min<int64_t>(int64_t(z), d.z - 1);
  const int64_t i1 = std::min(i0 + 1, d.x - 1), j1 = std::min(j0 + 1, d.y - 1), k1 = std::min(k0 + 1, d.z - 1);
  const double tx = x - i0, ty = y - j0, tz = z - k0;
  Vec3 out{0, 0, 0};
  for (int c = 0; c < 8; ++c) {
    const int64_t i = (c & 1) ? i1 : i0, j = (c & 2) ? j1 : j0, k = (c & 4) ? k1 : k0;
    const double w = ((c & 1) ? tx : 1 - tx) * ((c & 2) ? ty : 1 - ty) * ((c & 4) ? tz : 1 - tz);
    const float* v = grid.data() + static_cast<size_t>((k * d.y + j) * d.x + i) * 3;
    out += Vec3{v[0], v[1], v[2]} * w;
  }
  return out;
}

// Node index p of `grid` -> voxel index of `out` (same direction: one scale and offset per axis).
PreparedMap::OutputAxes outputAxes(const Geometry& out, const Geometry& grid) {
  out.validate("backward map output grid");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (std::abs(out.direction(r, c) - grid.direction(r, c)) > 1e-6)
        throw Error("backward map: the output grid's direction differs from the node grid's");
  PreparedMap::OutputAxes ax;
  const Vec3 o = out.physicalToIndex(grid.indexToPhysical({0, 0, 0}));
  const Vec3 one = out.physicalToIndex(grid.indexToPhysical({1, 1, 1}));
  ax.offset = o;
  ax.scale = one - o;
  ax.dims = {double(out.dims.x), double(out.dims.y), double(out.dims.z)};
  return ax;
}

}  // namespace

Vec3 PreparedSnap::apply(const Vec3& p, const Vec3& u, int* snappedBody) const {
  if (snappedBody) *snappedBody = -1;
  int64_t ci[3];
  for (int a = 0; a < 3; ++a) {
    const double x = toClass[3 * a] * u.x + toClass[3 * a + 1] * u.y + toClass[3 * a + 2] * u.z + toClass[9 + a];
    if (!(x > -0.5)) return u;
    ci[a] = static_cast<int64_t>(std::floor(x + 0.5));
  }
  if (ci[0] >= classDims.x || ci[1] >= classDims.y || ci[2] >= classDims.z) return u;
  const int c = int(classes[(ci[2] * classDims.y + ci[1]) * classDims.x + ci[0]]) - 2;
  if (c < 0 || c >= int(body.size()) || !valid[static_cast<size_t>(c)]) return u;
  const auto& m = body[static_cast<size_t>(c)];
  Vec3 s;
  for (int a = 0; a < 3; ++a) s[a] = m[3 * a] * p.x + m[3 * a + 1] * p.y + m[3 * a + 2] * p.z + m[9 + a];
  const Vec3 d = s - u;
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double e = deltaToMm[3 * a] * d.x + deltaToMm[3 * a + 1] * d.y + deltaToMm[3 * a + 2] * d.z;
    d2 += e * e;
  }
  if (!(d2 <= maxSnap2)) return u;
  if (snappedBody) *snappedBody = c;
  return s;
}

Vec3 PreparedMap::at(const Vec3& p, int* snappedBody) const {
  if (snappedBody) *snappedBody = -1;
  const Vec3 u = interpolated(p);
  return snap ? snap->apply(p, u, snappedBody) : u;
}

std::array<float, 4> PreparedMap::turnNormal(const Vec3& p, const std::array<float, 4>& n, int snappedBody) const {
  const Vec3 ns{n[0], n[1], n[2]};
  const double len = norm(ns);
  // Where shade() ignores the normal (no gradient, or one below its fade-in), skip the work.
  if (!(len > 1e-4) || !(n[3] > kGradLow)) return n;
  Mat3 jt;  // J^T up to a scale, which cancels
  if (snappedBody >= 0 && snap) {  // u = M p + m: J = M, J^T's columns are M's rows
    const auto& m = snap->body[static_cast<size_t>(snappedBody)];
    jt = Mat3::fromColumns({m[0], m[1], m[2]}, {m[3], m[4], m[5]}, {m[6], m[7], m[8]});
  } else {
    const double h = kNormalStepNodes;
    const Vec3 jx = nodeTexture(p + Vec3{h, 0, 0}) - nodeTexture(p - Vec3{h, 0, 0});
    const Vec3 jy = nodeTexture(p + Vec3{0, h, 0}) - nodeTexture(p - Vec3{0, h, 0});
    const Vec3 jz = nodeTexture(p + Vec3{0, 0, h}) - nodeTexture(p - Vec3{0, 0, h});
    jt = Mat3::fromColumns(jx, jy, jz).transposed();  // (2h du/dp)^T
  }
  const Vec3 m = nodeIndexToNormal * (jt * (normalToSourceIndex * ns));
  const double ml = norm(m);
  if (!(ml > 0) || !std::isfinite(ml)) return n;
  const Vec3 t = m * (len / ml);
  return {float(t.x), float(t.y), float(t.z), n[3]};
}

Vec3 PreparedMap::nodeTexture(const Vec3& p) const {
  // The Gaussian kernel's texture has one padding texel below every node.
  const double pad = upsampling == MapUpsampling::Gaussian ? 1.0 : 0.0;
  return trilinearClamped(index, texDims, p + Vec3{pad, pad, pad});
}

Vec3 PreparedMap::interpolated(const Vec3& p) const {
  Vec3 u;
  if (upsampling == MapUpsampling::Trilinear) {
    u = trilinearClamped(index, nodes, p);
  } else {
    // Position clamped onto the nodes; taps n0 - 1 .. n0 + 2 are texels n0 .. n0 + 3.
    int64_t n0[3];
    std::array<double, 4> w[3];
    for (int a = 0; a < 3; ++a) {
      const double q = std::clamp(p[a], 0.0, double(nodes[a] - 1));
      n0[a] = std::min<int64_t>(int64_t(std::floor(q)), nodes[a] - 1);
      w[a] = gaussianUpsamplingWeights(q - double(n0[a]));
    }
    u = {0, 0, 0};
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
          const float* v = index.data() +
                           static_cast<size_t>(((n0[2] + k) * texDims.y + n0[1] + j) * texDims.x + n0[0] + i) * 3;
          u += Vec3{v[0], v[1], v[2]} * (w[0][i] * w[1][j] * w[2][k]);
        }
  }
  return u;
}

double PreparedMap::outputWeight(const Vec3& p) const {
  if (!output) return 1.0;
  double w = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double x = output->scale[a] * p[a] + output->offset[a];
    w *= std::clamp(std::min(1.0 + x, output->dims[a] - x), 0.0, 1.0);
  }
  return w;
}

PreparedMap prepareMap(const BackwardMap& map, const Geometry& source) {
  PreparedMap pm;
  pm.upsampling = map.upsampling;
  pm.nodes = map.grid.dims;
  pm.index = mapToSourceIndex(map, source);
  pm.texDims = pm.nodes;
  if (map.upsampling == MapUpsampling::Gaussian) {
    pm.texDims = {pm.nodes.x + 3, pm.nodes.y + 3, pm.nodes.z + 3};
    pm.index = padForGaussian(pm.index, pm.nodes, pm.texDims);
  }
  if (map.rigidSnap) pm.snap = prepareSnap(*map.rigidSnap, map.grid, source);
  Mat3 gInv;
  if (!indexToMm(map.grid).inverse(gInv)) throw Error("backward map: singular node grid geometry");
  pm.normalToSourceIndex = indexToMm(source).transposed();
  pm.nodeIndexToNormal = gInv.transposed();
  if (map.output) pm.output = outputAxes(*map.output, map.grid);
  return pm;
}

}  // namespace vellum::render::detail
