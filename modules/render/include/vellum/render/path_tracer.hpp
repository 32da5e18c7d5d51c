#pragma once
// The cinematic quality's CPU reference (docs/lighting.md, "Cinematic"). The GL path is
// VolumeRenderer::render() with RenderSettings::quality = Quality::Cinematic.
#include "vellum/core/image.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::render {

/// Path traces `settings.cinematic.samples` paths per pixel on the CPU with the GL shader's
/// math and random numbers (delta tracking against per-block majorants, ratio-tracked shadow
/// rays to the key/fill lights and the sky, phase function or BRDF by gradient strength), then
/// tone maps and denoises as the GL path does. Slow; for tests and small images. Ignores the time
/// limit and label colours. Throws vellum::Error for the mip preset.
RgbaImage renderPathTracedCpu(const AnyVolume& volume, const RenderSettings& settings,
                              const BackwardMap* map = nullptr);

}  // namespace vellum::render
