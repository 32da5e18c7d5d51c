#include "vellum/deformation/rigidity.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>

#include "vellum/core/distance_transform.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/index_frame.hpp"
#include "vellum/core/rigid_fit.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/deformation/twist_frames.hpp"

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
// voxel per axis) reaches into: of every body, or of class `only` alone.
std::vector<uint8_t> bodyCellsOf(const VolumeU16& classes, const Geometry& grid, uint16_t only = 0) {
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
          if (classes(i, j, k) < 2 || (only && classes(i, j, k) != only)) continue;
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
  /// The number of the sample at grid index (i, j, k) (multiples of the stride) among the
  /// visited ones, x fastest.
  int64_t sample(int64_t i, int64_t j, int64_t k) const {
    return ((k / stride) * count(grid.dims.y) + j / stride) * count(grid.dims.x) + i / stride;
  }
};

// Kabsch fits of v -> u per component over samples whose u lies in the component;
// classOf(n, u): the class at u, sample n of the strided samples (x fastest).
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
          const uint16_t c = classOf(m.sample(i, j, k), u);
          if (c >= 2) local[c - 2u].add(m.grid.indexToPhysical({double(i), double(j), double(k)}), u);
        }
    std::lock_guard lock(mutex);
    for (int c = 0; c < nc; ++c) sums[static_cast<size_t>(c)].merge(local[static_cast<size_t>(c)]);
  });
  std::vector<RigidFit> fits;
  for (const auto& f : sums) fits.push_back(fitBody(f));
  // The fixed regions are not fitted: they stay where they are.
  if (const int f = bodies.fixedBody(); f >= 0) fits[static_cast<size_t>(f)] = RigidFit{RigidTransform{}, true};
  return fits;
}

double rotationAngleDeg(const Mat3& r) {
  const double c = std::clamp((r(0, 0) + r(1, 1) + r(2, 2) - 1) / 2, -1.0, 1.0);
  return std::acos(c) * 180.0 / 3.14159265358979323846;
}

// Fixed content shown this far (mm) from where it is counts as moved elsewhere (float
// rounding of the identity is ~1e-5 mm).
constexpr double kFixedElsewhereMm = 1e-3;

// Per-thread sums of measure().
struct MeasureSums {
  explicit MeasureSums(size_t bodies) : bodySe(bodies, 0), bodyMax(bodies, 0), bodyN(bodies, 0) {}
  double se = 0, maxRes = 0, soft = 0, softMax = 0, fixedSum = 0, fixedSe = 0, fixedMax = 0, elsewhereMax = 0;
  double minDet = std::numeric_limits<double>::infinity();
  Vec3 minDetAt{0, 0, 0};
  int64_t boneN = 0, softN = 0, folds = 0, tissue = 0, fixedN = 0, elsewhereN = 0;
  std::vector<double> bodySe, bodyMax;
  std::vector<int64_t> bodyN;
  void merge(const MeasureSums& o) {
    se += o.se; maxRes = std::max(maxRes, o.maxRes); soft += o.soft; softMax = std::max(softMax, o.softMax);
    fixedSum += o.fixedSum; fixedSe += o.fixedSe; fixedMax = std::max(fixedMax, o.fixedMax);
    elsewhereN += o.elsewhereN; elsewhereMax = std::max(elsewhereMax, o.elsewhereMax);
    if (o.minDet < minDet) minDet = o.minDet, minDetAt = o.minDetAt;
    boneN += o.boneN; softN += o.softN; folds += o.folds; tissue += o.tissue; fixedN += o.fixedN;
    for (size_t c = 0; c < bodySe.size(); ++c) {
      bodySe[c] += o.bodySe[c]; bodyMax[c] = std::max(bodyMax[c], o.bodyMax[c]); bodyN[c] += o.bodyN[c];
    }
  }
};

RigidityReport measure(const MapView& m, const RigidBodies& bodies) {
  RigidityReport r;
  r.components = bodies.componentCount();
  r.stride = m.stride;
  const Dims d = m.grid.dims;
  const int s = m.stride;
  r.nodes = m.count(d.x) * m.count(d.y) * m.count(d.z);
  // The class at every sample's u, looked up once for the fits and the measures (a read of the
  // CT-sized class volume per sample: the largest cost of a movie frame's node measure); up to
  // 2^25 samples (64 MB), beyond (a keyframe's voxels) looked up twice rather than held.
  std::vector<uint16_t> sampleClass;
  if (r.nodes <= (int64_t{1} << 25)) {
    resizeHugePaged(sampleClass, static_cast<size_t>(r.nodes));
    parallelFor(m.count(d.z), [&](int64_t k0, int64_t k1) {
      for (int64_t k = k0 * s; k < std::min(k1 * s, d.z); k += s)
        for (int64_t j = 0; j < d.y; j += s)
          for (int64_t i = 0; i < d.x; i += s)
            sampleClass[static_cast<size_t>(m.sample(i, j, k))] = bodies.classAt(m.at((k * d.y + j) * d.x + i));
    });
  }
  auto classOf = [&](int64_t n, const Vec3& u) {
    return sampleClass.empty() ? bodies.classAt(u) : sampleClass[static_cast<size_t>(n)];
  };
  const auto fits = fitComponents(m, bodies, classOf);
  const size_t nb = static_cast<size_t>(bodies.componentCount());
  const int fixed = bodies.fixedBody();
  const uint16_t fixedClass = fixed >= 0 ? static_cast<uint16_t>(fixed + 2) : 0;
  std::mutex mutex;
  MeasureSums total(nb);
  const Mat3 toMm = m.grid.direction * Mat3::fromColumns({m.grid.spacing.x, 0, 0},
                                                         {0, m.grid.spacing.y, 0},
                                                         {0, 0, m.grid.spacing.z});
  const double detIdx = toMm.determinant();
  parallelFor(m.count(d.z), [&](int64_t k0, int64_t k1) {
    MeasureSums l(nb);
    for (int64_t k = k0 * s; k < std::min(k1 * s, d.z); k += s)
      for (int64_t j = 0; j < d.y; j += s)
        for (int64_t i = 0; i < d.x; i += s) {
          const int64_t t = (k * d.y + j) * d.x + i;
          const Vec3 u = m.at(t);
          const Vec3 v = m.grid.indexToPhysical({double(i), double(j), double(k)});
          const uint16_t c = classOf(m.sample(i, j, k), u);
          // The fixed regions must not move: their voxels (output v in them) show what was
          // there. Their content shown elsewhere (u in them, v outside, moved) is counted apart:
          // a moving bone's rigid transform reaching into a fixed one at a joint (a collision).
          if (fixed >= 0) {
            if (bodies.classAt(v) == fixedClass) {
              const double e = norm(u - v);
              l.fixedSum += e; l.fixedSe += e * e; l.fixedMax = std::max(l.fixedMax, e); ++l.fixedN;
            } else if (c == fixedClass) {
              const double e = norm(u - v);
              if (e > kFixedElsewhereMm) { ++l.elsewhereN; l.elsewhereMax = std::max(l.elsewhereMax, e); }
            }
          }
          if (c >= 2 && c != fixedClass) {
            const size_t b = c - 2u;
            if (fits[b].valid) {
              const double e = norm(u - fits[b].apply(v));
              l.se += e * e; l.maxRes = std::max(l.maxRes, e); ++l.boneN;
              l.bodySe[b] += e * e; l.bodyMax[b] = std::max(l.bodyMax[b], e);
            }
            ++l.bodyN[b];
          } else if (c == 1) {
            const double e = norm(u - v);
            l.soft += e; l.softMax = std::max(l.softMax, e); ++l.softN;
          }
          // Folds count in tissue only: air may fold without harm (and the 0.13 %
          // over all samples hid 0.3-0.6 % in tissue).
          if (i > 0 && j > 0 && k > 0 && i + 1 < d.x && j + 1 < d.y && k + 1 < d.z && c >= 1 &&
              (c != fixedClass || bodies.tissueAt(u))) {
            // Central differences between the sample's direct neighbours (not stride apart).
            const Vec3 dx = (m.at(t + 1) - m.at(t - 1)) * 0.5;
            const Vec3 dy = (m.at(t + d.x) - m.at(t - d.x)) * 0.5;
            const Vec3 dz = (m.at(t + d.x * d.y) - m.at(t - d.x * d.y)) * 0.5;
            // det(du/dv) = det(du/didx) / det(dv/didx)
            const double det = dot(dx, cross(dy, dz)) / detIdx;
            if (!(det > 0)) ++l.folds;
            if (det < l.minDet) l.minDet = det, l.minDetAt = v;
            ++l.tissue;
          }
        }
    std::lock_guard lock(mutex);
    total.merge(l);
  });
  r.boneNodes = total.boneN;
  r.softNodes = total.softN;
  r.boneRmsResidualMm = total.boneN ? std::sqrt(total.se / double(total.boneN)) : 0;
  r.boneMaxResidualMm = total.maxRes;
  r.softTissueMeanDisplacementMm = total.softN ? total.soft / double(total.softN) : 0;
  r.softTissueMaxDisplacementMm = total.softMax;
  r.tissueSamples = total.tissue;
  r.foldFraction = total.tissue ? double(total.folds) / double(total.tissue) : 0;
  r.minJacobian = total.minDet;
  r.minJacobianAtMm = total.minDetAt;
  r.fixedSamples = total.fixedN;
  r.fixedMaxDisplacementMm = total.fixedMax;
  r.fixedMeanDisplacementMm = total.fixedN ? total.fixedSum / double(total.fixedN) : 0;
  r.fixedContentElsewhere = total.elsewhereN;
  r.fixedContentElsewhereMaxMm = total.elsewhereMax;
  for (size_t b = 0; b < nb; ++b) {
    RigidityReport::Body o;
    o.ids = bodies.bodies()[b].ids;
    o.fixed = bodies.bodies()[b].fixed;
    o.samples = total.bodyN[b];
    if (o.fixed) {
      o.samples = total.fixedN;
      o.fitted = true;
      // About the identity: the displacement itself.
      o.rmsResidualMm = total.fixedN ? std::sqrt(total.fixedSe / double(total.fixedN)) : 0;
      o.maxResidualMm = total.fixedMax;
    } else if (fits[b].valid) {
      o.fitted = true;
      o.rmsResidualMm = o.samples ? std::sqrt(total.bodySe[b] / double(o.samples)) : 0;
      o.maxResidualMm = total.bodyMax[b];
      o.rotationDeg = rotationAngleDeg(fits[b].transform.rotation);
      o.translationMm = fits[b].transform.translation;
    }
    r.bodies.push_back(std::move(o));
  }
  return r;
}

// The voxel snap: every body's fit, and the output box its voxels can come from.
std::shared_ptr<const RigidSnap> makeRigidSnap(const RigidBodies& bodies, const std::vector<RigidFit>& fits,
                                               double maxSnapMm) {
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
  // The fixed regions are held (RigidSnap::held): exactly still at their own voxels. Not the
  // bones a pose keeps still, though their fits are the identity too: the ordinary snap keeps
  // them rigid, and held rims beside tissue the node map moves were a jump that folded (feet
  // frames at 20 deg: 0.101 -> 0.114 % of tissue).
  const auto& list = bodies.bodies();
  for (size_t c = 0; c < fits.size(); ++c) snap->held.push_back(c < list.size() && list[c].fixed ? 1 : 0);
  snap->maxSnapMm = maxSnapMm;
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

// The width of the fixed regions' blend band: `falloff`, narrowed so that the band ends at the
// core of the nearest body whose transform moves it by more than half a cell (a still bone
// agrees with the fixed regions and may lie in their band). Measured on the grid's nodes:
// the smallest distance to the fixed regions over the nodes within `margin` of such a body.
double fixedBandClearance(const Geometry& grid, const RigidBodies& bodies, const RigidBodies::GridFields& dist,
                          const std::vector<RigidFit>& fits, int fixedBody, double margin, double fixedMargin,
                          double falloff) {
  const auto& fixedField = dist.perBody[static_cast<size_t>(fixedBody)];
  if (fixedField.dims.x == 0 || falloff <= 0) return falloff;
  const double minSpacing = grid.minSpacing();
  const Geometry& cg = bodies.classes().geometry();
  double clearance = std::numeric_limits<double>::infinity();
  for (int c = 0; c < bodies.componentCount(); ++c) {
    const auto& fit = fits[static_cast<size_t>(c)];
    const auto& field = dist.perBody[static_cast<size_t>(c)];
    if (c == fixedBody || !fit.valid || field.dims.x == 0) continue;
    // How far the transform moves the body (its box's corners).
    const auto& b = bodies.boxes()[static_cast<size_t>(c)];
    double moves = 0;
    for (int q = 0; q < 8; ++q) {
      const Vec3 p = cg.indexToPhysical({double((q & 1) ? b[3] : b[0]), double((q & 2) ? b[4] : b[1]),
                                         double((q & 4) ? b[5] : b[2])});
      moves = std::max(moves, norm(fit.apply(p) - p));
    }
    if (moves <= 0.5 * minSpacing) continue;
    std::mutex m;
    parallelFor(field.dims.z, [&](int64_t k0, int64_t k1) {
      double local = std::numeric_limits<double>::infinity();
      for (int64_t k = k0; k < k1; ++k)
        for (int64_t j = 0; j < field.dims.y; ++j)
          for (int64_t i = 0; i < field.dims.x; ++i) {
            if (field.dist[static_cast<size_t>((k * field.dims.y + j) * field.dims.x + i)] > margin) continue;
            local = std::min(local, fixedField.at(i + field.lo[0], j + field.lo[1], k + field.lo[2]));
          }
      std::lock_guard lock(m);
      clearance = std::min(clearance, local);
    });
  }
  return std::clamp(clearance - fixedMargin, 0.0, falloff);
}

}  // namespace

double RigidBodies::GridFields::BodyField::at(int64_t i, int64_t j, int64_t k) const {
  const int64_t a = i - lo[0], b = j - lo[1], c = k - lo[2];
  if (a < 0 || b < 0 || c < 0 || a >= dims.x || b >= dims.y || c >= dims.z) return std::numeric_limits<double>::infinity();
  return dist[static_cast<size_t>((c * dims.y + b) * dims.x + a)];
}

double RigidBodies::GridFields::BodyField::sample(const Vec3& gi, const Dims& grid) const {
  if (dims.x == 0) return std::numeric_limits<double>::infinity();
  // The whole grid: the clamped trilinear sample the nearest field uses.
  if (dims == grid) return sampleClamped(dist, dims, gi);
  // The stencil's nodes (as sampleClamped picks them on the whole grid) must lie in the box.
  const int64_t gd[3] = {grid.x, grid.y, grid.z}, bd[3] = {dims.x, dims.y, dims.z};
  Vec3 local;
  for (int a = 0; a < 3; ++a) {
    const double g = std::clamp(gi[a], 0.0, double(gd[a] - 1));
    const int64_t i0 = std::min<int64_t>(static_cast<int64_t>(g), std::max<int64_t>(gd[a] - 2, 0));
    if (i0 < lo[static_cast<size_t>(a)] || i0 + (gd[a] > 1 ? 1 : 0) >= lo[static_cast<size_t>(a)] + bd[a])
      return std::numeric_limits<double>::infinity();
    local[a] = g - double(lo[static_cast<size_t>(a)]);
  }
  return sampleClamped(dist, dims, local);
}

std::shared_ptr<const RigidBodies::GridFields> RigidBodies::gridFields(const Geometry& grid, double reachMm) const {
  if (!(reachMm >= 0)) throw Error("rigid-body distance fields: the reach must be >= 0 mm");
  std::lock_guard lock(cache_->mutex);
  auto& entries = cache_->entries;
  for (size_t e = 0; e < entries.size(); ++e)
    if (entries[e].first.dims == grid.dims && entries[e].first.approxEqual(grid, 1e-6) &&
        entries[e].second->reachMm >= reachMm) {
      std::rotate(entries.begin(), entries.begin() + static_cast<std::ptrdiff_t>(e), entries.begin() + static_cast<std::ptrdiff_t>(e) + 1);
      return entries.front().second;
    }
  const Dims d = grid.dims;
  const size_t nodes = static_cast<size_t>(d.voxelCount());
  const int nc = componentCount();
  checkMemoryBudget(static_cast<uint64_t>(nodes) * (sizeof(double) + sizeof(uint16_t) + sizeof(float) * 3),
                    "rigid-body distance fields");
  auto fields = std::make_shared<GridFields>();
  fields->perBody.resize(static_cast<size_t>(nc));
  fields->nearest.assign(nodes, std::numeric_limits<float>::infinity());
  fields->reachMm = reachMm;
  // The class at every node once (a body may have many pieces; the classes are looked up once).
  std::vector<uint16_t> nodeClass(nodes);
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i)
          nodeClass[static_cast<size_t>((k * d.y + j) * d.x + i)] =
              classAt(grid.indexToPhysical({double(i), double(j), double(k)}));
  });
  // A box holds the body and every node within reach + 2 cell diagonals of it: a trilinear
  // stencil with a node outside then lies wholly beyond the reach (distances are 1-Lipschitz).
  const double diag = norm(grid.spacing);
  const double minSpacing = grid.minSpacing();
  const double growMm = reachMm + 2 * diag;
  const int64_t grow = std::isfinite(growMm) && growMm / minSpacing < 1e9
                           ? static_cast<int64_t>(std::ceil(growMm / minSpacing)) + 1
                           : std::max({d.x, d.y, d.z});
  std::vector<uint8_t> inside(nodes);
  for (int c = 0; c < nc; ++c) {
    const uint16_t cls = static_cast<uint16_t>(c + 2);
    parallelFor(static_cast<int64_t>(nodes), [&](int64_t t0, int64_t t1) {
      for (int64_t t = t0; t < t1; ++t) inside[static_cast<size_t>(t)] = nodeClass[static_cast<size_t>(t)] == cls;
    });
    if (c == fixedBody_ && d.x > 1 && d.y > 1 && d.z > 1) {
      // The fixed regions: every corner of a cell that holds one of their voxels, so that a
      // fixed structure thinner than the node spacing (a cortex shell between nodes) still has
      // identity nodes all around it and its voxels interpolate to where they are.
      const std::vector<uint8_t> cells = bodyCellsOf(*classes_, grid, cls);
      parallelFor(d.z, [&](int64_t k0, int64_t k1) {
        for (int64_t k = k0; k < k1; ++k)
          for (int64_t j = 0; j < d.y; ++j)
            for (int64_t i = 0; i < d.x; ++i) {
              bool any = false;
              for (int q = 0; q < 8 && !any; ++q) {
                const int64_t a = i - (q & 1), b = j - ((q >> 1) & 1), e = k - ((q >> 2) & 1);
                if (a < 0 || b < 0 || e < 0 || a > d.x - 2 || b > d.y - 2 || e > d.z - 2) continue;
                any = cells[static_cast<size_t>((e * d.y + b) * d.x + a)] != 0;
              }
              if (any) inside[static_cast<size_t>((k * d.y + j) * d.x + i)] = 1;
            }
      });
    }
    // The body's node box.
    int64_t lo[3] = {d.x, d.y, d.z}, hi[3] = {-1, -1, -1};
    for (int64_t k = 0; k < d.z; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i)
          if (inside[static_cast<size_t>((k * d.y + j) * d.x + i)]) {
            const int64_t p[3] = {i, j, k};
            for (int a = 0; a < 3; ++a) { lo[a] = std::min(lo[a], p[a]); hi[a] = std::max(hi[a], p[a]); }
          }
    auto& field = fields->perBody[static_cast<size_t>(c)];
    if (hi[0] < 0) continue;  // covers no node: left to the map
    const int64_t dd[3] = {d.x, d.y, d.z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max<int64_t>(lo[a] - grow, 0);
      hi[a] = std::min<int64_t>(hi[a] + grow, dd[a] - 1);
      field.lo[static_cast<size_t>(a)] = lo[a];
    }
    field.dims = {hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
    Geometry box = grid;
    box.dims = field.dims;
    box.origin = grid.indexToPhysical({double(lo[0]), double(lo[1]), double(lo[2])});
    std::vector<uint8_t> in(static_cast<size_t>(field.dims.voxelCount()));
    for (int64_t k = 0; k < field.dims.z; ++k)
      for (int64_t j = 0; j < field.dims.y; ++j)
        for (int64_t i = 0; i < field.dims.x; ++i)
          in[static_cast<size_t>((k * field.dims.y + j) * field.dims.x + i)] =
              inside[static_cast<size_t>(((k + lo[2]) * d.y + j + lo[1]) * d.x + i + lo[0])];
    field.dist = distanceField(box, in);
    for (int64_t k = 0; k < field.dims.z; ++k)
      for (int64_t j = 0; j < field.dims.y; ++j)
        for (int64_t i = 0; i < field.dims.x; ++i) {
          float& n = fields->nearest[static_cast<size_t>(((k + lo[2]) * d.y + j + lo[1]) * d.x + i + lo[0])];
          n = std::min(n, field.dist[static_cast<size_t>((k * field.dims.y + j) * field.dims.x + i)]);
        }
  }
  fields->bodyCells = bodyCellsOf(*classes_, grid);
  constexpr size_t kGridsKept = 3;
  entries.insert(entries.begin(), {grid, fields});
  if (entries.size() > kGridsKept) entries.pop_back();
  return fields;
}

FoldRepairStats applyRigidity(ControlVolume& cv, const RigidBodies& bodies, const RigidityParams& params,
                              Progress& progress) {
  return applyRigidity(cv, bodies, params, {}, progress);
}

FoldRepairStats applyRigidity(ControlVolume& cv, const RigidBodies& bodies, const RigidityParams& params,
                              const std::vector<std::optional<RigidTransform>>& prescribed, Progress& progress) {
  if (!(params.falloffMm >= 0)) throw Error("rigid falloff must be >= 0 mm");
  const int nc = bodies.componentCount();
  if (nc == 0) return {};
  const Dims d = cv.grid.dims;
  progress.begin("rigid bodies", static_cast<uint64_t>(nc) + 1);
  // Distance fields (mm, source space sampled on the control grid) per component: built once
  // per grid and kept in the bodies (an animation re-blends every frame on the same grid).
  // The band the blend reads, set below; the fields are exact that far (see gridFields()).
  const double bandMm = std::max({cv.grid.spacing.x, cv.grid.spacing.y, cv.grid.spacing.z, norm(cv.grid.spacing)}) +
                        std::max(params.falloffMm, 0.0);
  const auto dist = bodies.gridFields(cv.grid, bandMm);
  const BodyClassLookup lookup{bodies, cv.grid, dist->bodyCells};
  auto fits = fitComponents(MapView{cv.sourceMm.data(), cv.grid, 1}, bodies,
                            [&](int64_t, const Vec3& u) { return lookup.bodyClassAt(u); });
  for (size_t c = 0; c < prescribed.size() && c < fits.size(); ++c)
    if (prescribed[c] && static_cast<int>(c) != bodies.fixedBody()) fits[c] = {*prescribed[c], true};
  progress.advance(static_cast<uint64_t>(nc));
  const Mat3 gridIdx = mmToIndexOf(cv.grid);
  // Weight 1 within one control spacing of the body. A wider core (a whole cell diagonal) makes
  // nodes between two bones (joint gap < cell) average both fits, which is worse; the voxel
  // snap (RigidSnap) makes voxels inside the body exact instead.
  const double margin = std::max({cv.grid.spacing.x, cv.grid.spacing.y, cv.grid.spacing.z});
  // The fixed regions' core is their distance field's zero set: every corner of a cell that
  // holds a fixed voxel (gridFields() puts them in it), so those nodes are exactly v and
  // interpolation leaves the fixed voxels where they are (the snap makes them exact). A wider
  // core (it was a cell diagonal beyond them) only pushes the identity into the tissue beside.
  const double fixedMargin = 0;
  const double falloff = params.falloffMm;
  auto weightOver = [&](double dm, double core, double band) {
    if (dm <= core) return 1.0;
    if (band <= 0 || dm >= core + band) return 0.0;
    const double t = (dm - core) / band;
    return 1.0 - t * t * (3 - 2 * t);
  };
  auto weight = [&](double dm, double core) { return weightOver(dm, core, falloff); };
  const int fixedBody = bodies.fixedBody();
  // The fixed regions' band ends before the core of every body that moves. A fixed band over a
  // moving bone (the feet: a still box 7 mm from the turning hallux) pulls the tissue beside and
  // under the bone towards the identity while the bone itself keeps its transform: across the
  // direction of motion that is a 40 mm jump over a cell or two, a fold no repair can undo.
  // Ended short of the bone, the fixed weight depends on the distance to the fixed region
  // alone (a shear across the gap, fold-free: blending a turn with the identity keeps det > 0).
  const double fixedFalloff = fixedBody >= 0 ? fixedBandClearance(cv.grid, bodies, *dist, fits, fixedBody, margin,
                                                                  fixedMargin, falloff)
                                             : falloff;
  // Trilinear weights are positive, so a field interpolated at gi is never below the nearest-
  // body field interpolated there: beyond the band in that one field, every weight is 0.
  const double reach = std::max(fixedMargin, margin) + std::max(falloff, 0.0);
  // Nodes that land in a body (set to its fit) or in the fixed regions' core (the identity):
  // the fold repair never moves them. The band around a body stays free: the voxel snap keeps
  // the voxels that land in the body on its fit within a cell diagonal.
  std::vector<uint8_t> locked(params.repairFolds ? static_cast<size_t>(d.voxelCount()) : 0, 0);
  auto lock = [&](int64_t node, uint8_t level) {
    if (!locked.empty()) locked[static_cast<size_t>(node)] = level;
  };
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int64_t node = (k * d.y + j) * d.x + i;
          const Vec3 u = cv.sourceAt(node);
          const Vec3 gi = gridIdx * (u - cv.grid.origin);
          // The fixed regions count at the node itself too (v: the output must not move there).
          const bool nearFixed = fixedBody >= 0 && dist->perBody[static_cast<size_t>(fixedBody)].at(i, j, k) <= reach;
          if (!nearFixed && sampleClamped(dist->nearest, d, gi) > reach) continue;
          const Vec3 v = cv.grid.indexToPhysical({double(i), double(j), double(k)});
          float* o = cv.sourceMm.data() + 3 * node;
          double fixedW = 0;
          if (fixedBody >= 0) {
            const auto& f = dist->perBody[static_cast<size_t>(fixedBody)];
            fixedW = weightOver(std::min(f.sample(gi, d), f.at(i, j, k)), fixedMargin, fixedFalloff);
            if (fixedW >= 1) {  // exactly where it was
              o[0] = static_cast<float>(v.x); o[1] = static_cast<float>(v.y); o[2] = static_cast<float>(v.z);
              // Hard at the corners of the cells holding a fixed voxel (field 0 there): they
              // keep those voxels exactly still; the margin beyond may give way to a fold.
              lock(node, f.at(i, j, k) <= 0 ? kNodeHardLock : kNodeSoftLock);
              continue;
            }
          }
          // The moving bodies' blend with the MLS map first (overlapping bands normalised),
          // then the fixed regions' on top of it: where both bands reach, the fixed weight alone
          // decides how much of the identity there is, so across a fixed band the map is a
          // mix of the identity and the map beside it (no normalisation against a bone's core,
          // which made the identity's share vary with the distance to the bone).
          double sum = 0;
          bool core = false;  // weight 1 (within a spacing of a body): soft-locked
          Vec3 acc{0, 0, 0};
          for (int c = 0; c < nc; ++c) {
            if (c == fixedBody || !fits[static_cast<size_t>(c)].valid) continue;
            const double a = weight(dist->perBody[static_cast<size_t>(c)].sample(gi, d), margin);
            if (a <= 0) continue;
            core = core || a >= 1;
            sum += a;
            acc += fits[static_cast<size_t>(c)].apply(v) * a;
          }
          if (sum <= 0 && fixedW <= 0) continue;
          const Vec3 moving = sum <= 0 ? u : sum >= 1 ? acc / sum : u * (1 - sum) + acc;
          Vec3 out = moving * (1 - fixedW) + v * fixedW;
          // A node that now lands inside a body follows that body exactly (only happens in
          // the inner band where the weight is already ~1, so the snap is invisible).
          const uint16_t c2 = lookup.bodyClassAt(out);
          const bool inBody = c2 >= 2 && fits[c2 - 2u].valid;
          if (inBody) out = fits[c2 - 2u].apply(v);
          if (inBody) lock(node, kNodeHardLock);
          else if (core) lock(node, kNodeSoftLock);
          o[0] = static_cast<float>(out.x); o[1] = static_cast<float>(out.y); o[2] = static_cast<float>(out.z);
        }
  });
  // Interpolation errors inside a body are below a control-cell diagonal.
  cv.rigidSnap = makeRigidSnap(bodies, fits, norm(cv.grid.spacing));
  FoldRepairStats folds;
  if (params.repairFolds)
    folds = repairFolds(
        cv, locked, [&](const Vec3& u) { return bodies.tissueAt(u); }, params.folds,
        [&](const Vec3& u) {
          const uint16_t c = lookup.bodyClassAt(u);
          return c >= 2 && int(c) - 2 != fixedBody && fits[c - 2u].valid;
        });
  progress.end();
  return folds;
}

RigidityReport worstOf(const std::vector<RigidityReport>& reports) {
  if (reports.empty()) return {};
  RigidityReport w = reports.front();
  for (size_t f = 1; f < reports.size(); ++f) {
    const RigidityReport& m = reports[f];
    w.boneRmsResidualMm = std::max(w.boneRmsResidualMm, m.boneRmsResidualMm);
    w.boneMaxResidualMm = std::max(w.boneMaxResidualMm, m.boneMaxResidualMm);
    w.softTissueMeanDisplacementMm = std::max(w.softTissueMeanDisplacementMm, m.softTissueMeanDisplacementMm);
    w.softTissueMaxDisplacementMm = std::max(w.softTissueMaxDisplacementMm, m.softTissueMaxDisplacementMm);
    w.foldFraction = std::max(w.foldFraction, m.foldFraction);
    if (m.minJacobian < w.minJacobian) w.minJacobian = m.minJacobian, w.minJacobianAtMm = m.minJacobianAtMm;
    w.fixedMaxDisplacementMm = std::max(w.fixedMaxDisplacementMm, m.fixedMaxDisplacementMm);
    w.fixedMeanDisplacementMm = std::max(w.fixedMeanDisplacementMm, m.fixedMeanDisplacementMm);
    w.fixedContentElsewhere = std::max(w.fixedContentElsewhere, m.fixedContentElsewhere);
    w.fixedContentElsewhereMaxMm = std::max(w.fixedContentElsewhereMaxMm, m.fixedContentElsewhereMaxMm);
    w.nodes = std::max(w.nodes, m.nodes);
    w.boneNodes = std::max(w.boneNodes, m.boneNodes);
    w.softNodes = std::max(w.softNodes, m.softNodes);
    w.tissueSamples = std::max(w.tissueSamples, m.tissueSamples);
    w.fixedSamples = std::max(w.fixedSamples, m.fixedSamples);
    for (size_t b = 0; b < std::min(w.bodies.size(), m.bodies.size()); ++b) {
      auto& x = w.bodies[b];
      const auto& y = m.bodies[b];
      x.samples = std::max(x.samples, y.samples);
      x.fitted = x.fitted || y.fitted;
      x.rmsResidualMm = std::max(x.rmsResidualMm, y.rmsResidualMm);
      x.maxResidualMm = std::max(x.maxResidualMm, y.maxResidualMm);
      if (y.rotationDeg > x.rotationDeg) {  // the frame where it turns most
        x.rotationDeg = y.rotationDeg;
        x.translationMm = y.translationMm;
      }
    }
  }
  return w;
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

std::shared_ptr<const RigidSnap> rigidSnapOf(const RigidBodies& bodies, const std::vector<RigidTransform>& backward,
                                             double maxSnapMm) {
  if (backward.size() != bodies.bodies().size()) throw Error("rigid snap: one transform per body is needed");
  std::vector<RigidFit> fits;
  for (const RigidTransform& t : backward) fits.push_back(RigidFit{t, true});
  return makeRigidSnap(bodies, fits, maxSnapMm);
}

}  // namespace vellum::deformation
