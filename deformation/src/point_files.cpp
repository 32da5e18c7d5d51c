#include "vellum/deformation/point_files.hpp"

#include <nlohmann/json.hpp>

#include <cmath>

#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::deformation {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// kMaxControlPoints points are about 15 MB of JSON; a keyframe track holds several such sets.
constexpr uint64_t kMaxPointFileBytes = 64u << 20;
constexpr uint64_t kMaxKeyframeFileBytes = 512u << 20;

void writeJson(const json& j, const fs::path& path) { io::writeTextFile(path, j.dump(2) + "\n"); }

Vec3 readVec(const json& j, const char* key, const fs::path& path, const std::string& where) {
  if (!j.contains(key)) throw FileError(path, where + "missing \"" + key + "\"");
  const json& v = j.at(key);
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
    throw FileError(path, where + "\"" + key + "\" must be [x, y, z] in mm");
  const Vec3 r{v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
  if (!isFinite(r)) throw FileError(path, where + "\"" + key + "\" is not finite");
  return r;
}

// `context`: "" for a point file, "keyframe K: " inside a keyframe file.
ControlPoints readPoints(const json& arr, const fs::path& path, const std::string& context = "") {
  if (!arr.is_array() || arr.empty()) throw FileError(path, context + "\"points\" must be a non-empty array");
  if (arr.size() > kMaxControlPoints)
    throw FileError(path, context + "\"points\" has " + std::to_string(arr.size()) + " entries; at most " +
                              std::to_string(kMaxControlPoints) + " control points are supported");
  ControlPoints pts;
  for (size_t i = 0; i < arr.size(); ++i) {
    const json& p = arr[i];
    const std::string where = context + "point " + std::to_string(i) + ": ";
    if (!p.is_object()) throw FileError(path, context + "point " + std::to_string(i) + " is not an object");
    ControlPoint cp;
    cp.source = readVec(p, "source", path, where);
    cp.target = p.contains("target") ? readVec(p, "target", path, where) : cp.source;
    if (p.contains("attributes")) {
      const json& a = p.at("attributes");
      if (!a.is_object()) throw FileError(path, where + "\"attributes\" must be an object");
      auto num = [&](const char* k, double def) {
        if (!a.contains(k)) return def;
        if (!a.at(k).is_number() || !std::isfinite(a.at(k).get<double>()))
          throw FileError(path, where + "attribute \"" + k + "\" must be a finite number");
        return a.at(k).get<double>();
      };
      cp.attributes = {num("lightness", 0), num("a", 0), num("b", 0), num("density", 1)};
    }
    pts.push_back(cp);
  }
  return pts;
}

json writePoints(const ControlPoints& pts) {
  json arr = json::array();
  for (const auto& p : pts) {
    json o{{"source", {p.source.x, p.source.y, p.source.z}},
           {"target", {p.target.x, p.target.y, p.target.z}}};
    if (!p.attributes.isDefault())
      o["attributes"] = {{"lightness", p.attributes.lightness}, {"a", p.attributes.a},
                         {"b", p.attributes.b}, {"density", p.attributes.density}};
    arr.push_back(o);
  }
  return arr;
}

void checkUnits(const json& j, const fs::path& path) {
  if (j.contains("units") && !(j.at("units").is_string() && j.at("units").get<std::string>() == "mm"))
    throw FileError(path, "\"units\" must be \"mm\"");
}

}  // namespace

PointFile loadControlPoints(const fs::path& path) {
  const json j = readJsonFile(path, kMaxPointFileBytes, "control-point file");
  if (!j.is_object()) throw FileError(path, "expected a JSON object with \"points\"");
  checkUnits(j, path);
  PointFile f;
  if (!j.contains("points")) throw FileError(path, "missing \"points\"");
  f.points = readPoints(j.at("points"), path);
  if (j.contains("power")) {
    // The engine's range for the MLS power, from its parameter table.
    const auto* power = params::findField(mlsParamsTable(), "power");
    MlsParams probe;
    if (j.at("power").is_number()) probe.power = j.at("power").get<double>();
    if (!j.at("power").is_number() || !(probe.power >= power->info.min && probe.power <= power->info.max))
      throw FileError(path, "\"power\" must be a number in " + params::rangeText(power->kind, power->info, {}));
    f.power = probe.power;
  }
  return f;
}

void saveControlPoints(const PointFile& file, const fs::path& path) {
  json j{{"units", "mm"}, {"points", writePoints(file.points)}};
  if (file.power) j["power"] = *file.power;
  writeJson(j, path);
}

/// A keyframe's "camera": {"azimuth", "elevation", "zoom", "pan": [x, y, z], "fov"} (any subset;
/// the ranges of `vellum render`'s camera flags).
static KeyframeCamera readCamera(const json& c, const fs::path& path, const std::string& where) {
  if (!c.is_object()) throw FileError(path, where + "\"camera\" must be an object");
  KeyframeCamera cam;
  const auto number = [&](const char* key, double& out, double lo, double hi) {
    if (!c.contains(key)) return;
    const json& v = c.at(key);
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < lo || v.get<double>() > hi)
      throw FileError(path, where + "\"camera\".\"" + key + "\" must be a number in " + std::to_string(int(lo)) +
                                ".." + std::to_string(int(hi)));
    out = v.get<double>();
  };
  number("azimuth", cam.azimuthDeg, -3600, 3600);
  number("elevation", cam.elevationDeg, -90, 90);
  if (c.contains("zoom")) {  // 0.05..50, not an integer range
    const json& v = c.at("zoom");
    if (!v.is_number() || !(v.get<double>() >= 0.05 && v.get<double>() <= 50))
      throw FileError(path, where + "\"camera\".\"zoom\" must be a number in 0.05..50");
    cam.zoom = v.get<double>();
  }
  if (c.contains("fov")) {  // degrees, 0 = orthographic
    const json& v = c.at("fov");
    if (!v.is_number() || !(v.get<double>() >= 0 && v.get<double>() <= kMaxKeyframeFieldOfViewDeg))
      throw FileError(path, where + "\"camera\".\"fov\" must be a number in 0.." +
                                std::to_string(int(kMaxKeyframeFieldOfViewDeg)) + " (degrees, 0 = orthographic)");
    cam.fieldOfViewDeg = v.get<double>();
  }
  if (c.contains("pan")) {
    const json& v = c.at("pan");
    bool ok = v.is_array() && v.size() == 3;
    for (size_t i = 0; ok && i < 3; ++i) ok = v[i].is_number() && std::isfinite(v[i].get<double>());
    if (!ok) throw FileError(path, where + "\"camera\".\"pan\" must be [x, y, z] in mm");
    cam.panMm = {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
  }
  for (auto it = c.begin(); it != c.end(); ++it)
    if (it.key() != "azimuth" && it.key() != "elevation" && it.key() != "zoom" && it.key() != "pan" &&
        it.key() != "fov")
      throw FileError(path, where + "\"camera\" has an unknown key \"" + it.key() + "\"");
  return cam;
}

void readTrackSettings(const json& j, const fs::path& path, KeyframeTrack& t) {
  if (j.contains("interpolation")) {
    if (!j.at("interpolation").is_string()) throw FileError(path, "\"interpolation\" must be linear, smooth or eased");
    try {
      t.interpolation = parseInterpolation(j.at("interpolation").get<std::string>());
    } catch (const Error& e) {
      throw FileError(path, std::string("\"interpolation\": ") + e.what());
    }
  }
  if (j.contains("loop")) {
    if (!j.at("loop").is_boolean()) throw FileError(path, "\"loop\" must be true or false");
    t.loop = j.at("loop").get<bool>();
  }
  if (!j.contains("keyframes") || !j.at("keyframes").is_array() || j.at("keyframes").empty())
    throw FileError(path, "\"keyframes\" must be a non-empty array");
  if (j.at("keyframes").size() > kMaxKeyframes)
    throw FileError(path, "\"keyframes\" has " + std::to_string(j.at("keyframes").size()) + " entries; at most " +
                              std::to_string(kMaxKeyframes) + " are supported");
}

KeyframeTrack loadKeyframes(const fs::path& path) {
  const json j = readJsonFile(path, kMaxKeyframeFileBytes, "keyframe file");
  if (!j.is_object()) throw FileError(path, "expected a JSON object with \"keyframes\"");
  checkUnits(j, path);
  KeyframeTrack t;
  readTrackSettings(j, path, t);
  for (const json& k : j.at("keyframes")) {
    const std::string where = "keyframe " + std::to_string(t.keyframes.size()) + ": ";
    if (!k.is_object()) throw FileError(path, where + "not an object");
    Keyframe kf;
    if (k.contains("duration")) {
      if (!k.at("duration").is_number()) throw FileError(path, where + "\"duration\" must be a number (s)");
      kf.durationS = k.at("duration").get<double>();
    }
    if (!k.contains("points")) throw FileError(path, where + "missing \"points\"");
    kf.points = readPoints(k.at("points"), path, where);
    if (k.contains("camera")) kf.camera = readCamera(k.at("camera"), path, where);
    if (k.contains("caption")) {
      if (!k.at("caption").is_string() || k.at("caption").get<std::string>().size() > kMaxCaptionLength)
        throw FileError(path, where + "\"caption\" must be a string of at most " + std::to_string(kMaxCaptionLength) +
                                  " bytes");
      kf.caption = k.at("caption").get<std::string>();
    }
    t.keyframes.push_back(std::move(kf));
  }
  try {
    t.validate();
  } catch (const Error& e) {
    throw FileError(path, e.what());
  }
  return t;
}

void saveKeyframes(const KeyframeTrack& track, const fs::path& path) {
  json arr = json::array();
  for (const auto& kf : track.keyframes) {
    json k = {{"duration", kf.durationS}, {"points", writePoints(kf.points)}};
    if (kf.camera) {
      k["camera"] = {{"azimuth", kf.camera->azimuthDeg}, {"elevation", kf.camera->elevationDeg},
                     {"zoom", kf.camera->zoom}, {"pan", {kf.camera->panMm.x, kf.camera->panMm.y, kf.camera->panMm.z}}};
      if (kf.camera->fieldOfViewDeg) k["camera"]["fov"] = *kf.camera->fieldOfViewDeg;
    }
    if (!kf.caption.empty()) k["caption"] = kf.caption;
    arr.push_back(std::move(k));
  }
  writeJson({{"units", "mm"}, {"interpolation", interpolationName(track.interpolation)},
             {"loop", track.loop}, {"keyframes", arr}}, path);
}

}  // namespace vellum::deformation
