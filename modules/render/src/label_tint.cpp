#include "vellum/render/label_tint.hpp"

namespace vellum::render {

LabelTint makeLabelTint(const LabelVolume& labels, const std::set<uint16_t>& hidden) {
  LabelTint t;
  t.ids = labels.ids();
  t.colours.assign(kMaxTintLabels, {0, 0, 0, 0});
  for (const Label& l : labels.table())
    if (l.id > 0 && l.id < kMaxTintLabels && !hidden.count(l.id))
      t.colours[l.id] = {l.rgb[0], l.rgb[1], l.rgb[2], 255};
  return t;
}

}  // namespace vellum::render
