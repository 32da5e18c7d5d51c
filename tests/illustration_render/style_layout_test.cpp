// The style table's GPU layout (illustration/src/style_layout.hpp): every slot named in the
// table carries its style field through packStyle, and the shader's names are generated.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "illustration_renderer_common.hpp"
#include "style_layout.hpp"

namespace vellum::illustration::detail {
namespace {

/// A segment style whose slot fields all hold distinct values inside their ranges.
SegmentStyle distinctStyle() {
  SegmentStyle s;
  double next = 0.11;
  for (const SlotInfo& slot : kStyleSlots) {
    const auto* f = params::findField(segmentStyleTable(), slot.key);
    if (!f) continue;
    auto pick = [&] {
      next += 0.07;
      return std::clamp(f->info.min + next, f->info.min, std::min(f->info.max, f->info.min + 50.0));
    };
    if (f->kind == params::Kind::Vector) f->setVector(s, {pick(), pick(), pick()});
    else if (f->kind == params::Kind::Choice) f->set(s, double(f->choices.size() - 1));
    else f->set(s, pick());
  }
  return s;
}

TEST(IllustrationStyleLayout, EverySlotCarriesItsStyleField) {
  Style style;
  style.fallback = distinctStyle();
  Geometry g;
  g.dims = {4, 4, 4};
  const StyleTable t = packStyle(style, {}, 1, g);
  const float* row = t.texels.data() + size_t(kRowTexels) * 4;  // label 1: the fallback row
  int checked = 0, derived = 0;
  for (const SlotInfo& slot : kStyleSlots) {
    const auto* f = params::findField(segmentStyleTable(), slot.key);
    if (!*slot.key) {  // derived
      ++derived;
      continue;
    }
    ASSERT_NE(f, nullptr) << slot.name << ": no style field " << slot.key;
    const float* p = row + slot.texel * 4 + slot.component;
    if (slot.isRgb) {
      const auto v = f->getVector(style.fallback);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(p[c], float(v[size_t(c)])) << slot.name << "[" << c << "]";
    } else {
      EXPECT_EQ(p[0], float(*f->get(style.fallback))) << slot.name;
    }
    ++checked;
  }
  EXPECT_EQ(derived, 2);  // Visible, Ink
  EXPECT_EQ(checked, int(std::size(kStyleSlots)) - derived);
  EXPECT_TRUE(t.row(1)[slot::Visible]);
  EXPECT_TRUE(t.row(1)[slot::Ink]);
  EXPECT_EQ(t.row(1)[slot::Texture], SolidTexture::Volume);
  EXPECT_EQ(t.row(1)[slot::Illum], IllumMode::Ct);
}

TEST(IllustrationStyleLayout, ShaderNamesComeFromTheTable) {
  const std::string glsl = styleLayoutGlsl();
  auto has = [&](const std::string& line) { return glsl.find(line + "\n") != std::string::npos; };
  EXPECT_TRUE(has("#define STYLE_ROW_TEXELS " + std::to_string(kRowTexels)));
  EXPECT_TRUE(has("#define STYLE_TONE_WARM(r) ((r).t[2].xyz)"));
  EXPECT_TRUE(has("#define STYLE_BOUNDARY_WIDTH_MM(r) ((r).t[8].w)"));
  EXPECT_TRUE(has("#define STYLE_VISIBLE_AT(label) (texelFetch(uStyle, ivec2(1, (label)), 0).w > 0.5)"));
  EXPECT_TRUE(has("#define STYLE_TEXTURE(r) int((r).t[5].w + 0.5)"));
  EXPECT_TRUE(has("#define TEXTURE_NONE " + std::to_string(int(SolidTexture::None))));
  EXPECT_TRUE(has("#define TEXTURE_VOLUME " + std::to_string(int(SolidTexture::Volume))));
  EXPECT_TRUE(has("#define ILLUM_CT " + std::to_string(int(IllumMode::Ct))));
  EXPECT_TRUE(has("#define BOUNDARY_MEASURE_CT " + std::to_string(int(BoundaryMeasure::Ct))));
}

}  // namespace
}  // namespace vellum::illustration::detail
