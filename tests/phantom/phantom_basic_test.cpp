// Options, geometry, label table, determinism and cancellation of the knee phantom.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

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
      {kFibula, "fibula"},       {kPatella, "patella"},      {kCartilage, "cartilage"}};
  EXPECT_EQ(p.labels.table().size(), expected.size());
  for (const auto& [id, name] : expected) {
    const auto l = p.labels.label(id);
    ASSERT_TRUE(l) << id;
    EXPECT_EQ(l->name, name);
  }
  int bones = 0, cortical = 0, soft = 0;
  for (uint16_t id = 0; id <= 12; ++id) {
    bones += isBone(id);
    cortical += isCorticalBone(id);
    soft += isSoftTissue(id);
    EXPECT_FALSE(isBone(id) && isSoftTissue(id)) << id;
    if (isCorticalBone(id)) {
      EXPECT_TRUE(isBone(id)) << id;
    }
  }
  EXPECT_EQ(bones, 6);
  EXPECT_EQ(cortical, 4);
  EXPECT_EQ(soft, 4);
  EXPECT_FALSE(isBone(kAir) || isSoftTissue(kAir));
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

}  // namespace
}  // namespace vellum::phantom
