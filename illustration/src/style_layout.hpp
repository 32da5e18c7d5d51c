#pragma once
// The style table's GPU layout (internal), named once: each segment's row is STYLE_ROW_TEXELS
// RGBA float texels, and VELLUM_STYLE_SLOTS says what every slot holds. The packer
// (packStyle), the CPU reference (StyleRow) and the shader (styleLayoutGlsl(): one
// STYLE_<SLOT>(row) macro per slot) are all generated from it, so none reads by position.
#include <string>
#include <type_traits>

#include "vellum/illustration/style.hpp"

namespace vellum::illustration::detail {

// X(Name, texel, component, type, style key, meaning). type: float, Rgb (3 components), bool
// (stored 0/1), or an enum (stored as its value; its choices become GLSL constants named after
// the style key, e.g. TEXTURE_VOLUME). style key: the segmentStyleTable() field it packs ("":
// derived). Types are qualified where a slot shares the enum's name.
#define VELLUM_STYLE_SLOTS(X)                                                                          \
  X(Colour, 0, 0, Rgb, "colour", "segment colour")                                                     \
  X(Opacity, 0, 3, float, "opacity", "alpha per mm")                                                   \
  X(LambdaIllum, 1, 0, float, "lambda_illum", "weight l1 of I_illum")                                  \
  X(LambdaColouring, 1, 1, float, "lambda_colouring", "weight l2 of I_coloring")                       \
  X(LambdaTexture, 1, 2, float, "lambda_texture", "weight l3 of I_solidtex")                           \
  X(Visible, 1, 3, bool, "", "the row can show: visible, some weight and some opacity")                \
  X(ToneWarm, 2, 0, Rgb, "tone_warm", "Gooch warm tone")                                               \
  X(ToneBeta, 2, 3, float, "tone_beta", "share of the colour in the warm tone")                        \
  X(ToneCool, 3, 0, Rgb, "tone_cool", "Gooch cool tone")                                               \
  X(ToneAlpha, 3, 3, float, "tone_alpha", "share of the colour in the cool tone")                      \
  X(DepthColour, 4, 0, Rgb, "depth_colour", "colour distant parts fade to")                            \
  X(DepthStrength, 4, 3, float, "depth_strength", "how far they fade")                                 \
  X(DepthStart, 5, 0, float, "depth_start", "as a fraction of the bounding sphere's diameter")         \
  X(DepthEnd, 5, 1, float, "depth_end", "as a fraction of the bounding sphere's diameter")             \
  X(ToneAmount, 5, 2, float, "tone_amount", "0 flat colour, 1 full tone shading")                      \
  X(Texture, 5, 3, SolidTexture, "texture", "solid texture kind")                                      \
  X(TextureColour1, 6, 0, Rgb, "texture_colour1", "texture colour at 0")                               \
  X(TextureScaleMm, 6, 3, float, "texture_scale_mm", "size of one texture feature")                    \
  X(TextureColour2, 7, 0, Rgb, "texture_colour2", "texture colour at 1")                               \
  X(BoundaryMeasure, 7, 3, illustration::BoundaryMeasure, "boundary_measure", "what b measures")       \
  X(BoundaryKc, 8, 0, float, "boundary_kc", "boundary enhancement k_c")                                \
  X(BoundaryKs, 8, 1, float, "boundary_ks", "boundary enhancement k_s")                                \
  X(BoundaryKe, 8, 2, float, "boundary_ke", "boundary enhancement k_e")                                \
  X(BoundaryWidthMm, 8, 3, float, "boundary_width_mm", "width of the distance boundary band")          \
  X(SilhouetteKc, 9, 0, float, "silhouette_kc", "silhouette enhancement k_c")                          \
  X(SilhouetteKs, 9, 1, float, "silhouette_ks", "silhouette enhancement k_s")                          \
  X(SilhouetteKe, 9, 2, float, "silhouette_ke", "silhouette enhancement k_e")                          \
  X(CtGradientScale, 9, 3, float, "ct_gradient_scale", "|grad CT| that counts as a full boundary")     \
  X(Ambient, 10, 0, float, "ambient", "Blinn-Phong ambient")                                           \
  X(Diffuse, 10, 1, float, "diffuse", "Blinn-Phong diffuse")                                           \
  X(Specular, 10, 2, float, "specular", "Blinn-Phong specular")                                        \
  X(Shininess, 10, 3, float, "shininess", "Blinn-Phong exponent")                                      \
  X(Illum, 11, 0, IllumMode, "illum", "what I_illum shades")                                          \
  X(ToneKey, 11, 1, float, "tone_key", "n.l of the lit mid-tone that shows the colour (0 off)")       \
  X(LineWidthPx, 11, 2, float, "line_width_px", "ink line width in pixels (0 none)")                   \
  X(LineOpacity, 11, 3, float, "line_opacity", "ink opacity")                                          \
  X(LineColour, 12, 0, Rgb, "line_colour", "ink colour")                                               \
  X(HatchSpacingPx, 12, 3, float, "hatch_spacing_px", "hatching stroke spacing in pixels (0 none)")    \
  X(HatchWidthPx, 13, 0, float, "hatch_width_px", "hatching stroke width at full darkness")            \
  X(Ink, 13, 1, bool, "", "the row draws ink: lines, hatching or creases")                            \
  X(CreaseWidthPx, 13, 2, float, "crease_width_px", "crease line width in pixels (0 none)")              \
  X(CreaseAngleDeg, 13, 3, float, "crease_angle_deg", "normal turn that starts a crease line")

/// One slot: where a value of type T sits in a row (floats from the row's start).
template <class T>
struct Slot {
  int texel, component;
  constexpr int offset() const { return texel * 4 + component; }
};

namespace slot {
#define VELLUM_STYLE_SLOT(name, texel, component, type, key, meaning) \
  inline constexpr Slot<type> name{texel, component};
VELLUM_STYLE_SLOTS(VELLUM_STYLE_SLOT)
#undef VELLUM_STYLE_SLOT
}  // namespace slot

/// Every slot's place and width, for the checks below and the GLSL generator.
struct SlotInfo {
  const char* name;
  int texel, component, width;
  bool isRgb, isBool, isEnum;
  const char* key;
  const char* meaning;
};
template <class T>
constexpr SlotInfo slotInfo(const char* name, int texel, int component, const char* key, const char* meaning) {
  return {name, texel, component, std::is_same_v<T, Rgb> ? 3 : 1, std::is_same_v<T, Rgb>, std::is_same_v<T, bool>,
          std::is_enum_v<T>, key, meaning};
}
inline constexpr SlotInfo kStyleSlots[] = {
#define VELLUM_STYLE_SLOT(name, texel, component, type, key, meaning) \
  slotInfo<type>(#name, texel, component, key, meaning),
    VELLUM_STYLE_SLOTS(VELLUM_STYLE_SLOT)
#undef VELLUM_STYLE_SLOT
};

/// Texels (RGBA float) per style row: as many as the slots use.
constexpr int kRowTexels = [] {
  int n = 0;
  for (const SlotInfo& s : kStyleSlots) n = s.texel + 1 > n ? s.texel + 1 : n;
  return n;
}();

// No slot overlaps another or leaves its texel.
static_assert([] {
  bool used[kRowTexels * 4] = {};
  for (const SlotInfo& s : kStyleSlots) {
    if (s.component + s.width > 4) return false;
    for (int c = 0; c < s.width; ++c) {
      if (used[s.texel * 4 + s.component + c]) return false;
      used[s.texel * 4 + s.component + c] = true;
    }
  }
  return true;
}());

/// Read view of one packed row (the CPU reference's side of the shader's STYLE_* macros).
class StyleRow {
 public:
  explicit StyleRow(const float* p) : p_(p) {}
  float operator[](Slot<float> s) const { return p_[s.offset()]; }
  const float* operator[](Slot<Rgb> s) const { return p_ + s.offset(); }  ///< 3 floats
  bool operator[](Slot<bool> s) const { return p_[s.offset()] > 0.5f; }
  template <class E>
    requires std::is_enum_v<E>
  E operator[](Slot<E> s) const {
    return E(int(p_[s.offset()] + 0.5f));
  }

 private:
  const float* p_;
};

/// Writes into one row (kRowTexels * 4 floats).
inline void put(float* row, Slot<float> s, float v) { row[s.offset()] = v; }
inline void put(float* row, Slot<Rgb> s, const Rgb& v) {
  for (int c = 0; c < 3; ++c) row[s.offset() + c] = v[size_t(c)];
}
inline void put(float* row, Slot<bool> s, bool v) { row[s.offset()] = v ? 1.f : 0.f; }
template <class E>
  requires std::is_enum_v<E>
void put(float* row, Slot<E> s, E v) {
  row[s.offset()] = float(int(v));
}

/// GLSL for the shader: STYLE_ROW_TEXELS; per slot STYLE_<SLOT>(r) reading a loaded
/// `struct Row { vec4 t[STYLE_ROW_TEXELS]; }` and STYLE_<SLOT>_AT(label) fetching from the
/// uStyle texture (bools as bool, enums as int); per enum choice <KEY>_<CHOICE> (its value).
std::string styleLayoutGlsl();

}  // namespace vellum::illustration::detail
