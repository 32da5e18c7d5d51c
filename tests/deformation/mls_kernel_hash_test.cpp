// The MLS kernel's results, bit for bit: hashes of control volumes for every solve path
// (single-precision grid with its double-precision redo, double precision, similarity, rigid,
// density-aware weights). Refactoring the register-blocked solves must not change one bit.
// The hashes were recorded on x86-64-v3 (AVX2 + FMA, the kernel's fast clone); other CPUs run
// the default clone, whose rounding may differ, so the test skips there.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>

#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

uint64_t fnv1a(const std::vector<float>& values) {
  uint64_t h = 1469598103934665603ull;
  const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
  for (size_t b = 0; b < values.size() * sizeof(float); ++b) h = (h ^ bytes[b]) * 1099511628211ull;
  return h;
}

uint64_t controlVolumeHash(void (*configure)(DeformParams&)) {
  static const phantom::Phantom ph = [] {
    phantom::PhantomOptions o;
    o.dims = {40, 36, 44};  // rows that are not a multiple of 4 or 8 lanes: the tails run too
    return phantom::makePhantom(o);
  }();
  DeformParams p;
  p.controlScale = 2;
  configure(p);
  Deformer d(AnyVolume(ph.ct), p);
  d.setPoints(kneeBendTrack(ph.ct.geometry(), 25.0, 2.0, phantom::flexionAxisPointMm()).keyframes[1].points);
  return fnv1a(d.update().sourceMm);
}

bool fastCloneRuns() { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }

}  // namespace

TEST(MlsKernelBits, ControlVolumesHashAsRecorded) {
  if (!fastCloneRuns()) GTEST_SKIP() << "hashes recorded on AVX2+FMA; this CPU runs the default clone";
#ifndef __OPTIMIZE__
  // Unoptimised builds (the Debug sanitizer suite) do not fuse multiply-adds as -O2 does, so
  // their last bits differ: the hashes hold for optimised builds only.
  GTEST_SKIP() << "hashes recorded in an optimised build";
#endif
  struct Case {
    const char* name;
    void (*configure)(DeformParams&);
    uint64_t hash;
  };
  const Case cases[] = {
      {"affine, single-precision grid", [](DeformParams&) {}, 18227582993056521050ull},
      {"affine, double precision", [](DeformParams& p) { p.singlePrecisionGrid = false; }, 11951969292903749987ull},
      {"similarity", [](DeformParams& p) { p.mls.method = MlsMethod::Similarity; }, 15120983296234146190ull},
      {"rigid", [](DeformParams& p) { p.mls.method = MlsMethod::Rigid; }, 3868449838903497586ull},
      {"affine, density-aware", [](DeformParams& p) { p.density.enabled = true; }, 15357901081256792686ull},
      {"affine, power 4", [](DeformParams& p) { p.mls.power = 4; }, 8570251453465753154ull},
  };
  for (const Case& c : cases) EXPECT_EQ(controlVolumeHash(c.configure), c.hash) << c.name;
}
