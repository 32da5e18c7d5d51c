// The shader's side of the style layout, generated from VELLUM_STYLE_SLOTS.
#include "style_layout.hpp"

#include <cctype>
#include <sstream>

#include "vellum/core/error.hpp"

namespace vellum::illustration::detail {
namespace {

/// "ToneWarm" -> "TONE_WARM", "boundary_measure" -> "BOUNDARY_MEASURE".
std::string macroName(const std::string& name) {
  std::string s;
  for (size_t i = 0; i < name.size(); ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (std::isupper(c) && i > 0) s += '_';
    s += std::isalnum(c) ? char(std::toupper(c)) : '_';
  }
  return s;
}

/// GLSL reading slot s from a vec4 expression: bools as bool, enums as int.
std::string readSlot(const SlotInfo& s, const std::string& texel) {
  const std::string v = texel + "." + std::string("xyzw").substr(size_t(s.component), size_t(s.width));
  if (s.isBool) return "(" + v + " > 0.5)";
  if (s.isEnum) return "int(" + v + " + 0.5)";
  return "(" + v + ")";
}

}  // namespace

std::string styleLayoutGlsl() {
  std::ostringstream s;
  s << "// Style row layout, generated from VELLUM_STYLE_SLOTS (style_layout.hpp).\n";
  s << "#define STYLE_ROW_TEXELS " << kRowTexels << "\n";
  for (const SlotInfo& slot : kStyleSlots) {
    const std::string name = "STYLE_" + macroName(slot.name), texel = std::to_string(slot.texel);
    s << "// " << (*slot.key ? slot.key : "(derived)") << ": " << slot.meaning << "\n";
    s << "#define " << name << "(r) " << readSlot(slot, "(r).t[" + texel + "]") << "\n";
    s << "#define " << name << "_AT(label) " << readSlot(slot, "texelFetch(uStyle, ivec2(" + texel + ", (label)), 0)")
      << "\n";
    if (!slot.isEnum) continue;
    // The choices, in enum order, as the style file names them.
    const auto* field = params::findField(segmentStyleTable(), slot.key);
    if (!field || field->choices.empty()) throw Error(std::string("style slot ") + slot.name + ": no choice field " + slot.key);
    for (size_t i = 0; i < field->choices.size(); ++i)
      s << "#define " << macroName(slot.key) << "_" << macroName(field->choices[i]) << " " << i << "\n";
  }
  return s.str();
}

}  // namespace vellum::illustration::detail
