#include "scene_file.hpp"

#include <fstream>
#include <nlohmann/json.hpp>

#include "vellum/core/error.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json vec3Json(const Vec3& v) { return json::array({v.x, v.y, v.z}); }
Vec3 jsonVec3(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()}; }

/// Relative to `base` when that needs no more than one "..", absolute otherwise: a scene
/// folder moved together with its data keeps working.
std::string storedPath(const fs::path& p, const fs::path& base) {
  if (p.empty()) return "";
  const fs::path abs = fs::absolute(p).lexically_normal();
  const fs::path rel = abs.lexically_relative(fs::absolute(base).lexically_normal());
  int ups = 0;
  for (const auto& part : rel) ups += part == "..";
  return (!rel.empty() && ups <= 1) ? rel.generic_string() : abs.generic_string();
}

fs::path resolvedPath(const std::string& stored, const fs::path& base) {
  if (stored.empty()) return {};
  const fs::path p(stored);
  return (p.is_absolute() ? p : base / p).lexically_normal();
}

}  // namespace

SceneFile readSceneFile(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw FileError(path, "cannot open scene file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw FileError(path, std::string("not valid JSON: ") + e.what());
  }
  SceneFile s;
  try {
    if (j.value("format", "") != "vellum-studio-scene")
      throw FileError(path, "not a vellum-studio scene (\"format\" is not \"vellum-studio-scene\")");
    const int version = j.at("version").get<int>();
    if (version < 1 || version > kSceneFormatVersion)
      throw FileError(path, "scene version " + std::to_string(version) + " is not supported (this studio reads 1.." +
                                std::to_string(kSceneFormatVersion) + ")");
    const fs::path base = path.parent_path();
    s.volume = resolvedPath(j.at("volume").get<std::string>(), base);
    s.labels = resolvedPath(j.value("labels", ""), base);
    s.seriesUid = j.value("series", "");
    s.layout = parseLayout(j.value("layout", "2x2"));
    s.preset = render::parsePreset(j.value("preset", "soft-tissue"));
    if (j.contains("camera")) {
      const json& c = j["camera"];
      s.camera.azimuthDeg = c.value("azimuth", s.camera.azimuthDeg);
      s.camera.elevationDeg = c.value("elevation", s.camera.elevationDeg);
      s.camera.zoom = c.value("zoom", s.camera.zoom);
      s.camera.fieldOfViewDeg = c.value("fov", s.camera.fieldOfViewDeg);
      if (c.contains("pan")) s.camera.panMm = jsonVec3(c["pan"]);
    }
    if (j.contains("slice_window"))
      s.sliceWindow = {j["slice_window"].at(0).get<double>(), j["slice_window"].at(1).get<double>()};
    if (j.contains("render_window"))
      s.renderWindow = {j["render_window"].at(0).get<double>(), j["render_window"].at(1).get<double>()};
    if (j.contains("crosshair")) s.crosshairMm = jsonVec3(j["crosshair"]);
    s.labelOpacity = j.value("label_opacity", s.labelOpacity);
    for (const auto& id : j.value("hidden_labels", json::array())) s.hiddenLabels.insert(id.get<uint16_t>());
    for (const auto& id : j.value("locked_labels", json::array())) s.lockedLabels.insert(id.get<uint16_t>());
    if (j.contains("deformation")) {
      const json& d = j["deformation"];
      SceneDeformation def;
      def.keyframesPath = resolvedPath(d.at("keyframes").get<std::string>(), base);
      if (!fs::exists(def.keyframesPath))
        throw FileError(def.keyframesPath, "referenced by " + path.filename().string() + " does not exist");
      def.track = deformation::loadKeyframes(def.keyframesPath);  // names that file on errors
      def.keyframe = d.value("keyframe", 0);
      if (def.keyframe < 0 || def.keyframe >= int(def.track.keyframes.size()))
        throw FileError(path, "deformation.keyframe " + std::to_string(def.keyframe) + " is not a keyframe of " +
                                  def.keyframesPath.filename().string());
      def.rigidLabels = d.value("rigid_labels", std::vector<uint16_t>{});
      def.falloffMm = d.value("rigid_falloff_mm", 10.0);
      if (!(def.falloffMm > 0 && def.falloffMm < 1e4)) throw FileError(path, "deformation.rigid_falloff_mm must be in (0, 1e4)");
      s.deformation = std::move(def);
    }
  } catch (const json::exception& e) {
    throw FileError(path, std::string("bad scene field: ") + e.what());
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  for (const fs::path& data : {s.volume, s.labels})
    if (!data.empty() && !fs::exists(data))
      throw FileError(data, "referenced by " + path.filename().string() + " does not exist");
  return s;
}

void writeSceneFile(const SceneFile& s, const fs::path& path) {
  const fs::path base = path.parent_path().empty() ? fs::current_path() : path.parent_path();
  json j;
  j["format"] = "vellum-studio-scene";
  j["version"] = kSceneFormatVersion;
  j["volume"] = storedPath(s.volume, base);
  j["labels"] = storedPath(s.labels, base);
  if (!s.seriesUid.empty()) j["series"] = s.seriesUid;
  j["layout"] = layoutName(s.layout);
  j["preset"] = render::presetName(s.preset);
  j["camera"] = {{"azimuth", s.camera.azimuthDeg},
                 {"elevation", s.camera.elevationDeg},
                 {"zoom", s.camera.zoom},
                 {"fov", s.camera.fieldOfViewDeg},
                 {"pan", vec3Json(s.camera.panMm)}};
  j["slice_window"] = {s.sliceWindow.center, s.sliceWindow.width};
  j["render_window"] = {s.renderWindow.center, s.renderWindow.width};
  j["crosshair"] = vec3Json(s.crosshairMm);
  j["label_opacity"] = s.labelOpacity;
  j["hidden_labels"] = s.hiddenLabels;
  j["locked_labels"] = s.lockedLabels;
  if (s.deformation) {
    fs::path keys = path;
    keys.replace_extension(".keyframes.json");
    deformation::saveKeyframes(s.deformation->track, keys);
    j["deformation"] = {{"keyframes", storedPath(keys, base)},
                        {"keyframe", s.deformation->keyframe},
                        {"rigid_labels", s.deformation->rigidLabels},
                        {"rigid_falloff_mm", s.deformation->falloffMm}};
  }
  const std::string text = j.dump(2) + "\n";
  io::writeAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    if (!out.flush()) throw FileError(path, "write failed");
  });
}

SceneFile describeScene(const Scene& scene) {
  SceneFile s;
  s.volume = scene.volumePath;
  s.labels = scene.labelsPath;
  s.seriesUid = scene.series.size() > 1 ? scene.seriesUid : "";
  s.layout = scene.layout;
  s.preset = scene.preset;
  s.camera = scene.camera;
  s.sliceWindow = scene.sliceWindow;
  s.renderWindow = scene.renderWindow;
  s.crosshairMm = scene.crosshairMm;
  s.labelOpacity = scene.labelOpacity;
  s.hiddenLabels = scene.hiddenLabels;
  s.lockedLabels = scene.lockedLabels;
  if (scene.authoring.active())
    s.deformation = SceneDeformation{{}, scene.authoring.track, scene.authoring.keyframe, scene.authoring.rigidLabels,
                                     scene.authoring.falloffMm};
  return s;
}

void applySceneView(const SceneFile& s, Scene& scene) {
  scene.layout = s.layout;
  scene.preset = s.preset;
  scene.camera = s.camera;
  scene.sliceWindow = s.sliceWindow;
  scene.renderWindow = s.renderWindow;
  scene.crosshairMm = s.crosshairMm;
  scene.labelOpacity = s.labelOpacity;
  scene.hiddenLabels = s.hiddenLabels;
  scene.lockedLabels = s.lockedLabels;
  if (s.deformation) {
    Authoring& a = scene.authoring;
    a.track = s.deformation->track;
    a.keyframe = s.deformation->keyframe;
    a.rigidLabels = s.deformation->rigidLabels;
    a.falloffMm = s.deformation->falloffMm;
    a.selected = -1;
    a.timeS.reset();
    a.playing = false;
    a.touch();
  }
}

}  // namespace vellum::studio
