// Styles: the one field table, JSON reading/validation/writing and docs generated from it,
// and the built-in presets.
#include "vellum/illustration/style.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include "vellum/core/error.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::illustration {
namespace {

using nlohmann::json;

/// Thrown by setters; turned into "<source>: <key>: <problem>".
struct FieldProblem {
  std::string what;
};

std::string describe(const json& v) {
  std::string s = v.dump();
  return s.size() > 40 ? s.substr(0, 37) + "..." : s;
}

std::string fmt(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

/// The float as the shortest decimal that reads back to it (0.3f -> 0.3, not 0.30000001).
double shortest(float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::strtod(std::string(buf, r.ptr).c_str(), nullptr);
}

template <class S>
struct Field {
  std::string key, help, range;
  std::function<json(const S&)> get;
  std::function<void(S&, const json&)> set;
};

template <class S>
Field<S> floatField(std::string key, std::string help, float S::*m, float lo, float hi) {
  std::string range = "[" + fmt(lo) + ", " + fmt(hi) + "]";
  return {key, help, range, [m](const S& s) { return json(shortest(s.*m)); },
          [m, lo, hi, range](S& s, const json& v) {
            if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < lo ||
                v.get<double>() > hi)
              throw FieldProblem{"expected a number in " + range + ", got " + describe(v)};
            s.*m = v.get<float>();
          }};
}

template <class S>
Field<S> boolField(std::string key, std::string help, bool S::*m) {
  return {key, help, "true | false", [m](const S& s) { return json(s.*m); },
          [m](S& s, const json& v) {
            if (!v.is_boolean()) throw FieldProblem{"expected true or false, got " + describe(v)};
            s.*m = v.get<bool>();
          }};
}

template <class S>
Field<S> stringField(std::string key, std::string help, std::string S::*m) {
  return {key, help, "text", [m](const S& s) { return json(s.*m); },
          [m](S& s, const json& v) {
            if (!v.is_string()) throw FieldProblem{"expected a string, got " + describe(v)};
            s.*m = v.get<std::string>();
          }};
}

template <class S>
Field<S> colourField(std::string key, std::string help, Rgb S::*m) {
  return {key, help, "[r, g, b] in [0, 1]",
          [m](const S& s) { return json::array({shortest((s.*m)[0]), shortest((s.*m)[1]), shortest((s.*m)[2])}); },
          [m](S& s, const json& v) {
            bool ok = v.is_array() && v.size() == 3;
            for (size_t i = 0; ok && i < 3; ++i)
              ok = v[i].is_number() && v[i].get<double>() >= 0 && v[i].get<double>() <= 1;
            if (!ok) throw FieldProblem{"expected [r, g, b] with each in [0, 1], got " + describe(v)};
            for (size_t i = 0; i < 3; ++i) (s.*m)[i] = v[i].get<float>();
          }};
}

template <class S, class E>
Field<S> enumField(std::string key, std::string help, E S::*m, std::vector<std::string> names) {
  std::string range;
  for (const auto& n : names) range += (range.empty() ? "" : " | ") + n;
  return {key, help, range, [m, names](const S& s) { return json(names[size_t(s.*m)]); },
          [m, names, range](S& s, const json& v) {
            if (v.is_string()) {
              auto it = std::find(names.begin(), names.end(), v.get<std::string>());
              if (it != names.end()) {
                s.*m = E(it - names.begin());
                return;
              }
            }
            throw FieldProblem{"expected one of " + range + ", got " + describe(v)};
          }};
}

template <class S>
Field<S> choiceField(std::string key, std::string help, std::string S::*m, std::vector<std::string> names) {
  std::string range;
  for (const auto& n : names) range += (range.empty() ? "" : " | ") + n;
  return {key, help, range, [m](const S& s) { return json(s.*m); },
          [m, names, range](S& s, const json& v) {
            if (!v.is_string() || std::find(names.begin(), names.end(), v.get<std::string>()) == names.end())
              throw FieldProblem{"expected one of " + range + ", got " + describe(v)};
            s.*m = v.get<std::string>();
          }};
}

// ---- THE table: every style field, once. ----
const std::vector<Field<SegmentStyle>>& segmentFields() {
  using S = SegmentStyle;
  static const std::vector<Field<S>> f = {
      stringField<S>("match", "label-table name this row styles (case-insensitive; a row also matches names that contain it)", &S::match),
      boolField<S>("visible", "draw this segment at all", &S::visible),
      floatField<S>("lambda_illum", "weight l1 of I_illum (Blinn-Phong or the CT's transfer function)", &S::lambdaIllum, 0, 1),
      floatField<S>("lambda_colouring", "weight l2 of I_coloring (tone-shaded, depth-dimmed colour)", &S::lambdaColouring, 0, 1),
      floatField<S>("lambda_texture", "weight l3 of I_solidtex (solid texture)", &S::lambdaTexture, 0, 1),
      floatField<S>("opacity", "opacity per mm of ray (as the render module's transfer functions)", &S::opacity, 0, 1),
      colourField<S>("colour", "segment colour (I_coloring, I_illum in phong mode)", &S::colour),
      floatField<S>("tone_amount", "0 = flat colour, 1 = full Gooch tone shading", &S::toneAmount, 0, 1),
      colourField<S>("tone_warm", "Gooch warm colour (normal faces the light)", &S::warm),
      colourField<S>("tone_cool", "Gooch cool colour (normal faces away from the light)", &S::cool),
      floatField<S>("tone_alpha", "Gooch alpha: share of the segment colour in the cool tone", &S::toneAlpha, 0, 1),
      floatField<S>("tone_beta", "Gooch beta: share of the segment colour in the warm tone", &S::toneBeta, 0, 1),
      floatField<S>("depth_strength", "depth dimming: how far the colour blends to depth_colour at depth_end (0 = off)", &S::dimStrength, 0, 1),
      floatField<S>("depth_start", "depth where dimming starts, from the nearest point of the volume's bounding sphere along the view (see depth_units)", &S::dimStart, 0, 100000),
      floatField<S>("depth_end", "depth where dimming is full (> depth_start)", &S::dimEnd, 0, 100000),
      enumField<S>("depth_units", "fraction: depths are fractions of the bounding sphere's diameter (0 = nearest, 1 = farthest point), at most 1; mm: millimetres",
                   &S::dimUnits, {"fraction", "mm"}),
      colourField<S>("depth_colour", "colour distant parts fade to (usually the background)", &S::dimColour),
      enumField<S>("texture", "solid texture of I_solidtex (volume: the style's texture_volume)", &S::texture,
                   {"none", "noise", "marble", "wood", "stripes", "stipple", "volume"}),
      floatField<S>("texture_scale_mm", "size of one texture feature in mm (volume: mm per texture voxel)", &S::textureScaleMm, 0.05f, 1000),
      colourField<S>("texture_colour1", "texture colour at 0", &S::textureColour1),
      colourField<S>("texture_colour2", "texture colour at 1 (stipple: the dots)", &S::textureColour2),
      enumField<S>("boundary_measure", "b in boundary enhancement: distance = clamp(1 - |d|/boundary_width_mm, 0, 1) (d: shape distance); ct = clamp(|grad CT|/ct_gradient_scale, 0, 1)",
                   &S::boundaryMeasure, {"distance", "ct"}),
      floatField<S>("boundary_width_mm", "width of the distance boundary band in mm", &S::boundaryWidthMm, 0.01f, 100),
      floatField<S>("ct_gradient_scale", "CT gradient magnitude (HU/mm) that counts as a full boundary", &S::ctGradientScale, 1, 100000),
      floatField<S>("boundary_kc", "boundary enhancement k_c: opacity *= k_c + k_s * b^k_e", &S::boundaryKc, 0, 100),
      floatField<S>("boundary_ks", "boundary enhancement k_s", &S::boundaryKs, 0, 100),
      floatField<S>("boundary_ke", "boundary enhancement k_e", &S::boundaryKe, 0.01f, 64),
      floatField<S>("silhouette_kc", "silhouette enhancement k_c: opacity *= k_c + k_s * (1 - |n.v|)^k_e", &S::silhouetteKc, 0, 100),
      floatField<S>("silhouette_ks", "silhouette enhancement k_s", &S::silhouetteKs, 0, 100),
      floatField<S>("silhouette_ke", "silhouette enhancement k_e", &S::silhouetteKe, 0.01f, 64),
      enumField<S>("illum", "I_illum: phong = Blinn-Phong of colour on the distance normal; ct = the CT's transfer function (style ct_preset) shaded on the CT gradient",
                   &S::illum, {"phong", "ct"}),
      floatField<S>("ambient", "ambient term (phong, CT shading and texture shading)", &S::ambient, 0, 1),
      floatField<S>("diffuse", "diffuse term", &S::diffuse, 0, 1),
      floatField<S>("specular", "specular term", &S::specular, 0, 1),
      floatField<S>("shininess", "specular exponent", &S::shininess, 1, 256),
  };
  return f;
}

Field<Style> lightField() {
  return {"light", "light direction in camera space: right, up, toward the viewer (normalised)",
          "[x, y, z], not all 0",
          [](const Style& s) { return json::array({shortest(s.light[0]), shortest(s.light[1]), shortest(s.light[2])}); },
          [](Style& s, const json& v) {
            bool ok = v.is_array() && v.size() == 3;
            for (size_t i = 0; ok && i < 3; ++i) ok = v[i].is_number() && std::isfinite(v[i].get<double>());
            if (ok) ok = std::abs(v[0].get<double>()) + std::abs(v[1].get<double>()) + std::abs(v[2].get<double>()) > 1e-6;
            if (!ok) throw FieldProblem{"expected [x, y, z], finite and not all 0, got " + describe(v)};
            for (size_t i = 0; i < 3; ++i) s.light[i] = v[i].get<float>();
          }};
}

const std::vector<Field<Style>>& globalFields() {
  using S = Style;
  static const std::vector<Field<S>> f = {
      stringField<S>("name", "style name", &S::name),
      stringField<S>("description", "one line for humans", &S::description),
      lightField(),
      colourField<S>("background", "figure background the CLI uses unless --transparent / --background", &S::background),
      choiceField<S>("ct_preset", "render-module transfer function for illum = ct rows", &S::ctPreset,
                     {"bone", "soft-tissue", "skin"}),
      stringField<S>("texture_volume", "volume file (any format io reads) for texture = volume rows; values are normalised to [0, 1] over its range and tiled", &S::textureVolume),
  };
  return f;
}


void readFields(auto& target, const auto& fields, const json& obj, const std::string& where,
                const std::set<std::string>& extraKeys) {
  if (!obj.is_object()) throw FieldProblem{where + ": expected an object, got " + describe(obj)};
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    if (extraKeys.count(it.key())) continue;
    auto f = std::find_if(fields.begin(), fields.end(), [&](const auto& x) { return x.key == it.key(); });
    if (f == fields.end())
      throw FieldProblem{(where.empty() ? "" : where + ".") + it.key() + ": unknown key"};
    try {
      f->set(target, it.value());
    } catch (const FieldProblem& p) {
      throw FieldProblem{(where.empty() ? "" : where + ".") + it.key() + ": " + p.what};
    }
  }
}

SegmentStyle readRow(const json& obj, const std::string& where, SegmentStyle base) {
  readFields(base, segmentFields(), obj, where, {});
  if (base.dimEnd <= base.dimStart && base.dimStrength > 0)
    throw FieldProblem{where + ".depth_end: must be greater than depth_start"};
  if (base.dimUnits == DepthUnits::Fraction && (base.dimStart > 1 || base.dimEnd > 1))
    throw FieldProblem{where + ".depth_start/depth_end: fractions must be in [0, 1] (or set depth_units to \"mm\")"};
  return base;
}

json writeRow(const SegmentStyle& r, bool withMatch) {
  json o = json::object();
  for (const auto& f : segmentFields())
    if (withMatch || f.key != "match") o[f.key] = f.get(r);
  return o;
}

SegmentStyle unclassifiedDefault() {
  SegmentStyle s;
  s.visible = false;
  return s;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

Style::Style() : unclassified(unclassifiedDefault()) {}

const std::vector<StyleFieldDoc>& styleFields() {
  static const std::vector<StyleFieldDoc> docs = [] {
    std::vector<StyleFieldDoc> d;
    const Style defStyle;
    for (const auto& f : globalFields()) d.push_back({f.key, f.help, f.get(defStyle).dump(), f.range, false});
    const SegmentStyle defRow;
    for (const auto& f : segmentFields()) d.push_back({f.key, f.help, f.get(defRow).dump(), f.range, true});
    return d;
  }();
  return docs;
}

Style styleFromJson(const std::string& text, const std::string& source) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    std::string msg = e.what();
    const auto pos = msg.find("parse error");
    throw FileError(source, "malformed JSON: " + (pos == std::string::npos ? msg : msg.substr(pos)));
  }
  Style s;
  try {
    if (!j.is_object()) throw FieldProblem{"expected a JSON object at the top level, got " + describe(j)};
    readFields(s, globalFields(), j, "", {"version", "unclassified", "default", "segments"});
    if (j.contains("version") && !(j["version"].is_number_integer() && j["version"].get<int>() == 1))
      throw FieldProblem{"version: expected 1, got " + describe(j["version"])};
    if (j.contains("unclassified")) s.unclassified = readRow(j["unclassified"], "unclassified", s.unclassified);
    if (j.contains("default")) s.fallback = readRow(j["default"], "default", s.fallback);
    if (j.contains("segments")) {
      const json& segs = j["segments"];
      if (!segs.is_array()) throw FieldProblem{"segments: expected an array, got " + describe(segs)};
      for (size_t i = 0; i < segs.size(); ++i) {
        const std::string where = "segments[" + std::to_string(i) + "]";
        SegmentStyle r = readRow(segs[i], where, SegmentStyle{});
        if (r.match.empty()) throw FieldProblem{where + ".match: required (the segment name this row styles)"};
        s.segments.push_back(r);
      }
    }
  } catch (const FieldProblem& p) {
    throw FileError(source, p.what);
  } catch (const json::exception& e) {  // never crash on odd JSON
    throw FileError(source, std::string("invalid style: ") + e.what());
  }
  return s;
}

std::string styleToJson(const Style& s) {
  json j = json::object();
  j["version"] = 1;
  for (const auto& f : globalFields()) j[f.key] = f.get(s);
  j["unclassified"] = writeRow(s.unclassified, false);
  j["default"] = writeRow(s.fallback, false);
  j["segments"] = json::array();
  for (const auto& r : s.segments) j["segments"].push_back(writeRow(r, true));
  return j.dump(2) + "\n";
}

Style loadStyle(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, std::filesystem::exists(path) ? "cannot be read" : "no such style file");
  std::stringstream ss;
  ss << in.rdbuf();
  Style s = styleFromJson(ss.str(), path.string());
  if (!s.textureVolume.empty() && std::filesystem::path(s.textureVolume).is_relative())
    s.textureVolume = (path.parent_path() / s.textureVolume).string();
  return s;
}

void saveStyle(const Style& style, const std::filesystem::path& path) {
  const std::string text = styleToJson(style);
  io::writeAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    out.close();
    if (!out) throw FileError(path, "could not be written");
  });
}

std::vector<SegmentStyle> resolveRows(const Style& style, const std::vector<Label>& table, int maxId) {
  std::vector<SegmentStyle> rows(static_cast<size_t>(std::max(maxId, 0)) + 1, style.fallback);
  rows[0] = style.unclassified;
  for (int id = 1; id <= maxId; ++id) {
    std::string name;
    for (const auto& l : table)
      if (l.id == id) name = lower(l.name);
    if (name.empty()) continue;
    const SegmentStyle* best = nullptr;
    size_t bestLen = 0;
    for (const auto& r : style.segments) {
      const std::string m = lower(r.match);
      if (m == name) {
        best = &r;
        break;
      }
      if (!m.empty() && name.find(m) != std::string::npos && m.size() > bestLen) {
        best = &r;
        bestLen = m.size();
      }
    }
    if (best) rows[size_t(id)] = *best;
  }
  return rows;
}

// ---- Presets ----
namespace {

SegmentStyle row(const std::string& match, Rgb colour, float opacity) {
  SegmentStyle r;
  r.match = match;
  r.colour = colour;
  r.opacity = opacity;
  return r;
}

void tone(SegmentStyle& r, Rgb warm, Rgb cool, float alpha, float beta) {
  r.warm = warm;
  r.cool = cool;
  r.toneAlpha = alpha;
  r.toneBeta = beta;
}

void silhouette(SegmentStyle& r, float kc, float ks, float ke) {
  r.silhouetteKc = kc;
  r.silhouetteKs = ks;
  r.silhouetteKe = ke;
}

void boundary(SegmentStyle& r, float kc, float ks, float ke) {
  r.boundaryKc = kc;
  r.boundaryKs = ks;
  r.boundaryKe = ke;
}

void dim(SegmentStyle& r, float strength, Rgb colour) {
  r.dimStrength = strength;
  r.dimStart = 0.35f;
  r.dimEnd = 0.9f;
  r.dimColour = colour;
}

Style textbook() {
  Style s;
  s.name = "textbook";
  s.description = "anatomy-textbook plate: ivory tone-shaded bone, red muscle with silhouettes, a faint skin outline";
  const Rgb paper{0.97f, 0.95f, 0.90f};
  s.background = paper;
  auto bone = row("bone", {0.93f, 0.89f, 0.78f}, 1.0f);
  tone(bone, {0.30f, 0.25f, 0.05f}, {0.06f, 0.07f, 0.22f}, 0.55f, 0.75f);
  bone.lambdaColouring = 0.85f;
  bone.lambdaIllum = 0.15f;
  bone.colour = {0.93f, 0.89f, 0.78f};
  dim(bone, 0.35f, paper);
  auto marrow = bone;
  marrow.match = "marrow";
  marrow.colour = {0.85f, 0.62f, 0.45f};
  auto cartilage = row("cartilage", {0.62f, 0.76f, 0.86f}, 0.6f);
  tone(cartilage, {0.25f, 0.25f, 0.1f}, {0.0f, 0.05f, 0.25f}, 0.5f, 0.7f);
  // Light enough to show the bone through ~15 cm of muscle; a moderate silhouette gain, since
  // a high one also picks up the voxel staircase where muscle meets bone.
  auto muscle = row("muscle", {0.78f, 0.13f, 0.11f}, 0.012f);
  tone(muscle, {0.30f, 0.10f, 0.0f}, {0.05f, 0.0f, 0.15f}, 0.5f, 0.7f);
  silhouette(muscle, 0.3f, 4.f, 4.f);
  dim(muscle, 0.3f, paper);
  auto skin = row("skin", {0.80f, 0.62f, 0.52f}, 0.03f);
  tone(skin, {0.2f, 0.1f, 0.0f}, {0.0f, 0.0f, 0.1f}, 0.6f, 0.7f);
  silhouette(skin, 0.0f, 3.f, 8.f);
  auto fat = row("fat", {0.95f, 0.85f, 0.45f}, 0.02f);
  silhouette(fat, 0.0f, 2.f, 6.f);
  auto vessel = row("vessel", {0.75f, 0.08f, 0.10f}, 0.8f);
  tone(vessel, {0.3f, 0.05f, 0.0f}, {0.05f, 0.0f, 0.2f}, 0.5f, 0.8f);
  auto vein = row("vein", {0.18f, 0.28f, 0.70f}, 0.8f);
  s.fallback = row("", {0.80f, 0.74f, 0.62f}, 0.3f);
  silhouette(s.fallback, 0.5f, 3.f, 3.f);
  s.segments = {bone, marrow, cartilage, muscle, skin, fat, vessel, vein};
  return s;
}

Style pen() {
  Style s;
  s.name = "pen";
  s.description = "monochrome pen drawing: dark silhouette and boundary lines over white, stippled shading";
  s.background = {1.f, 1.f, 1.f};
  // Ink: a grey that tone shading darkens to near black away from the light; opacity only
  // near surfaces (boundary k_c = 0) and mostly at silhouettes.
  SegmentStyle r = row("", {0.35f, 0.35f, 0.35f}, 0.6f);
  tone(r, {0.55f, 0.55f, 0.55f}, {0.f, 0.f, 0.f}, 0.1f, 0.6f);
  r.lambdaColouring = 0.7f;
  r.lambdaTexture = 0.3f;
  r.texture = SolidTexture::Stipple;
  r.textureScaleMm = 1.2f;
  r.textureColour1 = {1.f, 1.f, 1.f};
  r.textureColour2 = {0.05f, 0.05f, 0.05f};
  r.boundaryWidthMm = 1.0f;
  boundary(r, 0.0f, 1.f, 1.f);
  silhouette(r, 0.04f, 10.f, 4.f);
  s.fallback = r;
  auto skin = r;
  skin.match = "skin";
  skin.lambdaTexture = 0;
  skin.lambdaColouring = 1;
  skin.colour = {0.2f, 0.2f, 0.2f};
  silhouette(skin, 0.0f, 10.f, 8.f);
  s.segments = {skin};
  return s;
}

Style xray() {
  Style s;
  s.name = "x-ray";
  s.description = "radiograph look: translucent blue-white structures on black, boundaries glow";
  s.background = {0.02f, 0.03f, 0.05f};
  SegmentStyle r = row("", {0.75f, 0.85f, 1.0f}, 0.05f);
  r.toneAmount = 0;
  boundary(r, 0.3f, 2.f, 1.f);
  silhouette(r, 0.6f, 2.f, 2.f);
  s.fallback = r;
  auto bone = r;
  bone.match = "bone";
  bone.colour = {0.95f, 0.97f, 1.0f};
  bone.opacity = 0.12f;
  auto skin = r;
  skin.match = "skin";
  skin.opacity = 0.01f;
  s.segments = {bone, skin};
  return s;
}

Style dvr() {
  Style s;
  s.name = "dvr";
  s.description = "plain DVR of the CT (its transfer function and gradient), for the comparison plate";
  s.background = {0.f, 0.f, 0.f};
  SegmentStyle r;
  r.illum = IllumMode::Ct;
  r.lambdaIllum = 1;
  r.lambdaColouring = 0;
  s.unclassified = r;
  s.fallback = r;
  return s;
}

Style dvrColour() {
  Style s = textbook();
  s.name = "dvr-colour";
  s.description = "colour shading only: per-segment tone-shaded colours, no opacity modulation (comparison plate)";
  s.background = {0.f, 0.f, 0.f};
  for (auto* r : {&s.fallback}) *r = row("", {0.80f, 0.74f, 0.62f}, 0.3f);
  for (auto& r : s.segments) {
    silhouette(r, 1, 0, 1);
    boundary(r, 1, 0, 1);
    r.dimStrength = 0;
    r.opacity = std::max(r.opacity, 0.15f);
  }
  return s;
}

Style opacityModulation() {
  Style s = dvrColour();
  s.name = "opacity-modulation";
  s.description = "colour shading plus boundary and silhouette opacity modulation (comparison plate)";
  auto mod = [](SegmentStyle& r) {
    boundary(r, 0.15f, 1.5f, 1.f);
    silhouette(r, 0.3f, 4.f, 3.f);
  };
  mod(s.fallback);
  for (auto& r : s.segments)
    if (lower(r.match) != "bone") mod(r);
  return s;
}

}  // namespace

std::vector<std::string> stylePresetNames() {
  return {"textbook", "pen", "x-ray", "dvr", "dvr-colour", "opacity-modulation"};
}

Style stylePreset(const std::string& name) {
  if (name == "textbook") return textbook();
  if (name == "pen") return pen();
  if (name == "x-ray" || name == "xray") return xray();
  if (name == "dvr") return dvr();
  if (name == "dvr-colour") return dvrColour();
  if (name == "opacity-modulation") return opacityModulation();
  std::string names;
  for (const auto& n : stylePresetNames()) names += (names.empty() ? "" : ", ") + n;
  throw Error("unknown style preset '" + name + "' (valid: " + names + ")");
}

std::string styleDocsMarkdown() {
  std::ostringstream o;
  o << "# Illustration styles\n\n"
    << "<!-- Generated from the field table in illustration/src/style.cpp by the test\n"
    << "     IllustrationStyle.DocsUpToDate (VELLUM_REGEN_DOCS=1 rewrites it). Do not edit. -->\n\n"
    << "`vellum illustrate IN --shape DIR --style S.json` (or `--preset NAME`) renders a shape folder\n"
    << "with a style: one row per segment, combined per ray sample as\n\n"
    << "    I = lambda_illum * I_illum + lambda_colouring * I_coloring + lambda_texture * I_solidtex   (RGBA)\n"
    << "    alpha = that alpha * (boundary_kc + boundary_ks * b^boundary_ke)\n"
    << "                       * (silhouette_kc + silhouette_ks * (1 - |n.v|)^silhouette_ke)\n\n"
    << "n is the unit gradient of the shape's signed distance (outward), v the direction to the eye,\n"
    << "l the style's light. I_coloring = Gooch tone shading of `colour` (k = (1 + n.l)/2;\n"
    << "k * (tone_warm + tone_beta * colour) + (1 - k) * (tone_cool + tone_alpha * colour), mixed with the\n"
    << "flat colour by tone_amount), then depth-dimmed. I_illum = Blinn-Phong of `colour` on n, or\n"
    << "(illum = ct) the CT's transfer function (ct_preset) shaded on the CT gradient. I_solidtex = the\n"
    << "solid texture's colour, diffusely lit. Opacity is per mm of ray. b: see boundary_measure\n"
    << "(default: the distance band, since |grad d| = 1 everywhere for a distance field).\n\n"
    << "A style file is JSON: the top-level fields below, `unclassified` (the row of label 0),\n"
    << "`default` (segments no row matches) and `segments` (rows with `match`). Omitted fields take\n"
    << "their defaults; unknown keys and out-of-range values are errors naming the key.\n\n"
    << "## Top-level fields\n\n| key | meaning | default | range |\n|---|---|---|---|\n";
  for (const auto& f : styleFields())
    if (!f.perSegment) o << "| `" << f.key << "` | " << f.help << " | `" << f.defaultValue << "` | " << f.range << " |\n";
  o << "\n## Segment row fields\n\n| key | meaning | default | range |\n|---|---|---|---|\n";
  for (const auto& f : styleFields())
    if (f.perSegment) o << "| `" << f.key << "` | " << f.help << " | `" << f.defaultValue << "` | " << f.range << " |\n";
  o << "\n`unclassified` defaults to the same values with `visible: false`.\n\n## Presets\n\n";
  for (const auto& n : stylePresetNames()) {
    const Style s = stylePreset(n);
    o << "- `" << n << "`: " << s.description << ".";
    if (!s.segments.empty()) {
      o << " Rows:";
      for (size_t i = 0; i < s.segments.size(); ++i) o << (i ? ", " : " ") << s.segments[i].match;
      o << ".";
    }
    o << "\n";
  }
  o << "\n`vellum illustrate ... --preset NAME --save-style S.json` writes a preset as a starting point.\n";
  return o.str();
}

}  // namespace vellum::illustration
