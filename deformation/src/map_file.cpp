#include "vellum/deformation/map_file.hpp"

#include <cstring>
#include <string>

#include "vellum/core/error.hpp"
#include "vellum/io/nrrd_reader.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::deformation {
namespace fs = std::filesystem;

void saveBackwardMapNrrd(const std::vector<float>& map, const Geometry& g, const fs::path& path, bool gzip) {
  if (map.size() != 3 * static_cast<size_t>(g.dims.voxelCount()))
    throw FileError(path, "backward map has " + std::to_string(map.size()) + " floats, the grid " +
                              g.dims.str() + " needs 3 per voxel");
  io::NrrdLayout layout;
  layout.type = "float";
  layout.leadingSizes = {3};
  layout.leadingKinds = {"vector"};
  layout.geometry = g;
  layout.comments = {"Vellum backward map: source position (mm, LPS) of every output voxel"};
  layout.extraFields = "space units: \"mm\" \"mm\" \"mm\"\n";
  io::writeNrrd(path, layout, map.data(), map.size() * sizeof(float), gzip);
}

std::vector<float> loadBackwardMapNrrd(const fs::path& path, Geometry* gridOut) {
  io::NrrdContents c = io::readNrrd(path);
  const io::NrrdLayout& l = c.layout;
  if (l.type != "float" || l.leadingSizes != std::vector<int64_t>{3} || l.leadingKinds != std::vector<std::string>{"vector"})
    throw FileError(path, "not a Vellum backward map (needs type float, kinds vector domain domain domain, 3 components)");
  std::vector<float> map(c.bytes.size() / sizeof(float));
  std::memcpy(map.data(), c.bytes.data(), map.size() * sizeof(float));
  if (gridOut) *gridOut = l.geometry;
  return map;
}

}  // namespace vellum::deformation
