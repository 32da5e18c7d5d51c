#pragma once
// GLSL of the illustration ray caster, specialised with #defines (internal).
#include <string>
#include <vector>

namespace vellum::illustration::detail {

struct ShaderVariant {
  bool eight = true;        ///< EIGHT (central-difference gradients) else NEAREST (forward)
  bool ct = false;          ///< USE_CT: CT value + gradient texture, TF table
  bool texture = false;     ///< USE_TEXTURE: procedural solid textures
  bool textureVolume = false;  ///< USE_TEXVOL
  bool ink = false;         ///< USE_INK: lines and hatching
  int slots = 0;            ///< NSLOTS: per-segment distance fields (four a texel group)
  /// The painter's items whose row can show and the slots that draw ink (paintItems), as
  /// compile-time lists: llvmpipe runs every lane's code whether a branch is taken or not, so
  /// loops over them are unrolled with constant indices (the per-slot arrays stay in
  /// registers) and what no item needs is not compiled at all.
  std::vector<int> items, inkSlots;
  std::string key() const;
};

std::string illustrationFragmentSource(const ShaderVariant& v);

}  // namespace vellum::illustration::detail
