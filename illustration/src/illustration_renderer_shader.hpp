#pragma once
// GLSL of the illustration ray caster, specialised with #defines (internal).
#include <string>

namespace vellum::illustration::detail {

struct ShaderVariant {
  bool eight = true;        ///< EIGHT (8 voxel centres) else NEAREST
  bool ct = false;          ///< USE_CT: CT value + gradient texture, TF table
  bool texture = false;     ///< USE_TEXTURE: procedural solid textures
  bool textureVolume = false;  ///< USE_TEXVOL
  int key() const { return int(eight) | int(ct) << 1 | int(texture) << 2 | int(textureVolume) << 3; }
};

std::string illustrationFragmentSource(const ShaderVariant& v);

}  // namespace vellum::illustration::detail
