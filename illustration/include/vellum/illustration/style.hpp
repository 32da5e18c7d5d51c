#pragma once
// Illustration styles ([SAVI 2.5] in docs/references.md): one row per segment, combined per sample as
//   I = l1 * I_illum + l2 * I_coloring + l3 * I_solidtex            (RGBA, premultiplied)
//   alpha *= boundary(k_c + k_s * b^k_e) * silhouette(k_c + k_s * (1 - |n.v|)^k_e)
// Every field is described once, in two parameter tables (vellum/core/params.hpp):
// segmentStyleTable() and styleTable(). The JSON reader/validator, the writer, the studio's
// style panel and docs/styles.md are all generated from them.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/params.hpp"

namespace vellum::illustration {

using Rgb = std::array<float, 3>;

enum class SolidTexture { None, Noise, Marble, Wood, Stripes, Stipple, Volume };
enum class IllumMode { Phong, Ct };          ///< Blinn-Phong on the distance normal | CT's TF + CT gradient
enum class BoundaryMeasure { Distance, Ct };  ///< b = 1 - |d|/width | b = |grad CT| / scale
enum class DepthUnits { Fraction, Mm };       ///< of the bounding sphere's diameter | mm from its nearest point

/// One segment's style (a row of the renderer's lookup texture). Defaults: a visible,
/// tone-shaded, white segment with no modulation.
struct SegmentStyle {
  std::string match;  ///< label-table name this row applies to (case-insensitive); see resolveRows
  bool visible = true;
  float lambdaIllum = 0.f, lambdaColouring = 1.f, lambdaTexture = 0.f;
  float opacity = 0.5f;  ///< per mm of ray, like the render module's transfer function alpha
  Rgb colour{1.f, 1.f, 1.f};
  // Gooch tone shading of I_coloring: k = (1 + n.l) / 2, c = k*(warm + beta*colour) + (1-k)*(cool + alpha*colour)
  float toneAmount = 1.f;  ///< 0 = flat colour, 1 = full tone shading
  Rgb toneWarm{0.4f, 0.4f, 0.f}, toneCool{0.f, 0.f, 0.4f};
  float toneAlpha = 0.25f, toneBeta = 0.5f;
  // Depth dimming of I_coloring toward depthColour between two depths along the view, from the
  // nearest point of the volume's bounding sphere: fractions of its diameter, or mm.
  float depthStrength = 0.f, depthStart = 0.3f, depthEnd = 1.f;
  DepthUnits depthUnits = DepthUnits::Fraction;
  Rgb depthColour{1.f, 1.f, 1.f};
  // Solid texture
  SolidTexture texture = SolidTexture::None;
  float textureScaleMm = 8.f;
  Rgb textureColour1{1.f, 1.f, 1.f}, textureColour2{0.f, 0.f, 0.f};
  // Opacity modulation
  BoundaryMeasure boundaryMeasure = BoundaryMeasure::Distance;
  float boundaryWidthMm = 1.5f;    ///< Distance: b = clamp(1 - |d| / width, 0, 1)
  float ctGradientScale = 200.f;   ///< Ct: b = clamp(|grad CT| (HU/mm) / scale, 0, 1)
  float boundaryKc = 1.f, boundaryKs = 0.f, boundaryKe = 1.f;
  float silhouetteKc = 1.f, silhouetteKs = 0.f, silhouetteKe = 1.f;
  // I_illum
  IllumMode illum = IllumMode::Phong;
  float ambient = 0.3f, diffuse = 0.7f, specular = 0.2f, shininess = 24.f;
  // Lit mid-tone anchor: n.l at which I_coloring and the Phong/texture light give `colour`
  // exactly (0 = off: plain Gooch / Phong values).
  float toneKey = 0.f;
  // Ink (screen space): silhouette/contour lines of constant pixel width and hatching by tone.
  float lineWidthPx = 0.f, lineOpacity = 1.f;
  Rgb lineColour{0.f, 0.f, 0.f};
  float hatchSpacingPx = 0.f, hatchWidthPx = 1.f;
  // Crease lines where the surface's normal turns sharply (edges, folds), constant pixel width.
  float creaseWidthPx = 0.f, creaseAngleDeg = 30.f;

  bool operator==(const SegmentStyle&) const = default;
};

/// A whole style: global settings, the label-0 row, a default row and named rows.
struct Style {
  std::string name = "custom";
  std::string description;
  std::array<float, 3> light{-0.4f, 0.5f, 1.f};  ///< camera space: right, up, toward the viewer
  Rgb background{1.f, 1.f, 1.f};                ///< suggested figure background
  std::string ctPreset = "soft-tissue";          ///< render-module TF for IllumMode::Ct rows
  std::string textureVolume;                     ///< volume file for SolidTexture::Volume
  SegmentStyle unclassified;                     ///< label 0 (default invisible)
  SegmentStyle fallback;                         ///< segments no named row matches
  std::vector<SegmentStyle> segments;            ///< matched by label-table name

  Style();
  bool operator==(const Style&) const = default;
};

struct Style;
/// The per-segment fields (JSON keys of a row) and the top-level fields of a style.
const params::Table<SegmentStyle>& segmentStyleTable();
const params::Table<Style>& styleTable();

/// Documentation of one field (generated docs, `--help`): JSON key, meaning, default, range.
struct StyleFieldDoc {
  std::string key, help, defaultValue, range;
  bool perSegment = true;  ///< false: a top-level field of the style
};
const std::vector<StyleFieldDoc>& styleFields();
/// docs/styles.md as generated from the field table and the presets.
std::string styleDocsMarkdown();

/// JSON text <-> style. Errors are vellum::FileError("<source>: <problem>"), one line,
/// naming the key (e.g. "segments[1].opacity: expected a number in [0, 1], got \"x\"").
Style styleFromJson(const std::string& text, const std::string& source = "style");
std::string styleToJson(const Style& style);
Style loadStyle(const std::filesystem::path& path);
void saveStyle(const Style& style, const std::filesystem::path& path);  ///< atomic

/// Built-in presets: textbook, pen, x-ray, dvr, dvr-colour, opacity-modulation.
std::vector<std::string> stylePresetNames();
Style stylePreset(const std::string& name);  ///< throws vellum::Error listing the names

/// Row per label id 0..maxId: id 0 -> unclassified; otherwise the named row whose match
/// equals the label's table name (case-insensitive), else the named row whose match is
/// contained in it ("bone" matches "bone boundary"; longest wins), else fallback.
std::vector<SegmentStyle> resolveRows(const Style& style, const std::vector<Label>& table,
                                      int maxId);

}  // namespace vellum::illustration
