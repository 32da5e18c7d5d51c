#include "segment_meshes.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

namespace {

std::array<uint8_t, 3> colourOf(const LabelVolume& segments, const std::string& name) {
  for (const Label& l : segments.table())
    if (l.name == name) return l.rgb;
  return {255, 255, 255};
}

}  // namespace

SegmentMeshes loadSegmentMeshes(const fs::path& folder, const LabelVolume& segments) {
  SegmentMeshes out;
  const fs::path report = folder / "shape.json";
  auto add = [&](const std::string& name, std::vector<uint16_t> ids) {
    const fs::path file = folder / "meshes" / (name + ".ply");
    if (!fs::exists(file)) return;  // written as OBJ or STL: not read here
    out.push_back({name, std::move(ids), colourOf(segments, name), illustration::loadMesh(file)});
  };
  if (fs::exists(report)) {
    const nlohmann::json j = readJsonFile(report, 16u << 20, "shape report");  // a segment list: KBs
    try {
      for (const auto& s : j.at("segments")) add(s.at("name").get<std::string>(), s.value("ids", std::vector<uint16_t>{}));
    } catch (const nlohmann::json::exception& e) {
      throw FileError(report, std::string("not a vellum shape report: ") + e.what());
    }
    return out;
  }
  if (!fs::is_directory(folder / "meshes")) return out;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder / "meshes"))
    if (e.path().extension() == ".ply") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) add(f.stem().string(), {});
  return out;
}

SegmentMeshes segmentMeshesOf(const std::vector<illustration::SegmentShape>& shapes) {
  SegmentMeshes out;
  for (const auto& s : shapes) out.push_back({s.segment.name, s.segment.ids, s.segment.rgb, s.mesh});
  return out;
}

std::vector<render::SurfaceMesh> toSurfaceMeshes(const SegmentMeshes& meshes) {
  std::vector<render::SurfaceMesh> out;
  for (const SegmentMesh& m : meshes) {
    render::SurfaceMesh s;
    s.rgb = {m.rgb[0] / 255.f, m.rgb[1] / 255.f, m.rgb[2] / 255.f};
    s.positionsMm.reserve(3 * m.mesh.vertices.size());
    for (const auto& v : m.mesh.vertices) s.positionsMm.insert(s.positionsMm.end(), v.begin(), v.end());
    s.triangles.reserve(3 * m.mesh.faces.size());
    for (const auto& f : m.mesh.faces) s.triangles.insert(s.triangles.end(), f.begin(), f.end());
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<bool> visibleMeshes(const SegmentMeshes& meshes, const std::set<uint16_t>& hidden) {
  std::vector<bool> visible;
  for (const SegmentMesh& m : meshes)
    visible.push_back(m.labelIds.empty() ||
                      !std::all_of(m.labelIds.begin(), m.labelIds.end(), [&](uint16_t id) { return hidden.count(id) > 0; }));
  return visible;
}

}  // namespace vellum::studio
