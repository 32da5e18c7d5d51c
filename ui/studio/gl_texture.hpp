#pragma once
// An RGBA8 2D texture holding a CPU image (slice or 3D render) for ImGui to draw.
#include <cstddef>  // vellum/core/image.hpp uses size_t without including it
#include <cstdint>

#include "vellum/core/image.hpp"

namespace vellum::studio {

class GlTexture {
 public:
  GlTexture() = default;
  ~GlTexture();
  GlTexture(const GlTexture&) = delete;
  GlTexture& operator=(const GlTexture&) = delete;
  /// Uploads (re-allocating only when the size changes). Needs a current GL context.
  void upload(const RgbaImage& image);
  unsigned id() const { return id_; }
  int width() const { return width_; }
  int height() const { return height_; }
  bool valid() const { return id_ != 0 && width_ > 0; }

 private:
  unsigned id_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace vellum::studio
