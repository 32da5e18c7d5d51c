#pragma once
// The cinematic quality's CPU reference (docs/lighting.md, "Cinematic"). The GL path is
// VolumeRenderer::render() with RenderSettings::quality = Quality::Cinematic.
#include "vellum/core/image.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/label_tint.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::render {

/// Path traces `settings.cinematic.samples` paths per pixel on the CPU with the GL shader's
/// math and random numbers (delta tracking against per-block majorants, ratio-tracked shadow
/// rays to the key/fill lights and the sky, phase function or BRDF by gradient strength), then
/// tone maps and denoises as the GL path does; `tint` (with settings.labelBlend > 0) colours the
/// albedo as VolumeRenderer::setLabelTint does. Slow; for tests and small images. Ignores the
/// time limit. Throws vellum::Error for the mip preset.
RgbaImage renderPathTracedCpu(const AnyVolume& volume, const RenderSettings& settings,
                              const BackwardMap* map = nullptr, const LabelTint* tint = nullptr);

}  // namespace vellum::render
