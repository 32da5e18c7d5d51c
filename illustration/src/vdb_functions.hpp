#pragma once
// The OpenVDB half of the shape pipeline lives in a module opened on first use
// (illustration/vdb): linking libopenvdb would cost every `vellum` command ~25 ms of dynamic
// loading at start-up, also the many that never build a shape. This is the table of its
// entry points, shared by the module and by vdb_client.cpp. Only plain types cross it.
#include <array>
#include <cstdint>
#include <vector>

#include "shape_internal.hpp"

namespace vellum::illustration::detail {

/// Bumped whenever VdbFunctions changes: a stale module file is refused, not called.
inline constexpr int kVdbFunctionsVersion = 2;

struct VdbFunctions {
  int version = kVdbFunctionsVersion;
  /// Narrow-band half width (voxels) of denoised level sets; toDense clamps to +-it.
  float levelSetHalfWidth = 2.0f;
  LevelSet* (*denoise)(const MaskBox& mask, int iterations, double margin) = nullptr;
  void (*release)(LevelSet* levelSet) = nullptr;
  /// phi (voxel units) on the full grid of `dims` voxels (x fastest) into `out`.
  void (*toDense)(const LevelSet& levelSet, std::array<int64_t, 3> dims, float* out) = nullptr;
  TriMesh (*indexMesh)(const LevelSet& levelSet, double adaptivity) = nullptr;
};

/// The module's functions, opened on first use (vdb_client.cpp; VELLUM_VDB_MODULE overrides
/// the built-in file). Throws vellum::Error naming the file when it cannot be opened or is stale.
const VdbFunctions& vdbFunctions();

}  // namespace vellum::illustration::detail

/// The module's one entry point (found with dlsym).
extern "C" const vellum::illustration::detail::VdbFunctions* vellum_vdb_functions();
