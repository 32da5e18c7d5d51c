// The phantom's ground truth: exact, connected, separated bones; physical volumes that do not
// depend on the grid; flexion as a rigid rotation of the calf; a thin condylar cortex.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "phantom_test_util.hpp"

namespace vellum::phantom {
namespace {

using test::cached;
using test::kBones;

constexpr uint16_t kMaxLabel = kCancellous;

TEST(PhantomTruth, WithoutPartialVolumeLabelsAreTheAnatomyAtVoxelCentres) {
  for (double flex : {0.0, 30.0}) {
    const Phantom& p = cached(64, 64, 64, flex, 15.0, false);
    PhantomOptions o;
    o.kneeFlexionDeg = flex;
    const Geometry& g = p.labels.geometry();
    size_t mismatches = 0;
    for (int64_t k = 0; k < g.dims.z; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          const Vec3 centre = g.indexToPhysical(Vec3{double(i), double(j), double(k)});
          mismatches += p.labels(i, j, k) != samplePhantom(centre, o).label;
        }
    EXPECT_EQ(mismatches, 0u) << "flexion " << flex;
  }
}

// The tie-break order of the majority vote, restated: cortex > marrow / core > cartilage >
// muscle > fat > skin > air (bones never share a voxel).
int tieRank(uint16_t id) {
  static const std::vector<uint16_t> order{kAir,        kSkin,        kFat,        kMuscle,
                                           kCartilage,  kCancellous,  kTibiaMarrow, kFemurMarrow,
                                           kPatella,    kFibula,      kTibiaCortex, kFemurCortex};
  return int(std::find(order.begin(), order.end(), id) - order.begin());
}

// Brute force: the label most of the voxel's sub-sample points (subSampleOffsets) have.
uint16_t majorityAt(const Geometry& g, int64_t i, int64_t j, int64_t k, const PhantomOptions& o) {
  std::array<int, kMaxLabel + 1> count{};
  for (const Vec3& d : subSampleOffsets(i, j, k))
    ++count[samplePhantom(g.indexToPhysical(Vec3{i + d.x, j + d.y, k + d.z}), o).label];
  uint16_t best = 0;
  for (uint16_t l = 1; l <= kMaxLabel; ++l)
    if (count[l] > count[best] || (count[l] == count[best] && tieRank(l) > tieRank(best)))
      best = l;
  return best;
}

TEST(PhantomTruth, LabelsAreTheMajorityStructureOfEachVoxel) {
  // Away from boundaries (all 26 neighbours' centres in the same structure) the label is the
  // structure at the centre; elsewhere it is the brute-force majority of the sub-samples.
  for (double flex : {0.0, 30.0}) {
    const Phantom& p = cached(64, 64, 64, flex);
    PhantomOptions o;
    o.kneeFlexionDeg = flex;
    const Geometry& g = p.labels.geometry();
    VolumeU16 centre(g);
    for (int64_t k = 0; k < g.dims.z; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i)
          centre(i, j, k) =
              samplePhantom(g.indexToPhysical(Vec3{double(i), double(j), double(k)}), o).label;
    size_t interior = 0, boundary = 0, notCentre = 0, mismatches = 0;
    for (int64_t k = 0; k < g.dims.z; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          bool uniform = true;
          for (int c = -1; c <= 1 && uniform; ++c)
            for (int b = -1; b <= 1 && uniform; ++b)
              for (int a = -1; a <= 1 && uniform; ++a)
                uniform = !g.contains(i + a, j + b, k + c) ||
                          centre(i + a, j + b, k + c) == centre(i, j, k);
          uint16_t expected = centre(i, j, k);
          if (uniform) {
            ++interior;
          } else {
            ++boundary;
            expected = majorityAt(g, i, j, k, o);
            notCentre += expected != centre(i, j, k);
          }
          mismatches += p.labels(i, j, k) != expected;
        }
    EXPECT_EQ(mismatches, 0u) << "flexion " << flex;
    EXPECT_GT(boundary, 20000u);  // the test does exercise the majority
    EXPECT_GT(notCentre, 500u);   // ... where it differs from the centre's structure
    EXPECT_GT(interior, 150000u);
  }
}

TEST(PhantomTruth, MajorityAndCentreTruthDifferOnlyAtMixedVoxels) {
  // With partial volume the labels are majorities, without they are the centres' structures:
  // they differ only where the voxel mixes tissues, and both estimate the same volumes.
  const Phantom& pv = cached(128, 128, 128, 0.0, 0.0, true);
  const Phantom& crisp = cached(128, 128, 128, 0.0, 0.0, false);
  const auto a = pv.labels.histogram(), b = crisp.labels.histogram();
  ASSERT_EQ(a.size(), b.size());
  size_t changed = 0;
  for (size_t v = 0; v < pv.ct.size(); ++v) {
    const uint16_t l = pv.labels.ids().data()[v], m = crisp.labels.ids().data()[v];
    if (l == m) continue;
    ++changed;
    // Only mixed voxels change: the noise-free CT there is not one tissue's nominal HU.
    EXPECT_NE(pv.ct.data()[v], crisp.ct.data()[v]) << v;
  }
  EXPECT_GT(changed, 1000u);
  EXPECT_LT(changed, pv.ct.size() / 50);
  for (uint16_t id = kSkin; id <= kMaxLabel; ++id)
    EXPECT_NEAR(double(a[id]), double(b[id]), 0.10 * double(b[id]) + 50) << id;
}

TEST(PhantomTruth, EveryLabelPresentAndBonesInsideMuscle) {
  const Phantom& p = cached(128, 128, 128);
  const auto h = p.labels.histogram();
  ASSERT_EQ(h.size(), kMaxLabel + 1u);
  for (uint16_t id = 0; id <= kMaxLabel; ++id) EXPECT_GT(h[id], 100u) << id;
  // Bone never touches air, skin or fat (6-neighbours): it lies inside the muscle. Except at
  // the fibula's head, where only ~1-2 mm of muscle separates it from the posterolateral fat
  // (under the PSF's reach of ~1.3 voxels): a few face contacts there are the truth.
  const Geometry& g = p.labels.geometry();
  size_t bad = 0, fibulaHead = 0;
  for (int64_t k = 1; k + 1 < g.dims.z; ++k)
    for (int64_t j = 1; j + 1 < g.dims.y; ++j)
      for (int64_t i = 1; i + 1 < g.dims.x; ++i) {
        const uint16_t id = p.labels(i, j, k);
        if (!isBone(id)) continue;
        for (auto [a, b, c] : {std::array<int, 3>{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0},
                               {0, 0, 1}, {0, 0, -1}}) {
          const uint16_t n = p.labels(i + a, j + b, k + c);
          if (n != kAir && n != kSkin && n != kFat) continue;
          const Vec3 q = g.indexToPhysical(Vec3{double(i), double(j), double(k)});
          const bool atHead = id == kFibula && q.z > -56 && q.z < -44;  // head: z = -50 +- 7.5
          (atHead ? fibulaHead : bad) += 1;
        }
      }
  EXPECT_EQ(bad, 0u);
  EXPECT_LE(fibulaHead, 6u);
}

// Each bone (cortex + marrow / core, from boneMap) is one 26-connected component, and no
// voxel of one bone is a 26-neighbour of another bone's voxel: per-bone rigidity can rely on
// connected components. The cancellous cores each lie inside one shell.
void expectSeparateConnectedBones(const Phantom& p, const std::string& what) {
  const VolumeU8 bones = boneMap(p.labels);
  const uint8_t* bm = bones.data();
  const Geometry& g = p.labels.geometry();
  for (const Bone bone : kBones)
    EXPECT_EQ(test::countComponents(g, [&](size_t v) { return bm[v] == uint8_t(bone); }), 1)
        << what << " bone " << int(bone);
  // The union of all bone ids has exactly four components: the bones' own.
  EXPECT_EQ(test::countComponents(p.labels, isBone), 4) << what;
  size_t touching = 0, orphanCore = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const int b = bones(i, j, k);
        orphanCore += p.labels(i, j, k) == kCancellous && b == 0;
        if (b == 0) continue;
        for (int c = -1; c <= 1; ++c)
          for (int bb = -1; bb <= 1; ++bb)
            for (int a = -1; a <= 1; ++a)
              if (g.contains(i + a, j + bb, k + c)) {
                const int o = bones(i + a, j + bb, k + c);
                touching += o != 0 && o != b;
              }
      }
  EXPECT_EQ(touching, 0u) << what;
  EXPECT_EQ(orphanCore, 0u) << what;
}

TEST(PhantomTruth, BonesAreSeparateConnectedComponents) {
  expectSeparateConnectedBones(cached(128, 128, 128), "128^3");
  expectSeparateConnectedBones(cached(64, 64, 64), "64^3");
  expectSeparateConnectedBones(cached(128, 128, 128, 30.0), "128^3 flexed 30");
  expectSeparateConnectedBones(cached(96, 96, 96, 90.0), "96^3 flexed 90");
  expectSeparateConnectedBones(cached(128, 128, 64, 0.0, 15.0, true, {1.4, 1.4, 3.4}),
                               "anisotropic");
}

// Monte-Carlo volume (mL) of `label` from the anatomy itself, sampled uniformly in the box
// [lo, hi] (mm); standard error in `se`.
double monteCarloVolumeMl(uint16_t label, Vec3 lo, Vec3 hi, int n, double* se) {
  std::mt19937_64 rng(label * 7919u + 17u);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PhantomOptions o;
  int hits = 0;
  for (int s = 0; s < n; ++s) {
    const Vec3 q{lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y),
                 lo.z + u(rng) * (hi.z - lo.z)};
    hits += samplePhantom(q, o).label == label;
  }
  const double box = (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z) / 1000.0;
  const double f = double(hits) / n;
  *se = box * std::sqrt(f * (1 - f) / n);
  return box * f;
}

// The physical bounding box of `label` in a label volume, grown by `margin` mm.
void labelBox(const LabelVolume& l, uint16_t label, double margin, Vec3& lo, Vec3& hi) {
  lo = {1e9, 1e9, 1e9};
  hi = {-1e9, -1e9, -1e9};
  const Geometry& g = l.geometry();
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        if (l(i, j, k) == label) {
          const Vec3 p = g.indexToPhysical(Vec3{double(i), double(j), double(k)});
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p[a] - margin);
            hi[a] = std::max(hi[a], p[a] + margin);
          }
        }
}

double labelVolumeMl(const LabelVolume& l, uint16_t label) {
  const auto h = l.histogram();
  const Vec3 s = l.geometry().spacing;
  return label < h.size() ? double(h[label]) * s.x * s.y * s.z / 1000.0 : 0.0;
}

TEST(PhantomTruth, VolumesMatchTheAnatomyAndDoNotDependOnTheGrid) {
  // Centre labels (no partial volume) sample the anatomy without bias; majority labels too
  // for structures thicker than a voxel, but a shell about one voxel thick (cortex 1.2-1.5 mm,
  // skin and cartilage 2 mm) wins the vote in voxels where it is only the largest of three
  // parts, or loses it where it is the smallest: thin shells gain or lose volume with voxel
  // size. 2.8-3.4 mm voxels also alias a 1.5 mm shell (the patella's, centre-sampled: -15%).
  // The majority is taken under the smooth PSF (~1.3 voxels of reach), which favours the
  // voxel's centre: at 2.8 mm a 1.2-1.5 mm cortex rarely wins it (measured: patella -40%,
  // fibula -17%, femur cortex -16%; 128^3 and the 1.4 x 1.4 x 3.4 mm grid within 5%).
  // Tolerances: 1.4 mm voxels: centre 4%, majority 10%; 2.8-3.4 mm voxels: 25%, and 50% for
  // the cortical shells' majority on the 2.8 mm grid.
  const Vec3 aniso{1.4, 1.4, 3.4};
  for (const bool pv : {false, true}) {
    const Phantom& fine = cached(128, 128, 128, 0.0, 15.0, pv);
    const Phantom& coarse = cached(64, 64, 64, 0.0, 15.0, pv);
    const Phantom& anis = cached(128, 128, 64, 0.0, 15.0, pv, aniso);
    const double tolFine = pv ? 0.10 : 0.04, tolCoarse = 0.25;
    for (uint16_t id = kSkin; id <= kMaxLabel; ++id) {
      if (id == kMuscle) continue;  // fills the FOV-clipped leg: checked through the others
      Vec3 lo, hi;
      labelBox(fine.labels, id, 4.0, lo, hi);
      double se = 0;
      const double truth = monteCarloVolumeMl(id, lo, hi, 400000, &se);
      const double v128 = labelVolumeMl(fine.labels, id), v64 = labelVolumeMl(coarse.labels, id),
                   vAniso = labelVolumeMl(anis.labels, id);
      const std::string line = fine.labels.label(id)->name + (pv ? " (majority)" : " (centre)") +
                               ": truth " + std::to_string(truth) + " mL, 128^3 " +
                               std::to_string(v128) + ", 64^3 " + std::to_string(v64) +
                               ", aniso " + std::to_string(vAniso);
      std::printf("  %s\n", line.c_str());
      SCOPED_TRACE(line);
      EXPECT_NEAR(v128, truth, tolFine * truth + 4 * se);
      const double tol64 = pv && isCorticalBone(id) ? 0.5 : tolCoarse;
      EXPECT_NEAR(v64, truth, tol64 * truth + 4 * se);
      EXPECT_NEAR(vAniso, truth, tolCoarse * truth + 4 * se);
    }
  }
}

TEST(PhantomTruth, AnisotropicGridShowsTheSameAnatomyInMm) {
  const VolumeU8 iso = boneMap(cached(128, 128, 128).labels);
  const VolumeU8 aniso = boneMap(cached(128, 128, 64, 0.0, 15.0, true, {1.4, 1.4, 3.4}).labels);
  for (const Bone bone : kBones) {
    const Vec3 a = test::boneCentroid(iso, bone), b = test::boneCentroid(aniso, bone);
    EXPECT_LT(norm(a - b), 1.0) << "bone " << int(bone);
  }
}

TEST(PhantomFlexion, TibiaRotatesRigidlyAboutTheAxisFemurStays) {
  const VolumeU8 straight = boneMap(cached(128, 128, 128).labels);
  const VolumeU8 flexed = boneMap(cached(128, 128, 128, 30.0).labels);
  for (const Bone bone : kBones) {
    uint64_t n0 = 0, n1 = 0;
    const Vec3 c0 = test::boneCentroid(straight, bone, &n0);
    const Vec3 c1 = test::boneCentroid(flexed, bone, &n1);
    const bool calf = bone == Bone::kTibia || bone == Bone::kFibula;
    const Vec3 expected = calf ? flexCalfPoint(c0, 30.0) : c0;
    EXPECT_LT(norm(c1 - expected), 1.0) << "bone " << int(bone);
    EXPECT_NEAR(double(n1), double(n0), 0.02 * n0) << "bone " << int(bone);  // rigid: same volume
    if (calf) {
      EXPECT_GT(norm(c1 - c0), 20.0) << "the calf bones moved";
    }
  }
  // The rotation convention: the foot goes posterior (+y) and the axis point is fixed.
  const Vec3 a = flexionAxisPointMm();
  EXPECT_LT(norm(flexCalfPoint(a, 45.0) - a), 1e-12);
  const Vec3 foot = flexCalfPoint(a + Vec3{0, 0, -100}, 90.0);
  EXPECT_NEAR(foot.y, 100.0, 1e-9);
  EXPECT_NEAR(foot.z, a.z, 1e-9);
}

TEST(PhantomFlexion, CalfSoftTissueFollowsTheTibia) {
  // A point in the calf muscle at flexion 0 is still muscle once moved by the flexion, and a
  // point of thigh muscle stays where it is.
  PhantomOptions straight, flexed;
  flexed.kneeFlexionDeg = 40;
  const Vec3 calfMuscle{20, 25, -60}, thighMuscle{-30, 20, 70};
  ASSERT_EQ(samplePhantom(calfMuscle, straight).label, kMuscle);
  EXPECT_EQ(samplePhantom(flexCalfPoint(calfMuscle, 40), flexed).label, kMuscle);
  EXPECT_EQ(samplePhantom(thighMuscle, flexed).label, kMuscle);
  // Skin surface along a calf ray moves with the calf.
  for (double r = 40; r < 70; r += 0.5) {
    const Vec3 q{0, r, -60};
    EXPECT_EQ(samplePhantom(q, straight).label, samplePhantom(flexCalfPoint(q, 40), flexed).label)
        << r;
  }
}

// Extent (mm) of `label` along the segment from `a` to `b`, sampled every 1 um.
double extentAlong(const Vec3& a, const Vec3& b, uint16_t label) {
  const int n = static_cast<int>(norm(b - a) / 0.001);
  int hits = 0;
  for (int s = 0; s <= n; ++s) hits += samplePhantom(a + (b - a) * (double(s) / n)).label == label;
  return hits * norm(b - a) / n;
}

TEST(PhantomTruth, JointLayersAndThinCondylarCortex) {
  // Vertical ray through the medial condyle's lowest point (x = 19 mm, y = 0).
  const double cortex = extentAlong({19, 0, 10}, {19, 0, 2}, kFemurCortex);
  EXPECT_GE(cortex, 1.0);
  EXPECT_LE(cortex, 1.5);
  EXPECT_NEAR(cortex, 1.2, 0.02);
  // Shaft cortex is thick: 4 mm along a horizontal ray through the femoral shaft.
  EXPECT_NEAR(extentAlong({-20, 2, 80}, {-5, 2, 80}, kFemurCortex), 4.0, 0.05);
  // From the tibia up into the femur: tibia cortex, cartilage, joint space, cartilage, femur.
  const std::vector<uint16_t> expected{kTibiaMarrow, kTibiaCortex, kCartilage, kMuscle,
                                       kCartilage,   kFemurCortex, kFemurMarrow};
  std::vector<uint16_t> seen;
  for (double z = -8; z <= 8; z += 0.01) {
    const uint16_t l = samplePhantom({19, 0, z}).label;
    if (seen.empty() || seen.back() != l) seen.push_back(l);
  }
  EXPECT_EQ(seen, expected);
  // Bone-to-bone gap of the joint: 5 mm.
  EXPECT_NEAR(extentAlong({19, 0, -2.6}, {19, 0, 2.6}, kCartilage) +
                  extentAlong({19, 0, -2.6}, {19, 0, 2.6}, kMuscle),
              5.0, 0.01);
}

TEST(PhantomTruth, FibulaIsLateralPosteriorPatellaAnterior) {
  const VolumeU8 bones = boneMap(cached(128, 128, 128).labels);
  const auto fibula = test::boneCentroid(bones, Bone::kFibula);
  const auto tibia = test::boneCentroid(bones, Bone::kTibia);
  const auto patella = test::boneCentroid(bones, Bone::kPatella);
  EXPECT_LT(fibula.x, tibia.x - 20);  // right knee: lateral is -x (patient right)
  EXPECT_GT(fibula.y, tibia.y + 10);  // posterior is +y
  EXPECT_LT(patella.y, -25);          // anterior
  EXPECT_GT(patella.z, 10);           // above the joint line
}

}  // namespace
}  // namespace vellum::phantom
