// The cinematic path tracer on GL (VolumeRenderer::render with Quality::Cinematic) against its
// CPU reference, statistically: both are Monte Carlo estimates, so their image means must agree
// within the Monte Carlo error measured from two GL seeds. Plus determinism and convergence.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "analytic_volumes.hpp"
#include "vellum/core/error.hpp"
#include "vellum/render/path_tracer.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::render {
namespace {

GlContext& ptGl() {
  static std::unique_ptr<GlContext> context = GlContext::createHeadless();
  return *context;
}

RenderSettings cinematic(Preset p, int samples, int seed) {
  RenderSettings s;
  s.preset = p;
  s.width = s.height = 32;
  s.camera.azimuthDeg = 40;
  s.quality = Quality::Cinematic;
  s.cinematic.samples = samples;
  s.cinematic.seed = seed;
  s.cinematic.denoise = 0;
  return s;
}

std::vector<double> channels(const RgbaImage& img) {
  std::vector<double> v;
  for (size_t i = 0; i < img.pixels.size(); ++i)
    if (i % 4 != 3) v.push_back(img.pixels[i]);
  return v;
}
double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s / double(v.size());
}

/// |mean(cpu) - mean(gl)| against the standard error of an image mean, from the per-value
/// differences of two independent GL renders (seeds 1 and 2).
void expectSameMean(const RgbaImage& gl1, const RgbaImage& gl2, const RgbaImage& cpu, const std::string& what) {
  const std::vector<double> a = channels(gl1), b = channels(gl2), c = channels(cpu);
  double var = 0;
  for (size_t i = 0; i < a.size(); ++i) var += (a[i] - b[i]) * (a[i] - b[i]);
  var /= 2.0 * double(a.size());  // variance of one render's value
  // Neighbouring values are correlated (channels of a pixel); count pixels, not values.
  const double se = std::sqrt(var / (double(a.size()) / 3.0));
  const double glMean = 0.5 * (mean(a) + mean(b)), diff = mean(c) - glMean;
  std::cout << "[ mc ] " << what << ": GL mean " << glMean << ", CPU " << mean(c) << ", standard error " << se << "\n";
  EXPECT_GT(mean(a), 4.0) << what << ": not an empty picture";
  EXPECT_LT(std::abs(diff), 4.0 * se * std::sqrt(1.5) + 0.05) << what;
}

TEST(PathTracerGl, MatchesTheCpuReferenceStatistically) {
  const VolumeI16 v = test::makeAnalyticVolume(32);
  VolumeRenderer r(ptGl());
  r.setVolume(v);
  for (Preset p : {Preset::SoftTissueBone, Preset::Bone}) {
    RenderSettings s = cinematic(p, 16, 1);
    s.cinematic.bounces = p == Preset::Bone ? 1 : 2;  // single and multiple scattering
    const RgbaImage gl1 = r.render(s);
    EXPECT_EQ(r.lastSamples(), 16);
    s.cinematic.seed = 2;
    const RgbaImage gl2 = r.render(s);
    s.cinematic.seed = 3;
    expectSameMean(gl1, gl2, renderPathTracedCpu(v, s), presetName(p));
  }
}

TEST(PathTracerGl, DeformedMatchesTheCpuReferenceStatistically) {
  // The twist map: GL bounds extinction per map cell, the CPU with one majorant; both sample the
  // source through the backward map (shadow rays included).
  const VolumeI16 v = test::makeAnalyticVolume(32);
  const BackwardMap map = test::makeTwistMap(v.geometry(), 12, false);
  VolumeRenderer r(ptGl());
  r.setVolume(v);
  r.setBackwardMap(&map);
  RenderSettings s = cinematic(Preset::SoftTissueBone, 8, 1);  // the CPU map lookups are slow
  s.camera.zoom = 2;  // the map's grid box is the cube around the volume's bounding sphere
  const RgbaImage gl1 = r.render(s);
  s.cinematic.seed = 2;
  const RgbaImage gl2 = r.render(s);
  s.cinematic.seed = 3;
  expectSameMean(gl1, gl2, renderPathTracedCpu(v, s, &map), "twisted soft tissue");
}

TEST(PathTracerGl, DeterministicForAFixedSeed) {
  const VolumeI16 v = test::makeAnalyticVolume(32);
  VolumeRenderer r(ptGl());
  r.setVolume(v);
  RenderSettings s = cinematic(Preset::SoftTissueBone, 4, 7);
  s.cinematic.denoise = 0.5;
  const RgbaImage a = r.render(s);
  EXPECT_EQ(a.pixels, r.render(s).pixels) << "bit-identical twice";
  s.cinematic.seed = 8;
  EXPECT_NE(a.pixels, r.render(s).pixels);
}

TEST(PathTracerGl, ProgressiveBatchesEqualOneRender) {
  // The studio's refinement at rest: N batches of one sample resolve to render()'s picture with
  // N samples, bit for bit, even with a one-shot render of another view in between.
  const VolumeI16 v = test::makeAnalyticVolume(32);
  VolumeRenderer r(ptGl());
  r.setVolume(v);
  RenderSettings s = cinematic(Preset::SoftTissueBone, 5, 3);
  s.cinematic.denoise = 0.5;
  s.cinematic.bounces = 2;
  EXPECT_THROW(r.addCinematicSamples(1), Error);
  r.beginCinematic(s);
  EXPECT_EQ(r.cinematicSamples(), 0);
  EXPECT_EQ(r.addCinematicSamples(1), 1);
  const RgbaImage one = r.resolveCinematic();
  RenderSettings other = cinematic(Preset::Bone, 2, 9);
  other.camera.azimuthDeg = -70;
  r.render(other);
  for (int i = 1; i < 5; ++i) EXPECT_EQ(r.addCinematicSamples(1), i + 1);
  const RgbaImage progressive = r.resolveCinematic();
  const RgbaImage once = r.render(s);
  EXPECT_EQ(r.lastSamples(), 5);
  EXPECT_EQ(progressive.pixels, once.pixels) << "5 x 1 sample == 5 samples";
  EXPECT_NE(one.pixels, once.pixels) << "the running picture changes as samples add up";
  s.cinematic.samples = 1;
  EXPECT_EQ(one.pixels, r.render(s).pixels) << "after one batch: render() with 1 sample";
}

TEST(PathTracerGl, ErrorFallsWithSamples) {
  const VolumeI16 v = test::makeAnalyticVolume(32);
  VolumeRenderer r(ptGl());
  r.setVolume(v);
  const RgbaImage reference = r.render(cinematic(Preset::SoftTissueBone, 256, 100));
  auto rms = [&](int samples) {
    const RgbaImage img = r.render(cinematic(Preset::SoftTissueBone, samples, 1));
    double e = 0;
    for (size_t i = 0; i < img.pixels.size(); ++i) e += std::pow(double(img.pixels[i]) - reference.pixels[i], 2);
    return std::sqrt(e / double(img.pixels.size()));
  };
  const double e2 = rms(2), e8 = rms(8), e32 = rms(32);
  std::cout << "[ mc ] RMS error against 256 samples: 2 -> " << e2 << ", 8 -> " << e8 << ", 32 -> " << e32 << "\n";
  // Monte Carlo: the error halves per 4x samples (less near the reference's own noise).
  EXPECT_LT(e8, 0.7 * e2);
  EXPECT_LT(e32, 0.7 * e8);
}

TEST(PathTracerGl, TimeLimitStopsEarlyAndMipFallsBackToRayCasting) {
  const VolumeI16 v = test::makeAnalyticVolume(32);
  VolumeRenderer r(ptGl());
  r.setVolume(v);
  RenderSettings s = cinematic(Preset::Bone, 1000, 1);
  s.cinematic.timeLimitS = 1e-6;  // one pass, then the limit has passed
  r.render(s);
  EXPECT_EQ(r.lastSamples(), 1);
  s.preset = Preset::Mip;
  RenderSettings plain = s;
  plain.quality = Quality::Standard;
  EXPECT_EQ(r.render(s).pixels, r.render(plain).pixels);
}

}  // namespace
}  // namespace vellum::render
