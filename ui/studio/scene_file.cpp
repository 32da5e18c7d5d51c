#include "scene_file.hpp"

#include <fstream>
#include <tuple>
#include <nlohmann/json.hpp>

#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json vec3Json(const Vec3& v) { return json::array({v.x, v.y, v.z}); }

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

/// Typed, range-checked fields: every error names the scene file and the field.
struct Fields {
  const fs::path& path;

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw FileError(path, "\"" + field + "\" " + what);
  }
  double number(const json& v, const std::string& field, double lo, double hi) const {
    if (!v.is_number()) fail(field, "must be a number");
    const double x = v.get<double>();
    if (!(x >= lo && x <= hi)) fail(field, "is " + std::to_string(x) + ", outside " + std::to_string(lo) + ".." + std::to_string(hi));
    return x;
  }
  double number(const json& obj, const char* key, const std::string& field, double def, double lo, double hi) const {
    return obj.contains(key) ? number(obj.at(key), field, lo, hi) : def;
  }
  std::string text(const json& obj, const char* key, const std::string& def) const {
    if (!obj.contains(key)) return def;
    if (!obj.at(key).is_string()) fail(key, "must be a string");
    return obj.at(key).get<std::string>();
  }
  bool flag(const json& obj, const char* key, const std::string& field, bool def) const {
    if (!obj.contains(key)) return def;
    if (!obj.at(key).is_boolean()) fail(field, "must be true or false");
    return obj.at(key).get<bool>();
  }
  Vec3 vec3(const json& v, const std::string& field) const {
    if (!v.is_array() || v.size() != 3) fail(field, "must be [x, y, z] in mm");
    return {number(v[0], field, -1e9, 1e9), number(v[1], field, -1e9, 1e9), number(v[2], field, -1e9, 1e9)};
  }
  WindowLevel window(const json& v, const std::string& field) const {
    if (!v.is_array() || v.size() != 2) fail(field, "must be [center, width]");
    return {number(v[0], field + "[0]", -1e9, 1e9), number(v[1], field + "[1]", 1e-9, 1e9)};
  }
  std::vector<uint16_t> ids(const json& obj, const char* key, const std::string& field) const {
    std::vector<uint16_t> out;
    if (!obj.contains(key)) return out;
    const json& v = obj.at(key);
    if (!v.is_array() || v.size() > 65536) fail(field, "must be an array of at most 65536 label ids");
    for (const json& id : v) {
      if (!id.is_number_integer()) fail(field, "must hold integer label ids");
      out.push_back(static_cast<uint16_t>(number(id, field, 0, 65535)));
    }
    return out;
  }
  const json& object(const json& obj, const char* key, const std::string& field) const {
    const json& v = obj.at(key);
    if (!v.is_object()) fail(field, "must be an object");
    return v;
  }
};

/// Version 3: the tables' keys (unknown keys are refused, so a typo does not pass silently).
void readView(const json& j, ViewState& v, const Fields& f) {
  if (j.contains("view")) params::fromJson(viewSettingsTable(), j["view"], v.view, "view");
  if (j.contains("render")) params::fromJson(render::renderSettingsTable(), j["render"], v.render, "render");
  if (j.contains("pan")) v.render.camera.panMm = f.vec3(j["pan"], "pan");
  if (j.contains("illustration")) {
    const json& il = f.object(j, "illustration", "illustration");
    v.illustration.enabled = f.flag(il, "enabled", "illustration.enabled", false);
    if (il.contains("style")) v.illustration.style = illustration::styleFromJson(il["style"].dump(), "illustration.style");
  }
  if (j.contains("camera_bookmarks") && (!j["camera_bookmarks"].is_array() || j["camera_bookmarks"].size() > 10000))
    f.fail("camera_bookmarks", "must be an array of at most 10000 cameras");
  for (const json& b : j.value("camera_bookmarks", json::array())) {
    if (!b.is_object() || !b.contains("name") || !b.at("name").is_string())
      f.fail("camera_bookmarks", "entries must be objects with a \"name\"");
    CameraBookmark bm{b.at("name").get<std::string>(), {}};
    render::RenderSettings camera;
    json keys = b;
    keys.erase("name");
    keys.erase("pan");
    params::fromJson(render::renderSettingsTable(), keys, camera, "camera_bookmarks");
    bm.camera = camera.camera;
    if (b.contains("pan")) bm.camera.panMm = f.vec3(b["pan"], "camera_bookmarks.pan");
    v.bookmarks.push_back(std::move(bm));
  }
}

/// Versions 1 and 2 wrote each view field under its own key.
void readLegacyView(const json& j, ViewState& v, const Fields& f) {
  v.view.layout = parseLayout(f.text(j, "layout", "2x2"));
  v.render.preset = render::parsePreset(f.text(j, "preset", "soft-tissue"));
  if (j.contains("camera")) {
    const json& c = f.object(j, "camera", "camera");
    render::Camera& cam = v.render.camera;
    cam.azimuthDeg = f.number(c, "azimuth", "camera.azimuth", cam.azimuthDeg, -1e6, 1e6);
    cam.elevationDeg = f.number(c, "elevation", "camera.elevation", cam.elevationDeg, -90, 90);
    cam.zoom = f.number(c, "zoom", "camera.zoom", cam.zoom, 1e-3, 1e3);
    cam.fieldOfViewDeg = f.number(c, "fov", "camera.fov", cam.fieldOfViewDeg, 0, 169);
    if (c.contains("pan")) cam.panMm = f.vec3(c["pan"], "camera.pan");
  }
  if (j.contains("slice_window")) v.view.sliceWindow = f.window(j["slice_window"], "slice_window");
  if (j.contains("render_window")) {
    const WindowLevel w = f.window(j["render_window"], "render_window");
    std::tie(v.render.windowCenter, v.render.windowWidth) = std::pair{w.center, w.width};
  }
  v.view.labelOpacity = static_cast<float>(f.number(j, "label_opacity", "label_opacity", v.view.labelOpacity, 0, 1));
  params::validate(viewSettingsTable(), v.view);
  params::validate(render::renderSettingsTable(), v.render);
}

SceneDeformation readDeformation(const json& j, const Fields& f, const fs::path& base) {
  const json& d = f.object(j, "deformation", "deformation");
  if (!d.contains("keyframes") || !d.at("keyframes").is_string()) f.fail("deformation.keyframes", "must be a file name");
  SceneDeformation def;
  def.keyframesPath = resolvedPath(d.at("keyframes").get<std::string>(), base);
  if (!fs::exists(def.keyframesPath))
    throw FileError(def.keyframesPath, "referenced by " + f.path.filename().string() + " does not exist");
  def.track = deformation::loadKeyframes(def.keyframesPath);  // names that file on errors
  def.keyframe = static_cast<int>(f.number(d, "keyframe", "deformation.keyframe", 0, 0, 1e9));
  if (def.keyframe >= int(def.track.keyframes.size()))
    throw FileError(f.path, "deformation.keyframe " + std::to_string(def.keyframe) + " is not a keyframe of " +
                                def.keyframesPath.filename().string());
  def.rigidLabels = f.ids(d, "rigid_labels", "deformation.rigid_labels");
  def.falloffMm = f.number(d, "rigid_falloff_mm", "deformation.rigid_falloff_mm", 10.0, 1e-6, 1e4);
  if (d.contains("engine")) params::fromJson(deformation::deformParamsTable(), d["engine"], def.engine, "deformation.engine");
  return def;
}

/// "joints": {"pose": FILE}: the pose file beside the scene, read by the pose file's own
/// reader (errors name that file and its field).
ScenePose readJoints(const json& j, const Fields& f, const fs::path& base) {
  const json& o = f.object(j, "joints", "joints");
  for (auto it = o.begin(); it != o.end(); ++it)
    if (it.key() != "pose") f.fail("joints." + it.key(), "is not a key of \"joints\" (only \"pose\")");
  if (!o.contains("pose") || !o.at("pose").is_string() || o.at("pose").get<std::string>().empty())
    f.fail("joints.pose", "must be a pose file name");
  ScenePose p;
  p.posePath = resolvedPath(o.at("pose").get<std::string>(), base);
  if (!fs::is_regular_file(p.posePath))
    throw FileError(p.posePath, "referenced by " + f.path.filename().string() + " does not exist");
  p.pose = deformation::loadPose(p.posePath);
  return p;
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
  // A scene is a few KB (its keyframes live in their own file); 16 MiB is room for bookmarks.
  const json j = readJsonFile(path, 16u << 20, "scene file");
  if (!j.is_object()) throw FileError(path, "not a vellum-studio scene (expected a JSON object)");
  const Fields f{path};
  SceneFile s;
  try {
    if (!j.contains("format") || j.at("format") != "vellum-studio-scene")
      throw FileError(path, "not a vellum-studio scene (\"format\" is not \"vellum-studio-scene\")");
    if (!j.contains("version") || !j.at("version").is_number_integer()) f.fail("version", "must be an integer");
    const int version = j.at("version").get<int>();
    if (version < 1 || version > kSceneFormatVersion)
      throw FileError(path, "scene version " + std::to_string(version) + " is not supported (this studio reads 1.." +
                                std::to_string(kSceneFormatVersion) + ")");
    const fs::path base = path.parent_path();
    if (!j.contains("volume") || !j.at("volume").is_string()) f.fail("volume", "must be a file name");
    s.volume = resolvedPath(j.at("volume").get<std::string>(), base);
    s.labels = resolvedPath(f.text(j, "labels", ""), base);
    s.shapes = resolvedPath(f.text(j, "shapes", ""), base);
    s.seriesUid = f.text(j, "series", "");
    if (version >= 3) readView(j, s.view, f);
    else readLegacyView(j, s.view, f);
    if (j.contains("crosshair")) s.crosshairMm = f.vec3(j["crosshair"], "crosshair");
    for (uint16_t id : f.ids(j, "hidden_labels", "hidden_labels")) s.hiddenLabels.insert(id);
    for (uint16_t id : f.ids(j, "locked_labels", "locked_labels")) s.lockedLabels.insert(id);
    if (j.contains("deformation")) s.deformation = readDeformation(j, f, base);
    if (j.contains("joints")) s.pose = readJoints(j, f, base);
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
  if (s.pose) {
    fs::path file = path;
    file.replace_extension(".pose.json");
    deformation::savePose(s.pose->pose, file);
    j["joints"] = {{"pose", storedPath(file, base)}};
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
  if (scene.authoring.joints) s.pose = ScenePose{{}, *scene.authoring.joints};
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
