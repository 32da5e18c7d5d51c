// The OpenVDB module (see src/vdb_functions.hpp): Whitaker-style constrained level-set
// denoising and surface extraction.
//
// The initial level set is the narrow-band signed distance (voxel units) of the binary mask's
// boundary from tools::topologyToLevelSet (zero crossings on the voxel faces between inside
// and outside voxels). Each iteration is one tools::LevelSetFilter mean-curvature step (which
// also renormalises the band), followed by the constraint of Whitaker (2000): at every voxel
// centre the sign of phi must stay that of the original mask, with a margin m:
// phi <= -m inside and phi >= +m outside (m = DenoiseOptions::marginVoxels, default 0.15:
// without it a one-voxel-thin sheet collapses onto its voxel centres, the minimal-area
// answer, and its two sides meet). Between two neighbouring centres of different label phi therefore
// changes sign, so the zero level set stays within half a voxel of the voxel face that
// separates them (the original binary boundary) while curvature flow removes the staircase.
#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/TopologyToLevelSet.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <openvdb/tree/LeafManager.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>

#include "../src/vdb_functions.hpp"

namespace vellum::illustration::detail {

namespace {
void initVdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}
constexpr float kHalfWidth = 2.0f;  // narrow band half width (voxels)
}  // namespace

struct LevelSet {
  openvdb::FloatGrid::Ptr grid;
};

namespace {
using FloatLeaf = openvdb::FloatTree::LeafNodeType;

/// Voxels of the original binary boundary (inside voxels with an outside face neighbour and
/// outside voxels with an inside face neighbour), grouped by the 8^3 leaf block they lie in:
/// the constraint then reads each block's leaf (or tile) once instead of walking the tree
/// for every voxel.
struct Boundary {
  std::vector<openvdb::Coord> origins;  ///< leaf origin of each block (full-grid coordinates)
  std::vector<uint32_t> start;          ///< block b's items: [start[b], start[b + 1])
  std::vector<uint16_t> items;          ///< leaf offset | 512 when the voxel is inside
};

Boundary boundaryVoxels(const MaskBox& m) {
  const int64_t bx0 = (m.ox >> 3), by0 = (m.oy >> 3), bz0 = (m.oz >> 3);
  const int64_t nbx = ((m.ox + m.nx - 1) >> 3) - bx0 + 1, nby = ((m.oy + m.ny - 1) >> 3) - by0 + 1,
                nbz = ((m.oz + m.nz - 1) >> 3) - bz0 + 1;
  const size_t nb = size_t(nbx * nby * nbz);
  std::vector<std::vector<uint16_t>> perBlock(nb);
  // tbb directly: this module links no Vellum library (its code would be a second copy).
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nb, 16), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); ++b) {
      const int64_t x0 = (bx0 + int64_t(b) % nbx) * 8, y0 = (by0 + (int64_t(b) / nbx) % nby) * 8,
                    z0 = (bz0 + int64_t(b) / (nbx * nby)) * 8;
      auto& out = perBlock[b];
      for (int64_t x = 0; x < 8; ++x)
        for (int64_t y = 0; y < 8; ++y)
          for (int64_t z = 0; z < 8; ++z) {
            const int64_t gi = x0 + x, gj = y0 + y, gk = z0 + z;
            const int64_t i = gi - m.ox, j = gj - m.oy, k = gk - m.oz;
            if (i < 0 || j < 0 || k < 0 || i >= m.nx || j >= m.ny || k >= m.nz) continue;  // outside the box
            bool in, edge;
            if (i > 0 && j > 0 && k > 0 && i + 1 < m.nx && j + 1 < m.ny && k + 1 < m.nz) {
              const uint8_t* p = m.inside.data() + size_t((k * m.ny + j) * m.nx + i);
              const int64_t sy = m.nx, sz = m.nx * m.ny;
              in = *p != 0;
              edge = (p[1] != 0) != in || (p[-1] != 0) != in || (p[sy] != 0) != in || (p[-sy] != 0) != in ||
                     (p[sz] != 0) != in || (p[-sz] != 0) != in;
            } else {
              in = m.at(gi, gj, gk);
              edge = m.at(gi + 1, gj, gk) != in || m.at(gi - 1, gj, gk) != in || m.at(gi, gj + 1, gk) != in ||
                     m.at(gi, gj - 1, gk) != in || m.at(gi, gj, gk + 1) != in || m.at(gi, gj, gk - 1) != in;
            }
            if (edge) out.push_back(uint16_t(x * 64 + y * 8 + z) | (in ? 512 : 0));
          }
    }
  });
  Boundary bd;
  bd.start.push_back(0);
  for (size_t b = 0; b < nb; ++b) {
    if (perBlock[b].empty()) continue;
    bd.origins.emplace_back(int((bx0 + int64_t(b) % nbx) * 8), int((by0 + (int64_t(b) / nbx) % nby) * 8),
                            int((bz0 + int64_t(b) / (nbx * nby)) * 8));
    bd.items.insert(bd.items.end(), perBlock[b].begin(), perBlock[b].end());
    bd.start.push_back(uint32_t(bd.items.size()));
  }
  return bd;
}

/// Whitaker's constraint: every voxel centre keeps the sign of the original mask.
void constrain(openvdb::FloatGrid& grid, const MaskBox& mask, const Boundary& boundary, float kEps) {
  // Active voxels (the narrow band), in parallel over leaves.
  openvdb::tree::LeafManager<openvdb::FloatTree> leaves(grid.tree());
  leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
    for (auto it = leaf.beginValueOn(); it; ++it) {
      const openvdb::Coord c = it.getCoord();
      const float v = *it;
      if (mask.at(c.x(), c.y(), c.z())) {
        if (v > -kEps) it.setValue(-kEps);
      } else if (v < kEps) {
        it.setValue(kEps);
      }
    }
  });
  // Boundary voxels the tracker may have pruned out of the band with the wrong sign: find
  // them in parallel (read-only; a block without a leaf has its tile's value throughout),
  // fix them serially (setValue may allocate leaves).
  std::vector<std::pair<openvdb::Coord, bool>> bad;
  std::mutex m;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, boundary.origins.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
    auto acc = grid.getConstAccessor();
    std::vector<std::pair<openvdb::Coord, bool>> local;
    for (size_t b = r.begin(); b < r.end(); ++b) {
      const openvdb::Coord& origin = boundary.origins[b];
      const FloatLeaf* leaf = acc.probeConstLeaf(origin);
      const float tile = leaf ? 0.0f : acc.getValue(origin);
      for (uint32_t n = boundary.start[b]; n < boundary.start[b + 1]; ++n) {
        const openvdb::Index off = boundary.items[n] & 511;
        const bool in = (boundary.items[n] & 512) != 0;
        const float v = leaf ? leaf->getValue(off) : tile;
        if (in ? v > -kEps : v < kEps) local.emplace_back(origin + FloatLeaf::offsetToLocalCoord(off), in);
      }
    }
    if (!local.empty()) {
      std::lock_guard<std::mutex> lock(m);
      bad.insert(bad.end(), local.begin(), local.end());
    }
  });
  auto acc = grid.getAccessor();
  for (const auto& [c, in] : bad) acc.setValue(c, in ? -kEps : kEps);
}
}  // namespace

namespace {
LevelSet* denoise(const MaskBox& mask, int iterations, double margin) {
  const float kEps = static_cast<float>(std::clamp(margin, 1e-3, 0.45));
  initVdb();
  static const bool profile = std::getenv("VELLUM_SHAPE_PROFILE") != nullptr;
  auto t0 = std::chrono::steady_clock::now();
  auto lap = [&](const char* what) {
    if (!profile) return;
    const auto t = std::chrono::steady_clock::now();
    std::fprintf(stderr, "  denoise %-10s %7.1f ms (box %lldx%lldx%lld)\n", what,
                 std::chrono::duration<double, std::milli>(t - t0).count(), (long long)mask.nx,
                 (long long)mask.ny, (long long)mask.nz);
    t0 = t;
  };
  auto ls = std::make_unique<LevelSet>();
  if (mask.count == 0) {
    ls->grid = openvdb::FloatGrid::create(kHalfWidth);
    ls->grid->setGridClass(openvdb::GRID_LEVEL_SET);
    return ls.release();
  }
  // The mask's topology (active = inside) built leaf by leaf straight from the mask's bytes
  // (8^3 blocks in parallel, empty blocks skipped): no dense float copy of the box, no
  // per-voxel tree traversal. Then OpenVDB's topologyToLevelSet: a narrow band whose zero
  // crossing lies on the faces between active and inactive voxels, normalised by the PDE
  // tracker (much cheaper than meshing the staircase and rebuilding with levelSetRebuild).
  using MaskLeaf = openvdb::MaskGrid::TreeType::LeafNodeType;
  const int64_t bx0 = (mask.ox >> 3), by0 = (mask.oy >> 3), bz0 = (mask.oz >> 3);
  const int64_t bx1 = ((mask.ox + mask.nx - 1) >> 3), by1 = ((mask.oy + mask.ny - 1) >> 3),
                bz1 = ((mask.oz + mask.nz - 1) >> 3);
  const int64_t nbx = bx1 - bx0 + 1, nby = by1 - by0 + 1, nbz = bz1 - bz0 + 1;
  std::vector<std::unique_ptr<MaskLeaf>> leaves(size_t(nbx * nby * nbz));
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, int64_t(leaves.size())), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t b = r.begin(); b < r.end(); ++b) {
      const int64_t x0 = (bx0 + b % nbx) * 8, y0 = (by0 + (b / nbx) % nby) * 8, z0 = (bz0 + b / (nbx * nby)) * 8;
      std::unique_ptr<MaskLeaf> leaf;
      for (int64_t x = 0; x < 8; ++x)
        for (int64_t y = 0; y < 8; ++y)
          for (int64_t z = 0; z < 8; ++z)
            if (mask.at(x0 + x, y0 + y, z0 + z)) {
              if (!leaf) leaf = std::make_unique<MaskLeaf>(openvdb::Coord(int(x0), int(y0), int(z0)), false);
              leaf->setValueOn(openvdb::Index(x * 64 + y * 8 + z));
            }
      leaves[size_t(b)] = std::move(leaf);
    }
  });
  auto topology = openvdb::MaskGrid::create(false);
  for (auto& leaf : leaves)
    if (leaf) topology->tree().addLeaf(leaf.release());
  leaves.clear();
  lap("copy");
  ls->grid = openvdb::tools::topologyToLevelSet(*topology, int(kHalfWidth), 0, 0, 0);
  topology.reset();
  lap("topology");
  ls->grid->setGridClass(openvdb::GRID_LEVEL_SET);
  // The constraint also runs once before the flow: it repairs any voxel centre whose sign
  // the rebuild got wrong (thin one-voxel structures), so even 0 iterations respect the band.
  const auto boundary = boundaryVoxels(mask);
  lap("boundary");
  constrain(*ls->grid, mask, boundary, kEps);
  lap("constrain");
  if (iterations > 0) {
    openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(*ls->grid);
    // First-order upwind renormalisation, one pass a step: the constraint pins the surface to
    // the half-voxel band anyway, so OpenVDB's default (HJWENO5, 3 passes) would mostly add
    // time.
    filter.setSpatialScheme(openvdb::math::FIRST_BIAS);
    filter.setTemporalScheme(openvdb::math::TVD_RK1);
    filter.setNormCount(1);
    for (int it = 0; it < iterations; ++it) {
      filter.meanCurvature();
      constrain(*ls->grid, mask, boundary, kEps);
    }
  }
  lap("flow");
  return ls.release();
}

void release(LevelSet* levelSet) { delete levelSet; }

void toDense(const LevelSet& ls, std::array<int64_t, 3> dims, float* out) {
  const openvdb::CoordBBox box(openvdb::Coord(0, 0, 0),
                               openvdb::Coord(int(dims[0] - 1), int(dims[1] - 1), int(dims[2] - 1)));
  openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> dense(box, out);
  openvdb::tools::copyToDense(*ls.grid, dense);
  const size_t n = size_t(dims[0]) * size_t(dims[1]) * size_t(dims[2]);
  for (size_t i = 0; i < n; ++i) out[i] = std::clamp(out[i], -kHalfWidth, kHalfWidth);
}

TriMesh indexMesh(const LevelSet& ls, double adaptivity) {
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*ls.grid, points, tris, quads, 0.0, adaptivity);
  TriMesh m;
  m.vertices.reserve(points.size());
  for (const auto& p : points) m.vertices.push_back({p.x(), p.y(), p.z()});
  m.faces.reserve(tris.size() + 2 * quads.size());
  // OpenVDB's winding is the reverse of outward counter-clockwise for level sets.
  for (const auto& t : tris) m.faces.push_back({t.x(), t.z(), t.y()});
  for (const auto& q : quads) {
    m.faces.push_back({q.x(), q.z(), q.y()});
    m.faces.push_back({q.x(), q.w(), q.z()});
  }
  return m;
}

}  // namespace
}  // namespace vellum::illustration::detail

extern "C" const vellum::illustration::detail::VdbFunctions* vellum_vdb_functions() {
  namespace d = vellum::illustration::detail;
  static const d::VdbFunctions functions{d::kVdbFunctionsVersion, d::kHalfWidth, &d::denoise, &d::release,
                                         &d::toDense, &d::indexMesh};
  return &functions;
}
