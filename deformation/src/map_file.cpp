#include "vellum/deformation/map_file.hpp"

#include <cmath>
#include <cstring>
#include <string>

#include "vellum/core/error.hpp"
#include "vellum/io/nrrd_reader.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::deformation {
namespace fs = std::filesystem;

namespace {
/// The writer twin of loadFloatVectorNrrd: `components` floats per node of `grid`, as a
/// float vector NRRD in mm space.
void saveFloatVectorNrrd(const std::vector<float>& values, int components, const Geometry& grid, const fs::path& path,
                         bool gzip, const char* what, const char* perWhat, std::string comment) {
  if (values.size() != size_t(components) * static_cast<size_t>(grid.dims.voxelCount()))
    throw FileError(path, std::string(what) + " has " + std::to_string(values.size()) + " floats, the grid " +
                              grid.dims.str() + " needs " + std::to_string(components) + " per " + perWhat);
  io::NrrdLayout layout;
  layout.type = "float";
  layout.leadingSizes = {components};
  layout.leadingKinds = {"vector"};
  layout.geometry = grid;
  layout.comments = {std::move(comment)};
  layout.extraFields = "space units: \"mm\" \"mm\" \"mm\"\n";
  io::writeNrrd(path, layout, values.data(), values.size() * sizeof(float), gzip);
}
}  // namespace

void saveBackwardMapNrrd(const std::vector<float>& map, const Geometry& g, const fs::path& path, bool gzip) {
  saveFloatVectorNrrd(map, 3, g, path, gzip, "backward map", "voxel",
                      "Vellum backward map: source position (mm, LPS) of every output voxel");
}

void saveAttributeFieldNrrd(const std::vector<float>& attributes, const Geometry& grid, const fs::path& path, bool gzip) {
  saveFloatVectorNrrd(attributes, 4, grid, path, gzip, "attribute field", "node",
                      "Vellum attribute field: dL*, da*, db*, density scale per node of the control grid (output space)");
}

std::vector<float> loadBackwardMapNrrd(const fs::path& path, Geometry* gridOut) {
  return loadFloatVectorNrrd(path, 3, "backward map", gridOut);
}

std::vector<float> loadAttributeFieldNrrd(const fs::path& path, Geometry* gridOut) {
  std::vector<float> a = loadFloatVectorNrrd(path, 4, "attribute field", gridOut);
  for (size_t i = 0; i < a.size(); ++i)
    if (!std::isfinite(a[i]))
      throw FileError(path, "attribute field value " + std::to_string(i) + " is not finite");
  return a;
}

std::vector<float> loadFloatVectorNrrd(const fs::path& path, int components, const char* what, Geometry* gridOut) {
  io::NrrdContents c = io::readNrrd(path);
  const io::NrrdLayout& l = c.layout;
  if (l.type != "float" || l.leadingSizes != std::vector<int64_t>{components} ||
      l.leadingKinds != std::vector<std::string>{"vector"})
    throw FileError(path, std::string("not a Vellum ") + what + " (needs type float, kinds vector domain domain domain, " +
                              std::to_string(components) + " components)");
  std::vector<float> map(c.bytes.size() / sizeof(float));
  std::memcpy(map.data(), c.bytes.data(), map.size() * sizeof(float));
  if (gridOut) *gridOut = l.geometry;
  return map;
}

}  // namespace vellum::deformation
