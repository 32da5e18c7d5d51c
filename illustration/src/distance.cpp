// Shape-aware representation: per-segment signed distances of the closed meshes on the CT
// grid (OpenVDB meshToSignedDistanceField, in the OpenVDB module), the union distance and the
// segmentation volume.
//
// Distances are computed on an isotropic VDB grid aligned with the CT's index axes, voxel
// size h = the smallest CT spacing, with vertices expressed in mm along those axes (distance
// is invariant under the CT's rotation). For isotropic CT grids the VDB voxels coincide with
// the CT voxels; otherwise each CT voxel centre is sampled trilinearly. Within the narrow band
// (bandMm, widened per mesh for shells and grow offsets) the values are exact distances to the
// mesh (OpenVDB computes point-triangle distances to the closest primitive).
//
// Signs: OpenVDB decides inside/outside by flood-filling from the grid's outside, so a cavity
// (a segment with a hole inside, e.g. muscle around bone) would count as inside. Each
// connected component of the mesh is therefore converted on its own (one closed surface:
// no cavity), and a point is inside the segment when an odd number of component surfaces
// enclose it; |d| is the minimum over the components. This is exact for any nesting.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <unordered_map>

#include "shape_internal.hpp"
#include "vdb_functions.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::illustration {

namespace {
/// Connected components of a mesh (faces sharing a vertex), as lists of face indices.
std::vector<std::vector<uint32_t>> connectedComponents(const TriMesh& mesh) {
  std::vector<uint32_t> parent(mesh.vertices.size());
  for (uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& f : mesh.faces) {
    const uint32_t a = find(f[0]), b = find(f[1]), c = find(f[2]);
    parent[b] = a;
    parent[find(c)] = find(a);
  }
  std::unordered_map<uint32_t, size_t> index;
  std::vector<std::vector<uint32_t>> comps;
  for (uint32_t fi = 0; fi < mesh.faces.size(); ++fi) {
    const uint32_t root = find(mesh.faces[fi][0]);
    auto [it, inserted] = index.try_emplace(root, comps.size());
    if (inserted) comps.emplace_back();
    comps[it->second].push_back(fi);
  }
  return comps;
}

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
void extendFarField(VolumeF32& u, float far) {
  const Geometry& g = u.geometry();
  const Dims& d = g.dims;
  const float inf = std::numeric_limits<float>::infinity();
  // Seeds: voxels well inside the exact band (OpenVDB's values in the band's outermost voxel
  // layer can be off by a voxel after its renormalisation).
  const float h = static_cast<float>(std::min({g.spacing.x, g.spacing.y, g.spacing.z}));
  const float seed = far - h;
  std::vector<float> sq(u.size());
  for (size_t n = 0; n < sq.size(); ++n) sq[n] = std::abs(u.data()[n]) < seed ? 0.0f : inf;
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
  for (size_t n = 0; n < sq.size(); ++n) {
    float& x = u.data()[n];
    if (std::abs(x) < seed || !std::isfinite(sq[n])) continue;
    const float mag = std::sqrt(sq[n]) + seed - 0.5f * h;
    x = x < 0 ? -mag : mag;
  }
}

bool isotropic(const Vec3& s) {
  const double h = std::min({s.x, s.y, s.z});
  return std::abs(s.x - h) < 1e-6 * h && std::abs(s.y - h) < 1e-6 * h && std::abs(s.z - h) < 1e-6 * h;
}
}  // namespace

std::vector<VolumeF32> signedDistances(const std::vector<TriMesh>& meshes, const Geometry& g,
                                       const DistanceOptions& options,
                                       const std::vector<double>& extraBandMm) {
  const detail::VdbFunctions& vdb = detail::vdbFunctions();
  const Vec3 sp = g.spacing;
  const double h = std::min({sp.x, sp.y, sp.z});
  const bool iso = isotropic(sp);
  const auto& d = g.dims;
  const std::array<int, 3> limit{int(std::ceil((d.x - 1) * sp.x / h)) + 1, int(std::ceil((d.y - 1) * sp.y / h)) + 1,
                                 int(std::ceil((d.z - 1) * sp.z / h)) + 1};
  std::vector<VolumeF32> out;
  out.resize(meshes.size());
  // Meshes in parallel (small meshes leave OpenVDB's own threads idle); each is threaded too.
  tbb::parallel_for(size_t(0), meshes.size(), [&](size_t m) {
    const TriMesh& mesh = meshes[m];
    std::vector<std::array<float, 3>> allPts;
    allPts.reserve(mesh.vertices.size());
    for (const auto& v : mesh.vertices) {
      const Vec3 q = g.physicalToIndex(Vec3{v[0], v[1], v[2]});
      allPts.push_back({float(q.x * sp.x), float(q.y * sp.y), float(q.z * sp.z)});
    }
    const auto components = connectedComponents(mesh);
    const double extra = m < extraBandMm.size() ? extraBandMm[m] : 0.0;
    const double bandMm = std::max(options.bandMm > 0 ? options.bandMm : defaultExactBandMm(g), std::abs(extra) + 2 * h);
    const float bandVox = static_cast<float>(std::max(3.0, bandMm / h));
    const float farMm = static_cast<float>(bandVox * h);
    VolumeF32 dense(g, farMm, farMm);  // min over components of |d|
    std::vector<uint8_t> parity(dense.size(), 0);  // number of enclosing surfaces, mod 2
    for (const auto& comp : components) {
      // Re-index the component's vertices.
      std::vector<std::array<float, 3>> pts;
      std::vector<std::array<uint32_t, 3>> tris;
      std::unordered_map<uint32_t, uint32_t> remap;
      for (uint32_t fi : comp) {
        uint32_t idx[3];
        for (int c = 0; c < 3; ++c) {
          const uint32_t v = mesh.faces[fi][size_t(c)];
          auto [it, inserted] = remap.try_emplace(v, static_cast<uint32_t>(pts.size()));
          if (inserted) pts.push_back(allPts[v]);
          idx[c] = it->second;
        }
        tris.push_back({idx[0], idx[1], idx[2]});
      }
      static const bool profile = std::getenv("VELLUM_SHAPE_PROFILE") != nullptr;
      auto t0 = std::chrono::steady_clock::now();
      auto lap = [&](const char* what) {
        if (!profile) return;
        const auto t = std::chrono::steady_clock::now();
        std::fprintf(stderr, "  distance %-8s %7.1f ms\n", what, std::chrono::duration<double, std::milli>(t - t0).count());
        t0 = t;
      };
      // The component's distance over its band box (dense, isotropic), then sampled at the CT
      // voxel centres: no tree traversal per voxel. Outside that box: +far.
      const detail::DenseBox box = vdb.surfaceDistance(pts, tris, h, bandVox, limit, farMm);
      lap("sdf");
      if (!box.values.empty()) {
        const std::array<int, 3> lo = box.lo, dim = box.dim;
        const std::vector<float>& buf = box.values;
        const size_t sy = size_t(dim[0]), sz = size_t(dim[0]) * size_t(dim[1]);
        parallelFor(d.z, [&](int64_t k0, int64_t k1) {
          for (int64_t k = k0; k < k1; ++k) {
            const double fz = k * sp.z / h - lo[2];
            if (fz < 0 || fz > dim[2] - 1) continue;
            const int64_t z0 = std::min<int64_t>(int64_t(fz), dim[2] - 2 < 0 ? 0 : dim[2] - 2);
            const double tz = dim[2] > 1 ? fz - z0 : 0;
            for (int64_t j = 0; j < d.y; ++j) {
              const double fy = j * sp.y / h - lo[1];
              if (fy < 0 || fy > dim[1] - 1) continue;
              const int64_t y0 = std::min<int64_t>(int64_t(fy), dim[1] - 2 < 0 ? 0 : dim[1] - 2);
              const double ty = dim[1] > 1 ? fy - y0 : 0;
              for (int64_t i = 0; i < d.x; ++i) {
                const double fx = i * sp.x / h - lo[0];
                if (fx < 0 || fx > dim[0] - 1) continue;
                const int64_t x0 = std::min<int64_t>(int64_t(fx), dim[0] - 2 < 0 ? 0 : dim[0] - 2);
                const double tx = dim[0] > 1 ? fx - x0 : 0;
                const float* p = buf.data() + size_t(z0) * sz + size_t(y0) * sy + size_t(x0);
                float val;
                if (iso || (tx == 0 && ty == 0 && tz == 0)) {
                  val = *p;
                } else {
                const size_t ox = dim[0] > 1 ? 1 : 0, oy = dim[1] > 1 ? sy : 0, oz = dim[2] > 1 ? sz : 0;
                const double c00 = p[0] + tx * (p[ox] - p[0]);
                const double c10 = p[oy] + tx * (p[oy + ox] - p[oy]);
                const double c01 = p[oz] + tx * (p[oz + ox] - p[oz]);
                const double c11 = p[oz + oy] + tx * (p[oz + oy + ox] - p[oz + oy]);
                const double c0 = c00 + ty * (c10 - c00), c1 = c01 + ty * (c11 - c01);
                val = static_cast<float>(c0 + tz * (c1 - c0));
                }
                val = std::clamp(val, -farMm, farMm);
                const size_t at = dense.linearIndex(i, j, k);
                dense.data()[at] = std::min(dense.data()[at], std::abs(val));
                if (val < 0) parity[at] ^= 1;
              }
            }
          }
        });
        lap("sample");
      }
    }
    for (size_t n = 0; n < dense.size(); ++n)
      if (parity[n]) dense.data()[n] = -dense.data()[n];
    out[m] = std::move(dense);
  }, tbb::simple_partitioner());
  return out;
}

void buildRepresentation(std::vector<VolumeF32>& distances, const std::vector<Segment>& segments,
                         const std::vector<Shell>& shells, VolumeF32& unionDistance,
                         LabelVolume& segmentation) {
  if (distances.size() != segments.size() || distances.empty())
    throw Error("buildRepresentation: one distance volume per segment needed");
  const Geometry& g = distances.front().geometry();
  const size_t n = segments.size();
  if (n + shells.size() > 255) throw Error("too many segments and shells for a uint8 label map (max 255)");
  // Shell per segment (first one wins), with its label id.
  std::vector<double> shellT(n, 0.0);
  std::vector<uint16_t> shellId(n, 0);
  std::vector<Label> table;
  for (size_t i = 0; i < n; ++i)
    table.push_back({static_cast<uint16_t>(i + 1), segments[i].name, segments[i].rgb});
  for (size_t s = 0; s < shells.size(); ++s) {
    size_t idx = n;
    for (size_t i = 0; i < n; ++i)
      if (segments[i].name == shells[s].segment) idx = i;
    if (idx == n) throw Error("--shell: unknown segment '" + shells[s].segment + "'");
    if (!(shells[s].thicknessMm > 0)) throw Error("--shell " + shells[s].segment + ": thickness must be > 0 mm");
    const auto id = static_cast<uint16_t>(n + 1 + s);
    if (shellId[idx] == 0) {
      shellId[idx] = id;
      shellT[idx] = shells[s].thicknessMm;
    }
    auto rgb = segments[idx].rgb;
    for (auto& c : rgb) c = static_cast<uint8_t>(c / 2 + 64);  // a paler, distinct shade
    table.push_back({id, segments[idx].name + " boundary", rgb});
  }
  unionDistance = VolumeF32(g, 0.0f, distances.front().background());
  VolumeU16 ids(g, 0, 0.0);
  const size_t count = static_cast<size_t>(g.dims.voxelCount());
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    const size_t slice = static_cast<size_t>(g.dims.x * g.dims.y);
    for (size_t v = static_cast<size_t>(k0) * slice; v < static_cast<size_t>(k1) * slice && v < count; ++v) {
      float u = distances[0].data()[v];
      uint16_t label = 0;
      for (size_t i = 0; i < n; ++i) {  // later segments paint over earlier ones
        const float d = distances[i].data()[v];
        u = std::min(u, d);
        if (d < 0) label = (shellId[i] != 0 && d > -shellT[i]) ? shellId[i] : static_cast<uint16_t>(i + 1);
      }
      unionDistance.data()[v] = u;
      ids.data()[v] = label;
    }
  });
  segmentation = LabelVolume(std::move(ids), std::move(table));
  float far = std::numeric_limits<float>::infinity();
  for (const auto& d : distances) far = std::min(far, static_cast<float>(d.background()));
  if (std::isfinite(far)) extendFarField(unionDistance, far);
}

}  // namespace vellum::illustration
