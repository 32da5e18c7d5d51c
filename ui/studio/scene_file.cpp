#include "scene_file.hpp"

#include <fstream>
#include <tuple>
#include <nlohmann/json.hpp>

#include "vellum/core/error.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/deformation/deform_params.hpp"
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

/// Version 3: the tables' keys (unknown keys are refused, so a typo does not pass silently).
void readView(const json& j, ViewState& v) {
  if (j.contains("view")) params::fromJson(viewSettingsTable(), j["view"], v.view, "view");
  if (j.contains("render")) params::fromJson(render::renderSettingsTable(), j["render"], v.render, "render");
  if (j.contains("pan")) v.render.camera.panMm = jsonVec3(j["pan"]);
  if (j.contains("illustration")) {
    const json& il = j["illustration"];
    v.illustration.enabled = il.value("enabled", false);
    if (il.contains("style")) v.illustration.style = illustration::styleFromJson(il["style"].dump(), "illustration.style");
  }
  for (const json& b : j.value("camera_bookmarks", json::array())) {
    CameraBookmark bm{b.at("name").get<std::string>(), {}};
    render::RenderSettings camera;
    json keys = b;
    keys.erase("name");
    keys.erase("pan");
    params::fromJson(render::renderSettingsTable(), keys, camera, "camera_bookmarks");
    bm.camera = camera.camera;
    if (b.contains("pan")) bm.camera.panMm = jsonVec3(b["pan"]);
    v.bookmarks.push_back(std::move(bm));
  }
}

/// Versions 1 and 2 wrote each view field under its own key.
void readLegacyView(const json& j, ViewState& v) {
  v.view.layout = parseLayout(j.value("layout", "2x2"));
  v.render.preset = render::parsePreset(j.value("preset", "soft-tissue"));
  if (j.contains("camera")) {
    const json& c = j["camera"];
    render::Camera& cam = v.render.camera;
    cam.azimuthDeg = c.value("azimuth", cam.azimuthDeg);
    cam.elevationDeg = c.value("elevation", cam.elevationDeg);
    cam.zoom = c.value("zoom", cam.zoom);
    cam.fieldOfViewDeg = c.value("fov", cam.fieldOfViewDeg);
    if (c.contains("pan")) cam.panMm = jsonVec3(c["pan"]);
  }
  if (j.contains("slice_window"))
    v.view.sliceWindow = {j["slice_window"].at(0).get<double>(), j["slice_window"].at(1).get<double>()};
  if (j.contains("render_window"))
    std::tie(v.render.windowCenter, v.render.windowWidth) =
        std::pair{j["render_window"].at(0).get<double>(), j["render_window"].at(1).get<double>()};
  v.view.labelOpacity = j.value("label_opacity", v.view.labelOpacity);
  params::validate(viewSettingsTable(), v.view);
  params::validate(render::renderSettingsTable(), v.render);
}

/// The camera fields of the render table (a bookmark is a camera, nothing else).
json cameraJson(const render::Camera& camera) {
  render::RenderSettings s;
  s.camera = camera;
  json all = params::toJson(render::renderSettingsTable(), s), j;
  for (const char* key : {"azimuth", "elevation", "zoom", "fov"}) j[key] = all.at(key);
  j["pan"] = vec3Json(camera.panMm);
  return j;
}

}  // namespace

json sceneViewJson(const SceneFile& s) {
  json j;
  j["view"] = params::toJson(viewSettingsTable(), s.view.view);
  json r = params::toJson(render::renderSettingsTable(), s.view.render);
  for (const auto& key : renderKeysNotInScene()) r.erase(key);
  j["render"] = std::move(r);
  j["pan"] = vec3Json(s.view.render.camera.panMm);
  j["camera_bookmarks"] = json::array();
  for (const auto& b : s.view.bookmarks) {
    json bj = cameraJson(b.camera);
    bj["name"] = b.name;
    j["camera_bookmarks"].push_back(std::move(bj));
  }
  j["illustration"] = {{"enabled", s.view.illustration.enabled},
                       {"style", json::parse(illustration::styleToJson(s.view.illustration.style))}};
  j["crosshair"] = vec3Json(s.crosshairMm);
  j["hidden_labels"] = s.hiddenLabels;
  j["locked_labels"] = s.lockedLabels;
  return j;
}

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
    s.shapes = resolvedPath(j.value("shapes", ""), base);
    s.seriesUid = j.value("series", "");
    if (version >= 3) readView(j, s.view);
    else readLegacyView(j, s.view);
    if (j.contains("crosshair")) s.crosshairMm = jsonVec3(j["crosshair"]);
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
      if (d.contains("engine")) params::fromJson(deformation::deformParamsTable(), d["engine"], def.engine, "deformation.engine");
      s.deformation = std::move(def);
    }
  } catch (const json::exception& e) {
    throw FileError(path, std::string("bad scene field: ") + e.what());
  } catch (const FileError&) {
    throw;
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  for (const fs::path& data : {s.volume, s.labels, s.shapes})
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
  if (!s.shapes.empty()) j["shapes"] = storedPath(s.shapes, base);
  if (!s.seriesUid.empty()) j["series"] = s.seriesUid;
  j.update(sceneViewJson(s));
  if (s.deformation) {
    fs::path keys = path;
    keys.replace_extension(".keyframes.json");
    deformation::saveKeyframes(s.deformation->track, keys);
    j["deformation"] = {{"keyframes", storedPath(keys, base)},
                        {"keyframe", s.deformation->keyframe},
                        {"rigid_labels", s.deformation->rigidLabels},
                        {"rigid_falloff_mm", s.deformation->falloffMm},
                        {"engine", params::toJson(deformation::deformParamsTable(), s.deformation->engine)}};
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
  s.view = scene.viewState();
  s.shapes = scene.shapesPath;
  s.crosshairMm = scene.crosshairMm;
  s.hiddenLabels = scene.hiddenLabels;
  s.lockedLabels = scene.lockedLabels;
  if (scene.authoring.active())
    s.deformation = SceneDeformation{{}, scene.authoring.track, scene.authoring.keyframe, scene.authoring.rigidLabels,
                                     scene.authoring.falloffMm, scene.authoring.engine};
  return s;
}

void applySceneView(const SceneFile& s, Scene& scene) {
  scene.setViewState(s.view);
  scene.crosshairMm = s.crosshairMm;
  scene.hiddenLabels = s.hiddenLabels;
  scene.lockedLabels = s.lockedLabels;
  if (s.deformation) {
    Authoring& a = scene.authoring;
    a.track = s.deformation->track;
    a.keyframe = s.deformation->keyframe;
    a.rigidLabels = s.deformation->rigidLabels;
    a.falloffMm = s.deformation->falloffMm;
    a.engine = s.deformation->engine;
    a.selected = -1;
    a.timeS.reset();
    a.playing = false;
    a.touch();
  }
}

}  // namespace vellum::studio
