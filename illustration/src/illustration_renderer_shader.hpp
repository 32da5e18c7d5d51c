#pragma once
// GLSL of the illustration ray caster, specialised with #defines (internal).
#include <string>

namespace vellum::illustration::detail {

struct ShaderVariant {
  bool eight = true;        ///< EIGHT (central-difference gradients) else NEAREST (forward)
  bool ct = false;          ///< USE_CT: CT value + gradient texture, TF table
  bool texture = false;     ///< USE_TEXTURE: procedural solid textures
  bool textureVolume = false;  ///< USE_TEXVOL
  bool ink = false;         ///< USE_INK: lines and hatching
  int slots = 0;            ///< NSLOTS: per-segment distance fields (four a texel group)
  int key() const { return int(eight) | int(ct) << 1 | int(texture) << 2 | int(textureVolume) << 3 | int(ink) << 4 | slots << 5; }
};

std::string illustrationFragmentSource(const ShaderVariant& v);

}  // namespace vellum::illustration::detail
