#pragma once
// The shapes' segment meshes for the 3D view (ViewSettings::meshesIn3d): read from a `vellum
// shape` folder or kept from shapes made in the studio, and handed to render::MeshRenderer.
#include <array>
#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/render/mesh_renderer.hpp"

namespace vellum::studio {

struct SegmentMesh {
  std::string name;
  std::vector<uint16_t> labelIds;  ///< the label-map ids it was made from (hiding all hides it)
  std::array<uint8_t, 3> rgb{255, 255, 255};
  illustration::TriMesh mesh;
};
using SegmentMeshes = std::vector<SegmentMesh>;

/// FOLDER/meshes/NAME.ply for each segment NAME of FOLDER/shape.json (its "ids" are the label
/// ids), coloured as FOLDER's segment label table (`segments`) colours NAME. Without a
/// shape.json, every meshes/*.ply with no ids. Segments written in another mesh format are
/// left out. vellum::FileError naming the file for an unreadable shape.json or mesh.
SegmentMeshes loadSegmentMeshes(const std::filesystem::path& folder, const LabelVolume& segments);
/// The meshes of shapes made by the pipeline in the studio.
SegmentMeshes segmentMeshesOf(const std::vector<illustration::SegmentShape>& shapes);
/// As the renderer's plain arrays (colours in [0, 1]).
std::vector<render::SurfaceMesh> toSurfaceMeshes(const SegmentMeshes& meshes);
/// Per mesh: visible unless every one of its label ids is hidden (no ids: always visible).
std::vector<bool> visibleMeshes(const SegmentMeshes& meshes, const std::set<uint16_t>& hidden);

}  // namespace vellum::studio
