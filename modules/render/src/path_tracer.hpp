#pragma once
// The cinematic path tracer's shared math (docs/lighting.md, "Cinematic"): what the GLSL
// (shaders/path_trace_main.frag.glsl) and the CPU reference (path_tracer.cpp) both use, so that
// they draw the same random numbers, lights and majorants. Internal to modules/render.
#include <cstdint>
#include <vector>

#include "empty_space.hpp"
#include "lights.hpp"
#include "render_common.hpp"
#include "vellum/core/image.hpp"
#include "vellum/render/label_tint.hpp"

namespace vellum::render::detail {

/// Opacity per step -> extinction per mm; alpha is capped (an opaque table entry would give an
/// infinite majorant).
constexpr float kMaxPathAlpha = 0.9999f;
/// Ratio tracking stops when the transmittance falls below this (a shadow).
constexpr float kMinTransmittance = 1e-3f;
/// How far a tracking step moves past a block face, in mm (so that the next block is entered).
constexpr float kBlockNudgeMm = 1e-3f;
/// Surface (BRDF) events: outgoing rays start up to this many voxels (of the smallest spacing)
/// above the event, along the normal (see CpuTracer::path).
constexpr double kSurfaceOffsetVoxels = 2.0;
/// Upper bound on tracking iterations per ray segment (against runaway loops).
constexpr int kMaxTrackingSteps = 1 << 14;

/// PCG hash (Jarzynski & Olano 2020), bit-identical in GLSL.
inline uint32_t pcgHash(uint32_t v) {
  const uint32_t state = v * 747796405u + 2891336453u;
  const uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
/// Per pixel (row 0 = top) and sample index: a PCG stream seeded by hashing all three, so any
/// sample of any pixel can be drawn in any order (progressive passes, CPU rows in parallel).
struct PathRng {
  uint32_t state;
  PathRng(int px, int py, uint32_t sample, uint32_t seed)
      : state(pcgHash(pcgHash(pcgHash(seed) ^ uint32_t(px)) ^ (uint32_t(py) * 0x9E3779B9u)) ^
              pcgHash(sample + 0x632BE5ABu)) {}
  /// Uniform in [0, 1) with 24 bits.
  float next() {
    state = pcgHash(state);
    return float(state >> 8) * (1.f / 16777216.f);
  }
};

/// The scene lights (lights.hpp, shared with the ray caster) and how the paths sample them.
struct PathLights : SceneLights {
  float pickKey = 1;     ///< probability that next-event estimation samples the key (else the fill)
  int bounces = 1;
  float surfaceOffsetMm = 1;  ///< the most a surface event's outgoing rays start above it
};
PathLights makePathLights(const Frame& f, const RenderSettings& s);

/// Per block (source blocks of kBlockSize voxels, or map cells) the largest extinction per mm
/// any sample in it can have: the maximum of -ln(1 - alpha) / step over the table entries the
/// block's value range can interpolate between (alpha is linear between entries and -ln(1-a)
/// convex, so the maximum is at an entry).
std::vector<float> blockMajorants(const BlockRanges& ranges, const TfTable& tf, double stepMm);
/// The same per map cell: the largest of the blocks its samples read, times `scale` (the
/// attribute field's largest density scale).
std::vector<float> cellMajorants(const MapCells& cells, const std::vector<float>& block, const Dims& blocks, float scale);

/// Sums of sample radiance (linear, premultiplied by coverage) and coverage, 4 floats per
/// pixel, row 0 = top, over `samples` paths per pixel.
struct PathSums {
  int width = 0, height = 0, samples = 0;
  std::vector<float> rgba;
};
/// The picture: mean radiance times the exposure, ACES filmic tone map (Narkowicz's fit), sRGB,
/// over the background by the mean coverage, then (cinematic.denoise > 0 and a guide) the
/// edge-aware denoise: a guided filter of each channel under the ray caster's noise-free picture
/// of the same view (`guide`, made with denoiseGuideSettings()), window radius 1 + 5 x denoise
/// pixels. GL and CPU both end here.
RgbaImage finishPathTraced(const PathSums& sums, const RenderSettings& s, const RgbaImage* guide);
/// The settings the paths are traced with: the image size times cinematic.traceScale (at least
/// 1 pixel); finishPathTraced() upsamples their sums to the full size.
RenderSettings tracedSettings(const RenderSettings& s);
/// The settings of the denoise guide: the same view ray cast with plain shading.
RenderSettings denoiseGuideSettings(const RenderSettings& s);

/// The CPU reference's sums (renderPathTracedCpu() before finishPathTraced()): for tests that
/// check radiance before the tone map.
PathSums pathTraceCpu(const AnyVolume& volume, const RenderSettings& s, const BackwardMap* map,
                      const LabelTint* tint = nullptr);

/// Samples per pass of the progressive loop: small passes, so that a time limit is honoured
/// within about one pass and a GPU watchdog never fires.
constexpr int kSamplesPerPass = 1;

}  // namespace vellum::render::detail
