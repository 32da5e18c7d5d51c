#include "vellum/phantom/phantom.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "anatomy.hpp"
#include "noise.hpp"
#include "subsamples.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::phantom {
namespace {

using detail::Anatomy;
using detail::Classified;
using detail::Distances;

constexpr int64_t kMinDim = 16, kMaxDim = 1024;

void checkFlexion(double deg) {
  if (!std::isfinite(deg) || deg < 0.0 || deg > 90.0)
    throw Error("phantom: kneeFlexionDeg must be within [0, 90], got " + std::to_string(deg));
}

Geometry phantomGeometry(const PhantomOptions& o) {
  Geometry g;
  g.dims = o.dims;
  for (int a = 0; a < 3; ++a)
    if (o.dims[a] < kMinDim || o.dims[a] > kMaxDim)
      throw Error("phantom: dims must be within " + std::to_string(kMinDim) + ".." +
                  std::to_string(kMaxDim) + " per axis, got " + o.dims.str());
  const bool explicitSpacing = o.spacing.x != 0 || o.spacing.y != 0 || o.spacing.z != 0;
  for (int a = 0; a < 3; ++a) {
    if (explicitSpacing) {
      if (!(std::isfinite(o.spacing[a]) && o.spacing[a] > 0))
        throw Error("phantom: spacing must be positive and finite on every axis");
      g.spacing[a] = o.spacing[a];
    } else {
      if (!(std::isfinite(o.fieldOfViewMm[a]) && o.fieldOfViewMm[a] > 0))
        throw Error("phantom: fieldOfViewMm must be positive and finite on every axis");
      g.spacing[a] = o.fieldOfViewMm[a] / static_cast<double>(o.dims[a]);
    }
    // Centred on (0,0,0): voxel centres run symmetrically about the origin.
    g.origin[a] = -0.5 * static_cast<double>(o.dims[a] - 1) * g.spacing[a];
  }
  g.direction = Mat3::identity();
  return g;
}

std::array<double, detail::kTissueCount> tissueHu(const TissueHu& h) {
  std::array<double, detail::kTissueCount> t{};
  t[detail::tAir] = h.air;
  t[detail::tSkin] = h.skin;
  t[detail::tFat] = h.fat;
  t[detail::tMuscle] = h.muscle;
  t[detail::tCortex] = h.cortex;
  t[detail::tMarrow] = h.marrow;
  t[detail::tCancellous] = h.cancellous;
  t[detail::tCartilage] = h.cartilage;
  return t;
}

std::vector<Label> labelTable() {
  return {{kSkin, "skin", {225, 172, 150}},
          {kFat, "subcutaneous fat", {245, 220, 120}},
          {kMuscle, "muscle", {185, 60, 55}},
          {kFemurCortex, "femur cortex", {245, 240, 220}},
          {kFemurMarrow, "femur marrow", {215, 150, 90}},
          {kTibiaCortex, "tibia cortex", {220, 230, 250}},
          {kTibiaMarrow, "tibia marrow", {150, 120, 190}},
          {kFibula, "fibula", {130, 210, 140}},
          {kPatella, "patella", {250, 190, 80}},
          {kCartilage, "cartilage", {90, 175, 230}},
          {kCancellous, "cancellous bone", {200, 170, 120}}};
}

struct Mixed {
  double hu;       ///< mean tissue HU of the sub-samples
  uint16_t label;  ///< majority label of the sub-samples
};

/// Mean tissue HU and majority label (ties: detail::kTieRank) over the sub-samples `off`
/// (mm from the voxel centre p, all within `cloudMm` of it). Bone groups near the voxel are
/// re-evaluated exactly at every sub-sample. The leg envelope (skin/fat/muscle surfaces,
/// radii of curvature >= ~40 mm) is linearised from central differences at the centre, and
/// re-evaluated exactly only at sub-samples the linear form puts within `exactBandMm` of a
/// surface (beyond the linearisation error): same result as exact evaluation, a fraction of
/// the cost. Far groups keep their centre values (their sign cannot change in the voxel).
Mixed mixture(const Anatomy& anatomy, const Vec3& p, const Distances& centre, uint32_t near,
              const std::array<Vec3, kSubSamples>& off, double cloudMm, double exactBandMm,
              const std::array<double, detail::kTissueCount>& hu) {
  Vec3 gradOuter, gradMuscle;  // the fat surface is the outer one offset: same gradient
  bool leg = (near & detail::gLeg) != 0;
  uint32_t exact = near & ~uint32_t{detail::gLeg};
  // Across the thigh/calf seam the envelope is not smooth: no linearisation there.
  if (leg && std::abs(anatomy.seamDistance(p)) < cloudMm + 0.1) {
    exact |= detail::gLeg;
    leg = false;
  }
  if (leg) {
    constexpr double h = 0.05;
    for (int a = 0; a < 3; ++a) {
      Vec3 e;
      e[a] = h;
      Distances lo, hi;
      anatomy.evaluate(p - e, detail::gLeg, lo);
      anatomy.evaluate(p + e, detail::gLeg, hi);
      gradOuter[a] = (hi.legOuter - lo.legOuter) / (2 * h);
      gradMuscle[a] = (hi.legMuscle - lo.legMuscle) / (2 * h);
    }
  }
  double sum = 0;
  std::array<uint8_t, detail::kLabelCount> counts{};  // at most 64 per label
  const bool insideOther = centre.femurOuter < 0 || centre.tibiaOuter < 0 ||
                           centre.fibulaOuter < 0 || centre.patellaOuter < 0 ||
                           centre.femurCartilage < 0 || centre.tibiaCartilage < 0;
  if (leg && exact == 0 && !insideOther) {
    // Fast path, the common case: only the skin/fat/muscle surfaces cross the voxel.
    for (int n = 0; n < kSubSamples; ++n) {
      const Vec3& delta = off[n];
      const double dOuter = dot(gradOuter, delta);
      double outer = centre.legOuter + dOuter;
      double fat = centre.legFat + dOuter;
      double muscle = centre.legMuscle + dot(gradMuscle, delta);
      if (std::abs(outer) < exactBandMm || std::abs(fat) < exactBandMm ||
          std::abs(muscle) < exactBandMm) {
        Distances sub = centre;
        anatomy.evaluate(p + delta, detail::gLeg, sub);
        outer = sub.legOuter;
        fat = sub.legFat;
        muscle = sub.legMuscle;
      }
      const uint16_t label = outer >= 0 ? kAir : muscle < 0 ? kMuscle : fat < 0 ? kFat : kSkin;
      ++counts[label];
    }
    // The four leg labels have one tissue each: sum their HU by count.
    sum = counts[kAir] * hu[detail::tAir] + counts[kSkin] * hu[detail::tSkin] +
          counts[kFat] * hu[detail::tFat] + counts[kMuscle] * hu[detail::tMuscle];
    return {sum / kSubSamples, detail::majorityLabel(counts.data())};
  }
  for (int n = 0; n < kSubSamples; ++n) {
    const Vec3& delta = off[n];
    Distances sub = centre;
    uint32_t groups = exact;
    if (leg) {
      const double dOuter = dot(gradOuter, delta);
      sub.legOuter = centre.legOuter + dOuter;
      sub.legFat = centre.legFat + dOuter;
      sub.legMuscle = centre.legMuscle + dot(gradMuscle, delta);
      if (std::abs(sub.legOuter) < exactBandMm || std::abs(sub.legFat) < exactBandMm ||
          std::abs(sub.legMuscle) < exactBandMm)
        groups |= detail::gLeg;
    }
    if (groups) anatomy.evaluate(p + delta, groups, sub);
    const Classified c = Anatomy::classify(sub);
    sum += hu[c.tissue];
    ++counts[c.label];
  }
  return {sum / kSubSamples, detail::majorityLabel(counts.data())};
}

int16_t toHu(double v) {
  return static_cast<int16_t>(std::clamp(std::round(v), -32768.0, 32767.0));
}

}  // namespace

Phantom makePhantom(const PhantomOptions& options, Progress& progress) {
  const Geometry g = phantomGeometry(options);
  checkFlexion(options.kneeFlexionDeg);
  if (!(std::isfinite(options.noiseSigmaHu) && options.noiseSigmaHu >= 0))
    throw Error("phantom: noiseSigmaHu must be finite and >= 0");
  if (!(options.psfSmoothingVoxels >= 0.0 && options.psfSmoothingVoxels <= 1.0))
    throw Error("phantom: psfSmoothingVoxels must be within [0, 1], got " +
                std::to_string(options.psfSmoothingVoxels));
  // CT (int16) and labels (uint16) together, before either is allocated.
  checkMemoryBudget(g.dims, sizeof(int16_t) + sizeof(uint16_t), "phantom CT + labels");

  Phantom out{VolumeI16(g, static_cast<int16_t>(-1000), kCtAirHu), LabelVolume(g)};
  out.labels = LabelVolume(std::move(out.labels.ids()), labelTable());

  const Anatomy anatomy(options.kneeFlexionDeg);
  const auto hu = tissueHu(options.hu);
  const Vec3 s = g.spacing;
  // Sub-samples lie within (1 + smoothing) / 2 voxel of the centre per axis (radius `cloud`);
  // a structure whose |distance| at the centre exceeds that cannot change across them (the
  // distances are ~1-Lipschitz; 15% + 0.05 mm is margin for the approximate ellipse ones).
  const double smoothing = options.psfSmoothingVoxels;
  const double cloud = 0.5 * (1.0 + smoothing) * norm(s);
  const double nearMm = 1.15 * cloud + 0.05;
  // Linearising the leg over the sub-sample cloud (radius r) errs by about r^2 / (2 R) with
  // R >= 40 mm: sub-samples closer than twice that (and 0.1 mm) to a surface are exact.
  const double exactBandMm = std::max(0.1, cloud * cloud / 40.0);
  const Dims d = g.dims;
  const double sigma = options.noiseSigmaHu;
  const uint64_t seed = options.seed;
  int16_t* ct = out.ct.data();
  uint16_t* lab = out.labels.ids().data();

  // The sub-sample patterns (subSampleOffsets), in mm.
  std::vector<std::array<Vec3, kSubSamples>> patternsMm(detail::kSubSamplePatterns);
  for (uint32_t n = 0; n < detail::kSubSamplePatterns; ++n) {
    patternsMm[n] = detail::subSamplePattern(n, smoothing);
    for (Vec3& o : patternsMm[n]) o = Vec3{o.x * s.x, o.y * s.y, o.z * s.z};
  }

  progress.begin("Generating knee phantom", static_cast<uint64_t>(d.z));
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      for (int64_t j = 0; j < d.y; ++j) {
        size_t idx = static_cast<size_t>((k * d.y + j) * d.x);
        uint64_t noisePair = ~uint64_t{0};
        detail::GaussianPair noise{0, 0};
        for (int64_t i = 0; i < d.x; ++i, ++idx) {
          const Vec3 p = g.origin + Vec3{i * s.x, j * s.y, k * s.z};
          Distances dist;
          const uint32_t near = anatomy.evaluateNear(p, nearMm, dist);
          const Classified c = Anatomy::classify(dist);
          double v = hu[c.tissue];
          uint16_t label = c.label;
          if (options.partialVolume && near != 0) {
            const auto& off = patternsMm[detail::subSamplePatternIndex(i, j, k)];
            const Mixed m = mixture(anatomy, p, dist, near, off, cloud, exactBandMm, hu);
            v = m.hu;
            label = m.label;
          }
          if (sigma > 0) {
            if ((idx >> 1) != noisePair) {
              noisePair = idx >> 1;
              noise = detail::gaussianPair(seed, noisePair);
            }
            v += sigma * ((idx & 1) ? noise.b : noise.a);
          }
          ct[idx] = toHu(v);
          lab[idx] = label;
        }
      }
      progress.advance(1);
    }
  });
  progress.end();
  return out;
}

PhantomPoint samplePhantom(const Vec3& pMm, const PhantomOptions& options) {
  checkFlexion(options.kneeFlexionDeg);
  const Anatomy anatomy(options.kneeFlexionDeg);
  Distances dist;
  anatomy.evaluate(pMm, detail::gAll, dist);
  const Classified c = Anatomy::classify(dist);
  Bone bone = boneOf(c.label);
  if (c.label == kCancellous) bone = dist.fibulaOuter < 0 ? Bone::kFibula : Bone::kPatella;
  return {c.label, tissueHu(options.hu)[c.tissue], bone};
}

Vec3 flexionAxisPointMm() { return {0.0, 0.0, detail::kAxisZ}; }

Vec3 flexCalfPoint(const Vec3& pMm, double flexionDeg) {
  return Anatomy(flexionDeg).fromCalf(pMm);
}

bool isBone(uint16_t id) {
  return id == kFemurCortex || id == kFemurMarrow || id == kTibiaCortex || id == kTibiaMarrow ||
         id == kFibula || id == kPatella || id == kCancellous;
}

bool isCorticalBone(uint16_t id) {
  return id == kFemurCortex || id == kTibiaCortex || id == kFibula || id == kPatella;
}

Bone boneOf(uint16_t id) {
  switch (id) {
    case kFemurCortex: case kFemurMarrow: return Bone::kFemur;
    case kTibiaCortex: case kTibiaMarrow: return Bone::kTibia;
    case kFibula: return Bone::kFibula;
    case kPatella: return Bone::kPatella;
    default: return Bone::kNone;  // incl. kCancellous: shared by two bones, see boneMap
  }
}

bool isSoftTissue(uint16_t id) {
  return id == kSkin || id == kFat || id == kMuscle || id == kCartilage;
}

}  // namespace vellum::phantom
