// Shape-aware representation: per-segment signed distances of the closed meshes on the CT
// grid, the union distance and the segmentation volume.
//
// Distances are computed directly at the CT's voxel centres (anisotropic spacing and
// direction honoured), without an intermediate grid: every triangle visits the voxels within
// the exact band of its plane (a box per triangle, then the run of each row that is within
// the band) and keeps the exact point-triangle distance there (min over triangles). Cost
// O(faces x band voxels a face): the decimated meshes make it cheap, and no dense box of a
// finer isotropic grid is ever allocated.
//
// Signs: by ray parity along the grid's z axis (crossings counted watertight with a top-left
// rule); a voxel centre is inside when an odd number of crossings lie below it, exact for any
// nesting of closed components (a segment with a cavity, e.g. muscle around bone).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "shape_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::illustration {

namespace {
/// One line of the Felzenszwalb-Huttenlocher squared distance transform: out[q] =
/// min_p ((q-p) s)^2 + f[p], with f = +inf where there is no seed.
void edt1d(const float* f, float* out, int64_t n, double s, std::vector<int64_t>& v,
           std::vector<double>& z) {
  const double inf = std::numeric_limits<double>::infinity();
  v.assign(static_cast<size_t>(n), 0);
  z.assign(static_cast<size_t>(n) + 1, 0.0);
  int64_t k = -1;
  for (int64_t q = 0; q < n; ++q) {
    if (!std::isfinite(f[q])) continue;
    while (k >= 0) {
      const int64_t p = v[size_t(k)];
      const double sq = ((f[q] + (q * s) * (q * s)) - (f[p] + (p * s) * (p * s))) / (2 * s * (q - p));
      if (sq <= z[size_t(k)]) --k;
      else {
        ++k;
        v[size_t(k)] = q;
        z[size_t(k)] = sq;
        z[size_t(k) + 1] = inf;
        break;
      }
    }
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -inf;
      z[1] = inf;
    }
  }
  if (k < 0) {
    for (int64_t q = 0; q < n; ++q) out[q] = std::numeric_limits<float>::infinity();
    return;
  }
  int64_t j = 0;
  for (int64_t q = 0; q < n; ++q) {
    while (z[size_t(j) + 1] < q * s) ++j;
    const int64_t p = v[size_t(j)];
    out[q] = static_cast<float>((q - p) * s * (q - p) * s + f[p]);
  }
}

/// Far field: beyond the exact band (|u| >= far - h) the magnitude becomes the Euclidean
/// distance (mm, anisotropic spacing honoured) to the nearest band voxel centre plus the
/// band's width, far - 1.5 h: an upper bound of the true distance that is exact for flat
/// surfaces; the error stays within about a voxel (measured in the tests).
/// `scratch`: a buffer for the squared distances, resized to u.size() (a caller's spare
/// volume-sized buffer: a fresh 4-byte-a-voxel allocation costs its page faults).
void extendFarField(VolumeF32& u, float far, std::vector<float>& sq) {
  const Geometry& g = u.geometry();
  const Dims& d = g.dims;
  const float inf = std::numeric_limits<float>::infinity();
  // Seeds: voxels well inside the exact band (OpenVDB's values in the band's outermost voxel
  // layer can be off by a voxel after its renormalisation).
  const float h = static_cast<float>(g.minSpacing());
  const float seed = far - h;
  if (sq.size() != u.size()) resizeHugePaged(sq, u.size());
  parallelFor(static_cast<int64_t>(sq.size()), [&](int64_t b, int64_t e) {
    for (int64_t n = b; n < e; ++n) sq[size_t(n)] = std::abs(u.data()[n]) < seed ? 0.0f : inf;
  }, 1 << 16);
  const int64_t nx = d.x, ny = d.y, nz = d.z;
  // x lines, then y lines (within slices), then z lines.
  parallelFor(nz, [&](int64_t k0, int64_t k1) {
    std::vector<int64_t> v;
    std::vector<double> z;
    std::vector<float> in(size_t(std::max(nx, ny))), out(in.size());
    for (int64_t k = k0; k < k1; ++k) {
      for (int64_t j = 0; j < ny; ++j) {
        float* row = sq.data() + (k * ny + j) * nx;
        std::copy(row, row + nx, in.begin());
        edt1d(in.data(), row, nx, g.spacing.x, v, z);
      }
      for (int64_t i = 0; i < nx; ++i) {
        for (int64_t j = 0; j < ny; ++j) in[size_t(j)] = sq[size_t((k * ny + j) * nx + i)];
        edt1d(in.data(), out.data(), ny, g.spacing.y, v, z);
        for (int64_t j = 0; j < ny; ++j) sq[size_t((k * ny + j) * nx + i)] = out[size_t(j)];
      }
    }
  });
  // z lines: per y row, gather the (k, i) slab row by row (contiguous reads), transform its
  // columns in cache, scatter it back.
  parallelFor(ny, [&](int64_t j0, int64_t j1) {
    std::vector<int64_t> v;
    std::vector<double> z;
    std::vector<float> slab(static_cast<size_t>(nz * nx));
    std::vector<float> in(static_cast<size_t>(nz)), out(static_cast<size_t>(nz));
    for (int64_t j = j0; j < j1; ++j) {
      for (int64_t k = 0; k < nz; ++k)
        std::copy_n(sq.data() + (k * ny + j) * nx, nx, slab.data() + k * nx);
      for (int64_t i = 0; i < nx; ++i) {
        bool any = false;
        for (int64_t k = 0; k < nz; ++k) {
          in[size_t(k)] = slab[size_t(k * nx + i)];
          any = any || std::isfinite(in[size_t(k)]);
        }
        if (!any) continue;
        edt1d(in.data(), out.data(), nz, g.spacing.z, v, z);
        for (int64_t k = 0; k < nz; ++k) slab[size_t(k * nx + i)] = out[size_t(k)];
      }
      for (int64_t k = 0; k < nz; ++k)
        std::copy_n(slab.data() + k * nx, nx, sq.data() + (k * ny + j) * nx);
    }
  });
  parallelFor(static_cast<int64_t>(sq.size()), [&](int64_t b, int64_t e) {
    for (int64_t n = b; n < e; ++n) {
      float& x = u.data()[n];
      if (std::abs(x) < seed || !std::isfinite(sq[size_t(n)])) continue;
      const float mag = std::sqrt(sq[size_t(n)]) + seed - 0.5f * h;
      x = x < 0 ? -mag : mag;
    }
  }, 1 << 16);
}

/// The mesh in the grid's index space (floats, one copy a vertex: every triangle sees the same
/// coordinates, which keeps the crossing tests watertight) and in "axis mm" (index * spacing:
/// an isometry of physical space, so distances there are physical distances).
struct GridMesh {
  std::vector<std::array<float, 3>> q;   // index coordinates
  std::vector<std::array<double, 3>> x;  // axis mm
  const std::vector<std::array<uint32_t, 3>>* faces = nullptr;
};

/// Canonical edge function: the same bits whichever triangle evaluates the shared edge, so
/// that a column through an edge or a vertex is claimed by exactly one of the triangles that
/// meet there (no double or missing crossing: one wrong parity would flip a whole column).
inline double edgeFn(const std::array<float, 3>& u, const std::array<float, 3>& v, double px, double py) {
  return (double(v[0]) - u[0]) * (py - u[1]) - (double(v[1]) - u[1]) * (px - u[0]);
}

/// Closest distance (mm) from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5),
/// squared; degenerate triangles fall back to their edges.
double pointTriangleDist2(const std::array<double, 3>& p, const std::array<double, 3>& a,
                          const std::array<double, 3>& b, const std::array<double, 3>& c) {
  auto sub = [](const std::array<double, 3>& u, const std::array<double, 3>& v) {
    return std::array<double, 3>{u[0] - v[0], u[1] - v[1], u[2] - v[2]};
  };
  auto dot = [](const std::array<double, 3>& u, const std::array<double, 3>& v) {
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  };
  auto dist2 = [&](const std::array<double, 3>& q) {
    const auto d = sub(p, q);
    return dot(d, d);
  };
  const auto ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return dist2(a);
  const auto bp = sub(p, b);
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return dist2(b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return dist2({a[0] + v * ab[0], a[1] + v * ab[1], a[2] + v * ab[2]});
  }
  const auto cp = sub(p, c);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dist2(c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return dist2({a[0] + w * ac[0], a[1] + w * ac[1], a[2] + w * ac[2]});
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return dist2({b[0] + w * (c[0] - b[0]), b[1] + w * (c[1] - b[1]), b[2] + w * (c[2] - b[2])});
  }
  const double den = va + vb + vc;
  if (!(std::abs(den) > 0)) {  // degenerate: the nearest of the three edges
    auto seg = [&](const std::array<double, 3>& u, const std::array<double, 3>& v) {
      const auto uv = sub(v, u), up = sub(p, u);
      const double l = dot(uv, uv);
      const double t = l > 0 ? std::clamp(dot(up, uv) / l, 0.0, 1.0) : 0.0;
      return dist2({u[0] + t * uv[0], u[1] + t * uv[1], u[2] + t * uv[2]});
    };
    return std::min({seg(a, b), seg(b, c), seg(c, a)});
  }
  const double v = vb / den, w = vc / den;
  return dist2({a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w});
}

/// |d| (mm) to the mesh for every voxel centre within `bandMm` of it, min-ed into `absd`
/// (others untouched). Each triangle visits the voxels of its box widened by the band, and
/// per x row only the run within the band of its plane; slabs of z in parallel, each with
/// the triangles that reach it (no two tasks write the same voxel).
void bandDistances(const GridMesh& gm, const Geometry& g, double bandMm, float* absd) {
  const auto& faces = *gm.faces;
  const Dims& d = g.dims;
  const Vec3 sp = g.spacing;
  const double rb[3] = {bandMm / sp.x, bandMm / sp.y, bandMm / sp.z};
  const int64_t slab = 4;
  const int64_t nslabs = (d.z + slab - 1) / slab;
  std::vector<std::vector<uint32_t>> bins(static_cast<size_t>(nslabs));
  for (uint32_t t = 0; t < faces.size(); ++t) {
    double lo = 1e300, hi = -1e300;
    for (uint32_t v : faces[t]) {
      lo = std::min(lo, double(gm.q[v][2]));
      hi = std::max(hi, double(gm.q[v][2]));
    }
    const int64_t k0 = std::max<int64_t>(0, int64_t(std::ceil(lo - rb[2])));
    const int64_t k1 = std::min<int64_t>(d.z - 1, int64_t(std::floor(hi + rb[2])));
    for (int64_t s = k0 / slab; k0 <= k1 && s <= k1 / slab; ++s) bins[size_t(s)].push_back(t);
  }
  const double band2 = bandMm * bandMm;
  tbb::parallel_for(int64_t(0), nslabs, [&](int64_t s) {
    const int64_t zs0 = s * slab, zs1 = std::min(d.z, zs0 + slab) - 1;
    for (uint32_t t : bins[size_t(s)]) {
      const auto& f = faces[t];
      const auto &a = gm.x[f[0]], &b = gm.x[f[1]], &c = gm.x[f[2]];
      int64_t lo[3], hi[3];
      for (int ax = 0; ax < 3; ++ax) {
        const double mn = std::min({gm.q[f[0]][ax], gm.q[f[1]][ax], gm.q[f[2]][ax]});
        const double mx = std::max({gm.q[f[0]][ax], gm.q[f[1]][ax], gm.q[f[2]][ax]});
        lo[ax] = std::max<int64_t>(0, int64_t(std::ceil(mn - rb[ax])));
        hi[ax] = int64_t(std::floor(mx + rb[ax]));
      }
      hi[0] = std::min<int64_t>(hi[0], d.x - 1);
      hi[1] = std::min<int64_t>(hi[1], d.y - 1);
      lo[2] = std::max(lo[2], zs0);
      hi[2] = std::min(hi[2], zs1);
      // Unit normal (mm): the plane's distance is linear along a row.
      const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      const double nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      const bool plane = nl > 1e-12;
      if (plane)
        for (double& v : n) v /= nl;
      const double nx = n[0] * sp.x;  // plane distance per voxel step in x
      for (int64_t k = lo[2]; k <= hi[2]; ++k)
        for (int64_t j = lo[1]; j <= hi[1]; ++j) {
          int64_t i0 = lo[0], i1 = hi[0];
          if (plane) {  // the run of the row within the band of the triangle's plane
            const double f0 = n[0] * (0 - a[0]) + n[1] * (j * sp.y - a[1]) + n[2] * (k * sp.z - a[2]);
            if (std::abs(nx) < 1e-12) {
              if (std::abs(f0) > bandMm) continue;
            } else {
              double ia = (-bandMm - f0) / nx, ib = (bandMm - f0) / nx;
              if (ia > ib) std::swap(ia, ib);
              i0 = std::max(i0, int64_t(std::ceil(ia)));
              i1 = std::min(i1, int64_t(std::floor(ib)));
            }
          }
          float* row = absd + (k * d.y + j) * d.x;
          for (int64_t i = i0; i <= i1; ++i) {
            const double d2 = pointTriangleDist2({i * sp.x, j * sp.y, k * sp.z}, a, b, c);
            if (d2 <= band2) row[i] = std::min(row[i], float(std::sqrt(d2)));
          }
        }
    }
  });
}

/// Inside/outside by ray parity along z: for every column of voxel centres (i, j) the
/// crossings with the surface, counted with a top-left rule (watertight: a column through a
/// shared edge or vertex counts once); a centre is inside when an odd number of crossings lie
/// below it. Exact for any nesting of closed components (cavities included). Negates `absd`
/// where inside.
void applyParity(const GridMesh& gm, const Dims& d, float* absd) {
  const auto& faces = *gm.faces;
  // Triangles by the rows j they span (counting sort).
  std::vector<uint32_t> start(static_cast<size_t>(d.y) + 1, 0);
  auto rowsOf = [&](const std::array<uint32_t, 3>& f, int64_t& j0, int64_t& j1) {
    const double mn = std::min({gm.q[f[0]][1], gm.q[f[1]][1], gm.q[f[2]][1]});
    const double mx = std::max({gm.q[f[0]][1], gm.q[f[1]][1], gm.q[f[2]][1]});
    j0 = std::max<int64_t>(0, int64_t(std::ceil(mn)));
    j1 = std::min<int64_t>(d.y - 1, int64_t(std::floor(mx)));
  };
  for (const auto& f : faces) {
    int64_t j0, j1;
    rowsOf(f, j0, j1);
    for (int64_t j = j0; j <= j1; ++j) ++start[size_t(j) + 1];
  }
  for (size_t j = 1; j < start.size(); ++j) start[j] += start[j - 1];
  std::vector<uint32_t> items(start.back());
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t t = 0; t < faces.size(); ++t) {
      int64_t j0, j1;
      rowsOf(faces[t], j0, j1);
      for (int64_t j = j0; j <= j1; ++j) items[fill[size_t(j)]++] = t;
    }
  }
  parallelFor(d.y, [&](int64_t jb, int64_t je) {
    std::vector<std::pair<int64_t, float>> hits;  // (column i, crossing z in index units)
    for (int64_t j = jb; j < je; ++j) {
      hits.clear();
      const double py = double(j);
      for (uint32_t n = start[size_t(j)]; n < start[size_t(j) + 1]; ++n) {
        const auto& f = faces[items[n]];
        const std::array<float, 3>* v[3] = {&gm.q[f[0]], &gm.q[f[1]], &gm.q[f[2]]};
        const double mn = std::min({(*v[0])[0], (*v[1])[0], (*v[2])[0]});
        const double mx = std::max({(*v[0])[0], (*v[1])[0], (*v[2])[0]});
        const int64_t i0 = std::max<int64_t>(0, int64_t(std::ceil(mn)));
        const int64_t i1 = std::min<int64_t>(d.x - 1, int64_t(std::floor(mx)));
        for (int64_t i = i0; i <= i1; ++i) {
          double w[3];
          int pos = 0, neg = 0;
          for (int e = 0; e < 3; ++e) {  // edge e: v[e] -> v[(e+1)%3], canonical direction by vertex id
            const uint32_t ia = f[size_t(e)], ib = f[size_t((e + 1) % 3)];
            w[e] = ia < ib ? edgeFn(gm.q[ia], gm.q[ib], double(i), py) : -edgeFn(gm.q[ib], gm.q[ia], double(i), py);
            pos += w[e] > 0;
            neg += w[e] < 0;
          }
          if (pos > 0 && neg > 0) continue;  // outside the projection
          if (pos == 0 && neg == 0) continue;  // degenerate (vertical) triangle
          const double s = pos > 0 ? 1.0 : -1.0;
          bool claim = true;
          for (int e = 0; e < 3 && claim; ++e) {
            if (w[e] != 0) continue;
            // On edge e: claimed only by the triangle for which the edge, oriented with the
            // projection counter-clockwise, points down, or along +x (top-left rule).
            const auto& ua = *v[e];
            const auto& ub = *v[(e + 1) % 3];
            double dx = double(ub[0]) - ua[0], dy = double(ub[1]) - ua[1];
            if (s < 0) {
              dx = -dx;
              dy = -dy;
            }
            claim = dy < 0 || (dy == 0 && dx > 0);
          }
          if (!claim) continue;
          const double sum = w[0] + w[1] + w[2];  // twice the projected area (signed)
          // Barycentric weight of a vertex = edge function of the opposite edge / sum.
          const double z = (w[1] * (*v[0])[2] + w[2] * (*v[1])[2] + w[0] * (*v[2])[2]) / sum;
          hits.emplace_back(i, float(z));
        }
      }
      std::sort(hits.begin(), hits.end());
      for (size_t h = 0; h < hits.size();) {
        size_t e = h;
        while (e < hits.size() && hits[e].first == hits[h].first) ++e;
        const int64_t i = hits[h].first;
        // Between crossing 2m and 2m+1 (sorted by z) the column is inside.
        for (size_t c = h; c + 1 < e; c += 2) {
          const int64_t k0 = std::max<int64_t>(0, int64_t(std::ceil(hits[c].second)));
          const int64_t k1 = std::min<int64_t>(d.z - 1, int64_t(std::ceil(hits[c + 1].second)) - 1);
          for (int64_t k = k0; k <= k1; ++k) {
            float& x = absd[(k * d.y + j) * d.x + i];
            x = -x;
          }
        }
        h = e;
      }
    }
  });
}
}  // namespace

void detail::signedDistanceInto(const TriMesh& mesh, const Geometry& g, const DistanceOptions& options,
                                double extraBandMm, VolumeF32& out) {
  const Vec3 sp = g.spacing;
  const double h = std::min({sp.x, sp.y, sp.z});
  const double bandMm =
      std::max(options.bandMm > 0 ? options.bandMm : defaultExactBandMm(g), std::abs(extraBandMm) + 2 * h);
  const float farMm = static_cast<float>(std::max(3.0, bandMm / h) * h);
  GridMesh gm;
  gm.faces = &mesh.faces;
  gm.q.resize(mesh.vertices.size());
  gm.x.resize(mesh.vertices.size());
  for (size_t n = 0; n < mesh.vertices.size(); ++n) {
    const auto& v = mesh.vertices[n];
    const Vec3 q = g.physicalToIndex(Vec3{v[0], v[1], v[2]});
    gm.q[n] = {float(q.x), float(q.y), float(q.z)};
    gm.x[n] = {double(gm.q[n][0]) * sp.x, double(gm.q[n][1]) * sp.y, double(gm.q[n][2]) * sp.z};
  }
  if (out.dims() == g.dims && out.size() == size_t(g.dims.voxelCount())) {
    // Reused: refilled in parallel (its pages are already mapped).
    out.setGeometry(g);
    out.setBackground(farMm);
    float* v = out.data();
    parallelFor(static_cast<int64_t>(out.size()), [&](int64_t b, int64_t e) { std::fill(v + b, v + e, farMm); },
                1 << 16);
  } else {
    out = VolumeF32(g, farMm, farMm);
  }
  bandDistances(gm, g, farMm, out.data());
  applyParity(gm, g.dims, out.data());
}

VolumeF32 detail::signedDistance(const TriMesh& mesh, const Geometry& g, const DistanceOptions& options,
                                 double extraBandMm) {
  VolumeF32 out;
  signedDistanceInto(mesh, g, options, extraBandMm, out);
  return out;
}

std::vector<VolumeF32> signedDistances(const std::vector<TriMesh>& meshes, const Geometry& g,
                                       const DistanceOptions& options,
                                       const std::vector<double>& extraBandMm) {
  std::vector<VolumeF32> out;
  out.reserve(meshes.size());
  for (size_t m = 0; m < meshes.size(); ++m)
    out.push_back(detail::signedDistance(meshes[m], g, options, m < extraBandMm.size() ? extraBandMm[m] : 0.0));
  return out;
}

detail::RepresentationBuilder::RepresentationBuilder(const Geometry& g, const std::vector<Segment>& segments,
                                                     const std::vector<Shell>& shells)
    : segments_(segments), union_(g, std::numeric_limits<float>::infinity()), ids_(g, 0, 0.0),
      far_(std::numeric_limits<double>::infinity()) {
  const size_t n = segments.size();
  if (n + shells.size() > 255) throw Error("too many segments and shells for a uint8 label map (max 255)");
  // Shell per segment (first one wins), with its label id.
  shellT_.assign(n, 0.0);
  shellId_.assign(n, 0);
  for (size_t i = 0; i < n; ++i)
    table_.push_back({static_cast<uint16_t>(i + 1), segments[i].name, segments[i].rgb});
  for (size_t s = 0; s < shells.size(); ++s) {
    size_t idx = n;
    for (size_t i = 0; i < n; ++i)
      if (segments[i].name == shells[s].segment) idx = i;
    if (idx == n) throw Error("--shell: unknown segment '" + shells[s].segment + "'");
    if (!(shells[s].thicknessMm > 0)) throw Error("--shell " + shells[s].segment + ": thickness must be > 0 mm");
    const auto id = static_cast<uint16_t>(n + 1 + s);
    if (shellId_[idx] == 0) {
      shellId_[idx] = id;
      shellT_[idx] = shells[s].thicknessMm;
    }
    auto rgb = segments[idx].rgb;
    for (auto& c : rgb) c = static_cast<uint8_t>(c / 2 + 64);  // a paler, distinct shade
    table_.push_back({id, segments[idx].name + " boundary", rgb});
  }
}

void detail::RepresentationBuilder::add(size_t i, const VolumeF32& distance) {
  if (i >= segments_.size() || distance.dims() != union_.dims())
    throw Error("buildRepresentation: one distance volume per segment, on the same grid");
  if (first_) union_.setBackground(distance.background());
  first_ = false;
  far_ = std::min(far_, distance.background());
  const float* d = distance.data();
  float* u = union_.data();
  uint16_t* ids = ids_.data();
  const uint16_t shellId = shellId_[i], id = static_cast<uint16_t>(i + 1);
  const float t = static_cast<float>(shellT_[i]);
  parallelFor(static_cast<int64_t>(distance.size()), [&](int64_t b, int64_t e) {
    for (int64_t v = b; v < e; ++v) {
      u[v] = std::min(u[v], d[v]);
      if (d[v] < 0) ids[v] = (shellId != 0 && d[v] > -t) ? shellId : id;  // later segments paint over
    }
  }, 1 << 16);
}

void detail::RepresentationBuilder::finish(VolumeF32& unionDistance, LabelVolume& segmentation,
                                           std::vector<float>* scratch) {
  if (first_) throw Error("buildRepresentation: one distance volume per segment needed");
  segmentation = LabelVolume(std::move(ids_), std::move(table_));
  std::vector<float> own;
  if (std::isfinite(far_)) extendFarField(union_, static_cast<float>(far_), scratch ? *scratch : own);
  unionDistance = std::move(union_);
}

void buildRepresentation(std::vector<VolumeF32>& distances, const std::vector<Segment>& segments,
                         const std::vector<Shell>& shells, VolumeF32& unionDistance,
                         LabelVolume& segmentation) {
  if (distances.size() != segments.size() || distances.empty())
    throw Error("buildRepresentation: one distance volume per segment needed");
  detail::RepresentationBuilder builder(distances.front().geometry(), segments, shells);
  for (size_t i = 0; i < distances.size(); ++i) builder.add(i, distances[i]);
  builder.finish(unionDistance, segmentation);
}

}  // namespace vellum::illustration
