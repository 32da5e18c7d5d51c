#pragma once
// The sub-sample patterns behind subSampleOffsets, so makePhantom can precompute them.
#include <array>
#include <cstdint>

#include "vellum/phantom/phantom.hpp"

namespace vellum::phantom::detail {

/// Number of distinct pseudo-random sub-sample patterns.
inline constexpr uint32_t kSubSamplePatterns = 256;

/// The pattern voxel (i, j, k) uses: a hash of its index, in [0, kSubSamplePatterns).
uint32_t subSamplePatternIndex(int64_t i, int64_t j, int64_t k);

/// Index-space offsets of pattern `pattern` for the PSF smoothing (see subSampleOffsets).
std::array<Vec3, kSubSamples> subSamplePattern(uint32_t pattern, double psfSmoothingVoxels);

}  // namespace vellum::phantom::detail
