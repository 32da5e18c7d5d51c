#include "map_sampling.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "render_common.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/index_frame.hpp"

namespace vellum::render::detail {
namespace {

// The Gaussian kernel reads nodes -1 .. n + 1 per axis: pad the grid so that every tap is a texel.
std::vector<float> padForGaussian(const std::vector<float>& nodes, const Dims& nd, const Dims& pd) {
  std::vector<float> out(static_cast<size_t>(pd.voxelCount()) * 3);
  for (int64_t z = 0; z < pd.z; ++z)
    for (int64_t y = 0; y < pd.y; ++y)
      for (int64_t x = 0; x < pd.x; ++x) {
        const NodeTap tx = extendedNode(x - 1, nd.x), ty = extendedNode(y - 1, nd.y), tz = extendedNode(z - 1, nd.z);
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

// The snap for the shader's frames: u in source index, points p in map node index.
SnapFrame prepareSnap(const RigidSnap& rs, const Geometry& grid, const Geometry& source) {
  if (rs.fits.size() > static_cast<size_t>(kMaxSnapBodies))
    throw Error("backward map: the rigid snap has " + std::to_string(rs.fits.size()) +
                " bodies; the renderer handles at most " + std::to_string(kMaxSnapBodies));
  return snapFrame(rs, grid, indexToMm(source), source.origin);
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

Vec3 PreparedMap::at(const Vec3& p, int* snappedBody) const {
  if (snappedBody) *snappedBody = -1;
  const Vec3 u = interpolated(p);
  if (!snap) return u;
  const double v[3] = {p.x, p.y, p.z};
  double w[3] = {u.x, u.y, u.z};
  const int body = snap->apply(v, w);
  if (snappedBody) *snappedBody = body;
  return {w[0], w[1], w[2]};
}

std::array<float, 4> PreparedMap::turnNormal(const Vec3& p, const std::array<float, 4>& n, int snappedBody) const {
  const Vec3 ns{n[0], n[1], n[2]};
  const double len = norm(ns);
  // Where shade() ignores the normal (no gradient, or one below its fade-in), skip the work.
  if (!(len > 1e-4) || !(n[3] > kGradLow)) return n;
  if (twist && !(snappedBody >= 0 && snap)) {  // the kernel's Jacobian in mm: grad (f o u) = J^T grad f
    Vec3 q;
    for (int a = 0; a < 3; ++a) q[a] = std::clamp(p[a], 0.0, double(nodes[a] - 1));
    const Vec3 m = twist->jacobian(nodeGrid.indexToPhysical(q), mmToNode, nodes, kNormalStepNodes).transposed() * ns;
    const double ml = norm(m);
    if (!(ml > 0) || !std::isfinite(ml)) return n;
    const Vec3 t = m * (len / ml);
    return {float(t.x), float(t.y), float(t.z), n[3]};
  }
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
  const double pad = upsampling == Upsampling::Gaussian ? 1.0 : 0.0;
  return trilinearClamped(texture(), texDims, p + Vec3{pad, pad, pad});
}

Vec3 PreparedMap::interpolated(const Vec3& p) const {
  Vec3 q;
  for (int a = 0; a < 3; ++a) q[a] = std::clamp(p[a], 0.0, double(nodes[a] - 1));
  if (twist) return mmToSource(twist->sourceMm(nodeGrid.indexToPhysical(q), mmToNode, nodes));
  return interpolateNodes(index.data(), nodes, upsampling, 1, q);
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
  if (map.upsampling == Upsampling::Gaussian) {
    pm.texDims = {pm.nodes.x + 3, pm.nodes.y + 3, pm.nodes.z + 3};
    pm.padded = padForGaussian(pm.index, pm.nodes, pm.texDims);
  }
  if (map.rigidSnap) {
    pm.snap = prepareSnap(*map.rigidSnap, map.grid, source);
    pm.snapMarginVoxels = map.rigidSnap->maxSnapMm / source.minSpacing();
  }
  if (map.twist && !map.twist->stages().empty()) {  // no stage: the nodes' positions are the map
    pm.twist = map.twist;
    pm.nodeGrid = map.grid;
    pm.mmToNode = map.grid.physicalToIndexMap();
    pm.mmToSource = source.physicalToIndexMap();
    pm.twistMarginVoxels =
        map.twist->chordBoundMm(map.grid) / source.minSpacing();
  }
  Mat3 gInv;
  if (!indexToMm(map.grid).inverse(gInv)) throw Error("backward map: singular node grid geometry");
  pm.normalToSourceIndex = indexToMm(source).transposed();
  pm.nodeIndexToNormal = gInv.transposed();
  if (map.output) pm.output = outputAxes(*map.output, map.grid);
  return pm;
}

}  // namespace vellum::render::detail
