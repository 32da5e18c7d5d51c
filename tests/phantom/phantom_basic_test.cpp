// Options, geometry, label table, determinism and cancellation of the knee phantom.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "phantom_test_util.hpp"
#include "vellum/core/error.hpp"

namespace vellum::phantom {
namespace {

PhantomOptions small(int n = 32) {
  PhantomOptions o;
  o.dims = {n, n, n};
  return o;
}

TEST(PhantomOptions, RejectsBadDims) {
  for (Dims d : {Dims{15, 64, 64}, Dims{64, 1025, 64}, Dims{64, 64, 0}, Dims{-5, 64, 64}}) {
    PhantomOptions o;
    o.dims = d;
    EXPECT_THROW(makePhantom(o), Error) << d.str();
  }
}

TEST(PhantomOptions, RejectsBadSpacingFovNoiseAndFlexion) {
  auto o = small();
  o.spacing = {1, -1, 1};
  EXPECT_THROW(makePhantom(o), Error);
  o = small();
  o.fieldOfViewMm = {180, 0, 220};
  EXPECT_THROW(makePhantom(o), Error);
  o = small();
  o.noiseSigmaHu = std::nan("");
  EXPECT_THROW(makePhantom(o), Error);
  o = small();
  o.noiseSigmaHu = -1;
  EXPECT_THROW(makePhantom(o), Error);
  for (double f : {-1.0, 91.0, std::nan("")}) {
    o = small();
    o.kneeFlexionDeg = f;
    EXPECT_THROW(makePhantom(o), Error) << f;
    EXPECT_THROW(samplePhantom({0, 0, 0}, o), Error) << f;
  }
}

TEST(PhantomOptions, MemoryBudgetCheckedBeforeAllocating) {
  const char* old = std::getenv("VELLUM_MEMORY_LIMIT");
  const std::string saved = old ? old : "";
  // 128^3 needs 4 MiB for CT + 4 MiB for labels: each alone fits in 6 MiB, both do not.
  ::setenv("VELLUM_MEMORY_LIMIT", "6M", 1);
  PhantomOptions o;
  o.dims = {128, 128, 128};
  try {
    makePhantom(o);
    ADD_FAILURE() << "expected a memory budget error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("phantom"), std::string::npos) << e.what();
  }
  if (old) ::setenv("VELLUM_MEMORY_LIMIT", saved.c_str(), 1);
  else ::unsetenv("VELLUM_MEMORY_LIMIT");
}

TEST(PhantomGeometry, CentredWithFovSpacingAndIdentityDirection) {
  PhantomOptions o;
  o.dims = {90, 60, 110};
  const Phantom p = makePhantom(o);
  const Geometry& g = p.ct.geometry();
  EXPECT_EQ(g.dims, o.dims);
  EXPECT_DOUBLE_EQ(g.spacing.x, 2.0);
  EXPECT_DOUBLE_EQ(g.spacing.y, 3.0);
  EXPECT_DOUBLE_EQ(g.spacing.z, 2.0);
  EXPECT_NEAR(norm(g.center()), 0.0, 1e-9);
  EXPECT_EQ(g.direction, Mat3::identity());
  EXPECT_TRUE(p.labels.geometry().approxEqual(g));
  EXPECT_EQ(p.ct.background(), -1000.0);
  // Explicit spacing wins over the field of view.
  o.spacing = {1.5, 1.5, 2.5};
  const Phantom q = makePhantom(o);
  EXPECT_DOUBLE_EQ(q.ct.geometry().spacing.z, 2.5);
  EXPECT_NEAR(norm(q.ct.geometry().center()), 0.0, 1e-9);
}

TEST(PhantomLabels, TableNamesAndPredicates) {
  const Phantom& p = test::cached(32, 32, 32);
  const std::map<uint16_t, std::string> expected{
      {kSkin, "skin"},           {kFat, "subcutaneous fat"}, {kMuscle, "muscle"},
      {kFemurCortex, "femur cortex"}, {kFemurMarrow, "femur marrow"},
      {kTibiaCortex, "tibia cortex"}, {kTibiaMarrow, "tibia marrow"},
      {kFibula, "fibula"},       {kPatella, "patella"},      {kCartilage, "cartilage"},
      {kCancellous, "cancellous bone"}};
  EXPECT_EQ(p.labels.table().size(), expected.size());
  for (const auto& [id, name] : expected) {
    const auto l = p.labels.label(id);
    ASSERT_TRUE(l) << id;
    EXPECT_EQ(l->name, name);
  }
  int bones = 0, cortical = 0, soft = 0;
  for (uint16_t id = 0; id <= 13; ++id) {
    bones += isBone(id);
    cortical += isCorticalBone(id);
    soft += isSoftTissue(id);
    EXPECT_FALSE(isBone(id) && isSoftTissue(id)) << id;
    if (isCorticalBone(id)) {
      EXPECT_TRUE(isBone(id)) << id;
    }
    // Every id of one bone only maps to that bone; the shared core and non-bone ids to none.
    EXPECT_EQ(boneOf(id) != Bone::kNone, isBone(id) && id != kCancellous) << id;
  }
  EXPECT_EQ(bones, 7);
  EXPECT_EQ(cortical, 4);
  EXPECT_EQ(soft, 4);
  EXPECT_TRUE(isBone(kCancellous));
  EXPECT_FALSE(isCorticalBone(kCancellous) || isCorticalBone(kFemurMarrow) ||
               isCorticalBone(kTibiaMarrow));
  EXPECT_FALSE(isBone(kAir) || isSoftTissue(kAir));
  EXPECT_EQ(boneOf(kFemurCortex), Bone::kFemur);
  EXPECT_EQ(boneOf(kFemurMarrow), Bone::kFemur);
  EXPECT_EQ(boneOf(kTibiaCortex), Bone::kTibia);
  EXPECT_EQ(boneOf(kTibiaMarrow), Bone::kTibia);
  EXPECT_EQ(boneOf(kFibula), Bone::kFibula);
  EXPECT_EQ(boneOf(kPatella), Bone::kPatella);
}

TEST(PhantomBones, SamplePhantomNamesTheBoneOfEveryPoint) {
  // Cores of the fibula and the patella share kCancellous; the point query resolves them.
  const PhantomPoint fibulaCore = samplePhantom({-33, 20, -70});
  EXPECT_EQ(fibulaCore.label, kCancellous);
  EXPECT_EQ(fibulaCore.bone, Bone::kFibula);
  EXPECT_EQ(fibulaCore.hu, TissueHu{}.cancellous);
  const PhantomPoint fibulaShell = samplePhantom({-33 + 4.8, 20, -70});  // r 4.8 in 4..5.5
  EXPECT_EQ(fibulaShell.label, kFibula);
  EXPECT_EQ(fibulaShell.bone, Bone::kFibula);
  EXPECT_EQ(fibulaShell.hu, TissueHu{}.cortex);
  const PhantomPoint patellaCore = samplePhantom({0, -35, 34});
  EXPECT_EQ(patellaCore.label, kCancellous);
  EXPECT_EQ(patellaCore.bone, Bone::kPatella);
  EXPECT_EQ(samplePhantom({0, -35, 34 + 19.5}).label, kPatella);  // 0.5 mm under the top
  EXPECT_EQ(samplePhantom({0, 2, 70}).bone, Bone::kFemur);         // femoral shaft marrow
  EXPECT_EQ(samplePhantom({3, -6, -70}).bone, Bone::kTibia);       // tibial shaft marrow
  EXPECT_EQ(samplePhantom({0, 30, -70}).bone, Bone::kNone);        // calf muscle
}

TEST(PhantomBones, BoneMapResolvesEachCoreToTheShellAroundIt) {
  for (int n : {48, 128}) {
    const Phantom& p = test::cached(n, n, n);
    const VolumeU8 bones = boneMap(p.labels);
    ASSERT_TRUE(bones.geometry().approxEqual(p.labels.geometry()));
    const Geometry& g = p.labels.geometry();
    size_t cores = 0, wrong = 0, unresolved = 0;
    for (int64_t k = 0; k < g.dims.z; ++k)
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          const uint16_t id = p.labels(i, j, k);
          const Bone b = static_cast<Bone>(bones(i, j, k));
          if (id != kCancellous) {
            wrong += b != boneOf(id);
            continue;
          }
          ++cores;
          unresolved += b == Bone::kNone;
          // A core voxel lies inside one bone: the one the point truth names at its centre
          // (its centre is in that bone even where a thin shell won the majority elsewhere).
          const Bone atCentre =
              samplePhantom(g.indexToPhysical(Vec3{double(i), double(j), double(k)})).bone;
          wrong += b != atCentre;
        }
    EXPECT_GT(cores, n == 48 ? 20u : 1000u) << n;
    EXPECT_EQ(unresolved, 0u) << n;
    EXPECT_EQ(wrong, 0u) << n;
  }
}

TEST(PhantomBones, BoneMapLeavesAnOrphanCoreUnassigned) {
  // A hand-made label volume: a core touching the fibula's shell, another touching nothing.
  Geometry g;
  g.dims = {8, 4, 4};
  LabelVolume l(g);
  l(1, 1, 1) = kFibula;
  l(2, 1, 1) = kCancellous;
  l(2, 2, 2) = kCancellous;  // 26-neighbour of (2,1,1): same component
  l(6, 2, 2) = kCancellous;  // alone
  l(5, 0, 0) = kMuscle;
  const VolumeU8 b = boneMap(l);
  EXPECT_EQ(b(1, 1, 1), uint8_t(Bone::kFibula));
  EXPECT_EQ(b(2, 1, 1), uint8_t(Bone::kFibula));
  EXPECT_EQ(b(2, 2, 2), uint8_t(Bone::kFibula));
  EXPECT_EQ(b(6, 2, 2), uint8_t(Bone::kNone));
  EXPECT_EQ(b(5, 0, 0), uint8_t(Bone::kNone));
  EXPECT_EQ(b(0, 0, 0), uint8_t(Bone::kNone));
}

TEST(PhantomDeterminism, SameSeedSameBytesOtherSeedOtherNoise) {
  auto o = small(48);
  const Phantom a = makePhantom(o), b = makePhantom(o);
  ASSERT_EQ(a.ct.size(), b.ct.size());
  EXPECT_EQ(0, std::memcmp(a.ct.data(), b.ct.data(), a.ct.size() * sizeof(int16_t)));
  EXPECT_EQ(a.labels.ids().voxels(), b.labels.ids().voxels());
  o.seed = 2;
  const Phantom c = makePhantom(o);
  EXPECT_EQ(a.labels.ids().voxels(), c.labels.ids().voxels());  // anatomy does not change
  size_t differ = 0;
  for (size_t i = 0; i < a.ct.size(); ++i) differ += a.ct.data()[i] != c.ct.data()[i];
  EXPECT_GT(differ, a.ct.size() / 2);  // sigma 15: almost every voxel's noise differs
}

TEST(PhantomDeterminism, IndependentOfThreadCount) {
  auto o = small(40);
  o.kneeFlexionDeg = 20;
  Phantom serial, wide;
  tbb::task_arena one(1), many(8);
  one.execute([&] { serial = makePhantom(o); });
  many.execute([&] { wide = makePhantom(o); });
  EXPECT_EQ(serial.ct.voxels(), wide.ct.voxels());
  EXPECT_EQ(serial.labels.ids().voxels(), wide.labels.ids().voxels());
}

TEST(PhantomProgress, ReportsAndCancels) {
  double last = -1;
  int calls = 0;
  Progress progress([&](const std::string&, double f) {
    EXPECT_GE(f, last);
    last = f;
    ++calls;
  });
  makePhantom(small(24), progress);
  EXPECT_DOUBLE_EQ(last, 1.0);
  EXPECT_GT(calls, 2);

  Progress cancelled;
  cancelled.cancel();
  EXPECT_THROW(makePhantom(small(24), cancelled), Cancelled);

  // Cancelled mid-way from the callback (runs on a worker thread).
  Progress* self = nullptr;
  Progress midway([&](const std::string&, double f) {
    if (f > 0.3 && self) self->cancel();
  });
  self = &midway;
  EXPECT_THROW(makePhantom(small(64), midway), Cancelled);
}

TEST(PhantomSubSamples, StratifiedDeterministicAndWithinThePsf) {
  for (const double h : {0.0, kDefaultPsfSmoothing, 1.0}) {
    const auto a = subSampleOffsets(3, -7, 11, h), b = subSampleOffsets(3, -7, 11, h);
    const auto other = subSampleOffsets(4, -7, 11, h);
    size_t differ = 0;
    for (int n = 0; n < kSubSamples; ++n) {
      EXPECT_EQ(a[n].x, b[n].x);  // a pure function of the voxel index
      differ += a[n].x != other[n].x;
    }
    EXPECT_GT(differ, 32u) << h;  // ... that differs between voxels
    // Per axis: every coordinate within the PSF's support, and (box case) sample a + 4b + 16c
    // in stratum a along x; all 64 samples in distinct 1/64 slices of the box quantiles.
    const double reach = 0.5 * (1 + h);
    for (int axis = 0; axis < 3; ++axis) {
      std::array<int, kSubSamples> slices{};
      for (int n = 0; n < kSubSamples; ++n) {
        const double v = a[n][axis];
        EXPECT_LT(std::abs(v), reach) << h;
        if (h == 0.0) {
          const int stratum = (n >> (2 * axis)) & 3;
          EXPECT_EQ(int(std::floor((v + 0.5) * 4)), stratum);
          ++slices[std::clamp(int(std::floor((v + 0.5) * 64)), 0, 63)];
        }
      }
      if (h == 0.0) {
        for (int s : slices) EXPECT_EQ(s, 1);
      }
    }
    // The mean offset is ~0 (the PSF is centred) and its variance is that of the trapezoid:
    // (1 + h^2) / 12 per axis.
    for (int axis = 0; axis < 3; ++axis) {
      double m = 0, v = 0;
      for (const Vec3& o : a) m += o[axis];
      m /= kSubSamples;
      for (const Vec3& o : a) v += (o[axis] - m) * (o[axis] - m);
      v /= kSubSamples;
      EXPECT_NEAR(m, 0.0, 0.01) << h;
      EXPECT_NEAR(v, (1 + h * h) / 12.0, 0.01) << h;
    }
  }
}

TEST(PhantomSubSamples, BadSmoothingIsRejected) {
  auto o = small(32);
  o.psfSmoothingVoxels = 1.5;
  EXPECT_THROW(makePhantom(o), Error);
  o.psfSmoothingVoxels = std::nan("");
  EXPECT_THROW(makePhantom(o), Error);
}

}  // namespace
}  // namespace vellum::phantom
