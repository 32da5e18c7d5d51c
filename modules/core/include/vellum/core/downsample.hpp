#pragma once
// downsampleMean (region.hpp) of an int16 volume the caller holds, without wrapping it in an
// AnyVolume (a copy): the studio makes the 3D view's light source from its CT on a worker.
#include "vellum/core/volume.hpp"

namespace vellum {

/// Mean of every n^3 block, rounded (region.hpp's downsampleMean, the same code).
VolumeI16 downsampleMean(const VolumeI16& v, int n);

}  // namespace vellum
