#pragma once
// The full-resolution backward map as a file (`vellum deform --map-out`): a 4-D NRRD of
// 3-component float32 vectors (the source position in mm, LPS, of every output voxel),
// gzip-encoded, so other tools (3D Slicer, ITK, teem) read it as a displacement-style field.
#include <filesystem>
#include <vector>

#include "vellum/core/geometry.hpp"

namespace vellum::deformation {

/// Writes `mapMm` (3 floats per voxel of `grid`, x fastest, as upsampleMap() returns it) to
/// `path` as a single-file NRRD: type float, dimension 4, sizes 3 X Y Z, kinds "vector domain
/// domain domain", space left-posterior-superior with the grid's origin and directions,
/// encoding gzip (zlib, fast level) or raw. Written atomically (temporary + rename).
/// Throws vellum::FileError naming the file (size mismatch, cannot write, disk full).
void saveBackwardMapNrrd(const std::vector<float>& mapMm, const Geometry& grid,
                         const std::filesystem::path& path, bool gzip = true);

/// Reads a map written by saveBackwardMapNrrd (raw or gzip); fills `grid` if non-null.
/// Throws vellum::FileError naming the file for anything else or a damaged file.
std::vector<float> loadBackwardMapNrrd(const std::filesystem::path& path, Geometry* grid = nullptr);

/// The attribute field of a control volume (`vellum deform --attributes-out`): 4 floats per node
/// of the control grid (dL*, da*, db*, density scale; output space), the same NRRD layout with
/// 4 components. `vellum render --attributes` applies it to the deformed volume.
void saveAttributeFieldNrrd(const std::vector<float>& attributes, const Geometry& grid,
                            const std::filesystem::path& path, bool gzip = true);
std::vector<float> loadAttributeFieldNrrd(const std::filesystem::path& path, Geometry* grid = nullptr);

/// Either file: `components` floats per voxel; `what` names it in errors.
std::vector<float> loadFloatVectorNrrd(const std::filesystem::path& path, int components, const char* what,
                                       Geometry* grid = nullptr);

}  // namespace vellum::deformation
