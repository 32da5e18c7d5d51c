#pragma once
// The 0/1 copy of a mask: what the component operations (keep largest, islands, fill holes)
// start from, so that their results are 0/1 whatever non-zero values the input held. Its own
// small header so that only its users include it.
#include "vellum/core/volume.hpp"

namespace vellum {

/// A mask of `mask`'s geometry and background: 1 where `mask` is non-zero, else 0 (parallel).
VolumeU8 binaryCopy(const VolumeU8& mask);

}  // namespace vellum
