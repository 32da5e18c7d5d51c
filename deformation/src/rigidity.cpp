#include "vellum/deformation/rigidity.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <variant>

#include "vellum/core/distance_transform.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/components.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/core/rigid_fit.hpp"
#include "vellum/deformation/synthesis.hpp"

namespace vellum::deformation {
namespace {

Mat3 mmToIndexOf(const Geometry& g) {
  const Mat3 toMm = indexToMm(g);
  Mat3 inv;
  if (!toMm.inverse(inv)) throw Error("rigidity: singular geometry");
  return inv;
}

// A body covering fewer control nodes than this is too small for the control grid to hold
// it rigid (its fit would be noise); it is left to the MLS map.
constexpr double kMinFitNodes = 8;

// A body's best rigid transform v -> u (core's weighted Kabsch fit); invalid for a body
// covering too few nodes.
struct RigidFit {
  RigidTransform transform;
  bool valid = false;
  Vec3 apply(const Vec3& v) const { return transform.apply(v); }
};

RigidFit fitBody(const RigidFitSums& s) {
  RigidFit f;
  if (s.weight < kMinFitNodes) return f;
  f.transform = fitRigid(s);
  f.valid = true;
  return f;
}

// Distance (mm) on `grid` to the nodes where inside[] is true (the shared exact EDT).
std::vector<float> distanceField(const Geometry& grid, const std::vector<uint8_t>& inside) {
  VolumeU8 features(grid, 0);
  std::copy(inside.begin(), inside.end(), features.data());
  const VolumeF32 d2 = squaredDistanceMm(features);
  std::vector<float> dist(d2.size());
  for (size_t t = 0; t < dist.size(); ++t) dist[t] = std::sqrt(std::min(d2.data()[t], 1e30f));
  return dist;
}

double sampleClamped(const std::vector<float>& f, const Dims& d, const Vec3& idx) {
  double c[3];
  int64_t i0[3];
  const int64_t dd[3] = {d.x, d.y, d.z};
  for (int a = 0; a < 3; ++a) {
    const double g = std::clamp(idx[a], 0.0, double(dd[a] - 1));
    i0[a] = std::min<int64_t>(static_cast<int64_t>(g), std::max<int64_t>(dd[a] - 2, 0));
    c[a] = dd[a] > 1 ? g - double(i0[a]) : 0.0;
  }
  // A one-node axis has no upper neighbour: its weight there is 0, so reuse the lower node.
  const int64_t step[3] = {d.x > 1 ? 1 : 0, d.y > 1 ? d.x : 0, d.z > 1 ? d.x * d.y : 0};
  const float* base = f.data() + (i0[2] * d.y + i0[1]) * d.x + i0[0];
  double r = 0;
  for (int q = 0; q < 8; ++q) {
    const int ox = q & 1, oy = (q >> 1) & 1, oz = (q >> 2) & 1;
    const double w = (ox ? c[0] : 1 - c[0]) * (oy ? c[1] : 1 - c[1]) * (oz ? c[2] : 1 - c[2]);
    if (w != 0) r += w * double(base[ox * step[0] + oy * step[1] + oz * step[2]]);
  }
  return r;
}

// classAt() on a grid's positions, skipping the voxel lookup (a cache miss in a large volume)
// where the cell holds no body: those positions are never class >= 2.
struct BodyClassLookup {
  const RigidBodies& bodies;
  const Geometry& grid;
  const std::vector<uint8_t>& bodyCells;
  Mat3 gridIdx = mmToIndexOf(grid);
  // Body class at u, or 0/1 (not a body) without telling which.
  uint16_t bodyClassAt(const Vec3& u) const {
    const Vec3 g = gridIdx * (u - grid.origin);
    const Dims& d = grid.dims;
    if (g.x >= 0 && g.y >= 0 && g.z >= 0 && g.x <= double(d.x - 1) && g.y <= double(d.y - 1) &&
        g.z <= double(d.z - 1) && d.x > 1 && d.y > 1 && d.z > 1) {
      const int64_t i = std::min<int64_t>(static_cast<int64_t>(g.x), d.x - 2);
      const int64_t j = std::min<int64_t>(static_cast<int64_t>(g.y), d.y - 2);
      const int64_t k = std::min<int64_t>(static_cast<int64_t>(g.z), d.z - 2);
      if (!bodyCells[static_cast<size_t>((k * d.y + j) * d.x + i)]) return 0;
    }
    return bodies.classAt(u);
  }
};

// Marks the cells of `grid` that a rigid voxel's nearest-voxel region (the voxel +- half a
// voxel per axis) reaches into.
std::vector<uint8_t> bodyCellsOf(const VolumeU16& classes, const Geometry& grid) {
  const Dims d = grid.dims, cd = classes.dims();
  std::vector<uint8_t> cells(static_cast<size_t>(d.voxelCount()), 0);
  if (d.x < 2 || d.y < 2 || d.z < 2) return cells;
  const Geometry& cg = classes.geometry();
  // Class index -> grid index: g = G x + g0; the half-voxel box maps into g +- delta.
  const Mat3 G = mmToIndexOf(grid) * cg.direction *
                 Mat3::fromColumns({cg.spacing.x, 0, 0}, {0, cg.spacing.y, 0}, {0, 0, cg.spacing.z});
  const Vec3 g0 = mmToIndexOf(grid) * (cg.origin - grid.origin);
  Vec3 delta;
  for (int a = 0; a < 3; ++a)
    delta[a] = 0.5 * (std::abs(G(a, 0)) + std::abs(G(a, 1)) + std::abs(G(a, 2))) + 1e-6;
  const int64_t hi[3] = {d.x - 2, d.y - 2, d.z - 2};
  parallelFor(cd.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < cd.y; ++j)
        for (int64_t i = 0; i < cd.x; ++i) {
          if (classes(i, j, k) < 2) continue;
          const Vec3 g = G * Vec3{double(i), double(j), double(k)} + g0;
          int64_t lo[3], up[3];
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::clamp<int64_t>(static_cast<int64_t>(std::floor(g[a] - delta[a])), 0, hi[a]);
            up[a] = std::clamp<int64_t>(static_cast<int64_t>(std::floor(g[a] + delta[a])), 0, hi[a]);
          }
          for (int64_t c = lo[2]; c <= up[2]; ++c)
            for (int64_t b = lo[1]; b <= up[1]; ++b)
              for (int64_t a = lo[0]; a <= up[0]; ++a)
                std::atomic_ref<uint8_t>(cells[static_cast<size_t>((c * d.y + b) * d.x + a)])
                    .store(1, std::memory_order_relaxed);
        }
  });
  return cells;
}

// A backward map sampled on a grid (control-grid nodes or full-resolution voxels): 3 floats
// per sample, x fastest. Measures visit every `stride`-th sample along each axis.
struct MapView {
  const float* mm;
  Geometry grid;
  int stride = 1;
  Vec3 at(int64_t t) const { return {mm[3 * t], mm[3 * t + 1], mm[3 * t + 2]}; }
  int64_t count(int64_t n) const { return (n + stride - 1) / stride; }
};

// Kabsch fits of v -> u per component over samples whose u lies in the component.
template <class ClassOf>
std::vector<RigidFit> fitComponents(const MapView& m, const RigidBodies& bodies, const ClassOf& classOf) {
  const int nc = bodies.componentCount();
  std::vector<RigidFitSums> sums(static_cast<size_t>(nc));
  std::mutex mutex;
  const Dims d = m.grid.dims;
  const int s = m.stride;
  parallelFor(m.count(d.z), [&](int64_t k0, int64_t k1) {
    std::vector<RigidFitSums> local(static_cast<size_t>(nc));
    for (int64_t k = k0 * s; k < std::min(k1 * s, d.z); k += s)
      for (int64_t j = 0; j < d.y; j += s)
        for (int64_t i = 0; i < d.x; i += s) {
          const Vec3 u = m.at((k * d.y + j) * d.x + i);
          const uint16_t c = classOf(u);
          if (c >= 2) local[c - 2u].add(m.grid.indexToPhysical({double(i), double(j), double(k)}), u);
        }
    std::lock_guard lock(mutex);
    for (int c = 0; c < nc; ++c) sums[static_cast<size_t>(c)].merge(local[static_cast<size_t>(c)]);
  });
  std::vector<RigidFit> fits;
  for (const auto& f : sums) fits.push_back(fitBody(f));
  return fits;
}

std::vector<RigidFit> fitComponents(const MapView& m, const RigidBodies& bodies) {
  return fitComponents(m, bodies, [&](const Vec3& u) { return bodies.classAt(u); });
}

RigidityReport measure(const MapView& m, const RigidBodies& bodies) {
  RigidityReport r;
  r.components = bodies.componentCount();
  r.stride = m.stride;
  const Dims d = m.grid.dims;
  const int s = m.stride;
  r.nodes = m.count(d.x) * m.count(d.y) * m.count(d.z);
  const auto fits = fitComponents(m, bodies);
  std::mutex mutex;
  double se = 0, maxRes = 0, soft = 0;
  int64_t boneN = 0, softN = 0, folds = 0, interior = 0;
  const Mat3 toMm = m.grid.direction * Mat3::fromColumns({m.grid.spacing.x, 0, 0},
                                                         {0, m.grid.spacing.y, 0},
                                                         {0, 0, m.grid.spacing.z});
  const double detIdx = toMm.determinant();
  parallelFor(m.count(d.z), [&](int64_t k0, int64_t k1) {
    double lse = 0, lmax = 0, lsoft = 0;
    int64_t lb = 0, ls = 0, lf = 0, li = 0;
    for (int64_t k = k0 * s; k < std::min(k1 * s, d.z); k += s)
      for (int64_t j = 0; j < d.y; j += s)
        for (int64_t i = 0; i < d.x; i += s) {
          const int64_t t = (k * d.y + j) * d.x + i;
          const Vec3 u = m.at(t);
          const Vec3 v = m.grid.indexToPhysical({double(i), double(j), double(k)});
          const uint16_t c = bodies.classAt(u);
          if (c >= 2 && fits[c - 2u].valid) {
            const double e = norm(u - fits[c - 2u].apply(v));
            lse += e * e; lmax = std::max(lmax, e); ++lb;
          } else if (c == 1) {
            lsoft += norm(u - v); ++ls;
          }
          if (i > 0 && j > 0 && k > 0 && i + 1 < d.x && j + 1 < d.y && k + 1 < d.z) {
            // Central differences between the sample's direct neighbours (not stride apart).
            const Vec3 dx = (m.at(t + 1) - m.at(t - 1)) * 0.5;
            const Vec3 dy = (m.at(t + d.x) - m.at(t - d.x)) * 0.5;
            const Vec3 dz = (m.at(t + d.x * d.y) - m.at(t - d.x * d.y)) * 0.5;
            // det(du/dv) = det(du/didx) / det(dv/didx)
            const double det = dot(dx, cross(dy, dz)) / detIdx;
            if (!(det > 0)) ++lf;
            ++li;
          }
        }
    std::lock_guard lock(mutex);
    se += lse; maxRes = std::max(maxRes, lmax); soft += lsoft;
    boneN += lb; softN += ls; folds += lf; interior += li;
  });
  r.boneNodes = boneN;
  r.softNodes = softN;
  r.boneRmsResidualMm = boneN ? std::sqrt(se / double(boneN)) : 0;
  r.boneMaxResidualMm = maxRes;
  r.softTissueMeanDisplacementMm = softN ? soft / double(softN) : 0;
  r.foldFraction = interior ? double(folds) / double(interior) : 0;
  return r;
}

// The voxel snap: every body's fit, and the output box its voxels can come from.
std::shared_ptr<const RigidSnap> makeRigidSnap(const RigidBodies& bodies, const std::vector<RigidFit>& fits,
                                               const Geometry& grid) {
  auto snap = std::make_shared<RigidSnap>();
  // Shares the class voxels with the bodies (aliasing shared_ptr: no copy per frame).
  snap->classes = std::shared_ptr<const std::vector<uint16_t>>(bodies.classesPtr(), &bodies.classes().voxels());
  snap->classGrid = bodies.classes().geometry();
  for (const auto& f : fits) {
    std::array<double, 12> m{};
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) m[static_cast<size_t>(3 * r + c)] = f.transform.rotation(r, c);
      m[static_cast<size_t>(9 + r)] = f.transform.translation[r];
    }
    snap->fits.push_back(m);
    snap->valid.push_back(f.valid ? 1 : 0);
  }
  // Interpolation errors inside a body are below a control-cell diagonal.
  snap->maxSnapMm = norm(grid.spacing);
  // Where the snap can apply, per body: output voxels v with R v + t within maxSnap of the
  // body's box, i.e. the preimage of the box (expanded) under the fit, bounded in output mm.
  const Geometry& cg = bodies.classes().geometry();
  for (int c = 0; c < bodies.componentCount(); ++c) {
    const auto& b = bodies.boxes()[static_cast<size_t>(c)];
    std::array<double, 6> box{1e300, 1e300, 1e300, -1e300, -1e300, -1e300};
    if (fits[static_cast<size_t>(c)].valid && b[3] >= b[0]) {
      const RigidTransform& fit = fits[static_cast<size_t>(c)].transform;
      const Mat3 rt = fit.rotation.transposed();
      for (int q = 0; q < 8; ++q) {
        const Vec3 idx{(q & 1) ? b[3] + 0.5 : b[0] - 0.5, (q & 2) ? b[4] + 0.5 : b[1] - 0.5,
                       (q & 4) ? b[5] + 0.5 : b[2] - 0.5};
        const Vec3 p = cg.indexToPhysical(idx);
        const Vec3 v = rt * (p - fit.translation);
        for (int a = 0; a < 3; ++a) {
          box[static_cast<size_t>(a)] = std::min(box[static_cast<size_t>(a)], v[a] - snap->maxSnapMm);
          box[static_cast<size_t>(a + 3)] = std::max(box[static_cast<size_t>(a + 3)], v[a] + snap->maxSnapMm);
        }
      }
    }
    snap->reachMm.push_back(box);
  }
  return snap;
}

}  // namespace

RigidBodies RigidBodies::fromMask(VolumeU16 classes, int64_t minVoxels) {
  // classes: 0 air, 1 soft, 2 rigid (not yet split). 26-connected: a thin cortex shell
  // touching only along edges/corners stays one body.
  RigidBodies rb;
  VolumeU8 rigid(classes.geometry(), 0, 0);
  for (size_t t = 0; t < rigid.size(); ++t) rigid.data()[t] = classes.data()[t] == 2;
  const Components parts = connectedComponents(rigid, Connectivity::Vertex26);
  // Small components become soft tissue; the rest are numbered 2, 3, ... in scan order.
  std::vector<uint16_t> remap(parts.sizes.size(), 1);
  uint16_t kept = 2;
  for (size_t l = 1; l < parts.sizes.size(); ++l) {
    if (parts.sizes[l] < minVoxels) continue;
    if (kept == 0xFFFF) throw Error("rigidity: too many rigid components");
    remap[l] = kept++;
    rb.boxes_.push_back({parts.boxes[l].lo[0], parts.boxes[l].lo[1], parts.boxes[l].lo[2],
                         parts.boxes[l].hi[0], parts.boxes[l].hi[1], parts.boxes[l].hi[2]});
  }
  for (size_t t = 0; t < classes.size(); ++t)
    if (const uint32_t l = parts.labels[t]) classes.data()[t] = remap[l];
  rb.components_ = kept - 2;
  rb.mmToIndex_ = mmToIndexOf(classes.geometry());
  rb.classes_ = std::make_shared<const VolumeU16>(std::move(classes));
  return rb;
}

RigidBodies RigidBodies::fromLabels(const LabelVolume& labels, const std::vector<uint16_t>& rigidIds,
                                    int64_t minVoxels) {
  VolumeU16 cls(labels.geometry(), 0, 0);
  const auto& ids = labels.ids().voxels();
  for (size_t t = 0; t < ids.size(); ++t) {
    const uint16_t id = ids[t];
    cls.data()[t] = id == 0 ? 0
                    : std::find(rigidIds.begin(), rigidIds.end(), id) != rigidIds.end() ? 2 : 1;
  }
  return fromMask(std::move(cls), minVoxels);
}

RigidBodies RigidBodies::fromThreshold(const AnyVolume& ct, double boneHu, double airHu,
                                       int64_t minVoxels) {
  VolumeU16 cls(geometryOf(ct), 0, 0);
  std::visit([&](const auto& vol) {
    for (size_t t = 0; t < vol.size(); ++t) {
      const double v = static_cast<double>(vol.data()[t]);
      cls.data()[t] = v >= boneHu ? 2 : v > airHu ? 1 : 0;
    }
  }, ct);
  return fromMask(std::move(cls), minVoxels);
}

std::shared_ptr<const RigidBodies::GridFields> RigidBodies::gridFields(const Geometry& grid) const {
  std::lock_guard lock(cache_->mutex);
  auto& entries = cache_->entries;
  for (size_t e = 0; e < entries.size(); ++e)
    if (entries[e].first.dims == grid.dims && entries[e].first.approxEqual(grid, 1e-6)) {
      std::rotate(entries.begin(), entries.begin() + static_cast<std::ptrdiff_t>(e), entries.begin() + static_cast<std::ptrdiff_t>(e) + 1);
      return entries.front().second;
    }
  const Dims d = grid.dims;
  const size_t nodes = static_cast<size_t>(d.voxelCount());
  checkMemoryBudget(static_cast<uint64_t>(nodes) * (sizeof(double) + sizeof(float) * (components_ + 1)),
                    "rigid-body distance fields");
  auto fields = std::make_shared<GridFields>();
  fields->perBody.resize(static_cast<size_t>(components_));
  fields->nearest.assign(nodes, std::numeric_limits<float>::infinity());
  std::vector<uint8_t> inside(nodes);
  for (int c = 0; c < components_; ++c) {
    parallelFor(d.z, [&](int64_t k0, int64_t k1) {
      for (int64_t k = k0; k < k1; ++k)
        for (int64_t j = 0; j < d.y; ++j)
          for (int64_t i = 0; i < d.x; ++i)
            inside[static_cast<size_t>((k * d.y + j) * d.x + i)] =
                classAt(grid.indexToPhysical({double(i), double(j), double(k)})) == c + 2;
    });
    auto& field = fields->perBody[static_cast<size_t>(c)];
    field = distanceField(grid, inside);
    for (size_t t = 0; t < nodes; ++t) fields->nearest[t] = std::min(fields->nearest[t], field[t]);
  }
  fields->bodyCells = bodyCellsOf(*classes_, grid);
  constexpr size_t kGridsKept = 3;
  entries.insert(entries.begin(), {grid, fields});
  if (entries.size() > kGridsKept) entries.pop_back();
  return fields;
}

uint16_t RigidBodies::classAt(const Vec3& mm) const {
  const Vec3 idx = mmToIndex_ * (mm - classes_->geometry().origin);
  return static_cast<uint16_t>(classes_->sampleNearest(idx));
}

void applyRigidity(ControlVolume& cv, const RigidBodies& bodies, const RigidityParams& params,
                   Progress& progress) {
  if (!(params.falloffMm >= 0)) throw Error("rigid falloff must be >= 0 mm");
  const int nc = bodies.componentCount();
  if (nc == 0) return;
  const Dims d = cv.grid.dims;
  progress.begin("rigid bodies", static_cast<uint64_t>(nc) + 1);
  // Distance fields (mm, source space sampled on the control grid) per component: built once
  // per grid and kept in the bodies (an animation re-blends every frame on the same grid).
  const auto dist = bodies.gridFields(cv.grid);
  const BodyClassLookup lookup{bodies, cv.grid, dist->bodyCells};
  const auto fits = fitComponents(MapView{cv.sourceMm.data(), cv.grid, 1}, bodies,
                                  [&](const Vec3& u) { return lookup.bodyClassAt(u); });
  progress.advance(static_cast<uint64_t>(nc));
  const Mat3 gridIdx = mmToIndexOf(cv.grid);
  // Weight 1 within one control spacing of the body. A wider core (a whole cell diagonal) makes
  // nodes between two bones (joint gap < cell) average both fits, which is worse; the voxel
  // snap (RigidSnap) makes voxels inside the body exact instead.
  const double margin = std::max({cv.grid.spacing.x, cv.grid.spacing.y, cv.grid.spacing.z});
  const double falloff = params.falloffMm;
  auto weight = [&](double dm) {
    if (dm <= margin) return 1.0;
    if (falloff <= 0 || dm >= margin + falloff) return 0.0;
    const double t = (dm - margin) / falloff;
    return 1.0 - t * t * (3 - 2 * t);
  };
  // Trilinear weights are positive, so a field interpolated at gi is never below the nearest-
  // body field interpolated there: beyond the band in that one field, every weight is 0.
  const double reach = falloff > 0 ? margin + falloff : margin;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int64_t node = (k * d.y + j) * d.x + i;
          const Vec3 u = cv.sourceAt(node);
          const Vec3 gi = gridIdx * (u - cv.grid.origin);
          if (sampleClamped(dist->nearest, d, gi) > reach) continue;
          const Vec3 v = cv.grid.indexToPhysical({double(i), double(j), double(k)});
          double sum = 0;
          Vec3 acc{};
          for (int c = 0; c < nc; ++c) {
            if (!fits[static_cast<size_t>(c)].valid) continue;
            const double a = weight(sampleClamped(dist->perBody[static_cast<size_t>(c)], d, gi));
            if (a <= 0) continue;
            sum += a;
            acc += fits[static_cast<size_t>(c)].apply(v) * a;
          }
          if (sum <= 0) continue;
          Vec3 out = sum >= 1 ? acc / sum : u * (1 - sum) + acc;
          // A node that now lands inside a body follows that body exactly (only happens in
          // the inner band where the weight is already ~1, so the snap is invisible).
          const uint16_t c2 = lookup.bodyClassAt(out);
          if (c2 >= 2 && fits[c2 - 2u].valid) out = fits[c2 - 2u].apply(v);
          float* o = cv.sourceMm.data() + 3 * node;
          o[0] = static_cast<float>(out.x); o[1] = static_cast<float>(out.y); o[2] = static_cast<float>(out.z);
        }
  });
  cv.rigidSnap = makeRigidSnap(bodies, fits, cv.grid);
  progress.end();
}

RigidityReport measureRigidity(const ControlVolume& cv, const RigidBodies& bodies) {
  if (cv.sourceMm.size() != 3 * static_cast<size_t>(cv.grid.dims.voxelCount()))
    throw Error("measureRigidity: control volume size does not match its grid");
  RigidityReport r = measure(MapView{cv.sourceMm.data(), cv.grid, 1}, bodies);
  r.voxelLevel = false;
  return r;
}

RigidityReport measureRigidityMap(const std::vector<float>& mapMm, const Geometry& output,
                                  const RigidBodies& bodies, int stride) {
  if (stride < 1) throw Error("rigidity measure stride must be >= 1");
  if (mapMm.size() != 3 * static_cast<size_t>(output.dims.voxelCount()))
    throw Error("measureRigidityMap: map size does not match the output grid");
  RigidityReport r = measure(MapView{mapMm.data(), output, stride}, bodies);
  r.voxelLevel = true;
  return r;
}

RigidityReport measureRigidityVoxels(const ControlVolume& cv, const Geometry& output,
                                     const RigidBodies& bodies, Upsampling upsampling, int stride) {
  return measureRigidityMap(upsampleMap(cv, output, upsampling), output, bodies, stride);
}

}  // namespace vellum::deformation
