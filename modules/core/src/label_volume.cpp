#include "vellum/core/label_volume.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>

namespace vellum {

void LabelVolume::setLabel(const Label& label) {
  for (auto& l : table_)
    if (l.id == label.id) { l = label; return; }
  table_.push_back(label);
  std::sort(table_.begin(), table_.end(), [](const Label& a, const Label& b) { return a.id < b.id; });
}

std::optional<Label> LabelVolume::label(uint16_t id) const {
  for (const auto& l : table_)
    if (l.id == id) return l;
  return std::nullopt;
}

uint16_t LabelVolume::nextFreeId() const {
  uint16_t id = 1;
  while (label(id)) ++id;
  return id;
}

uint16_t LabelVolume::maxId() const {
  const auto& v = ids_.voxels();
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, v.size(), 1 << 16), uint16_t{0},
      [&](const tbb::blocked_range<size_t>& r, uint16_t m) {
        for (size_t i = r.begin(); i < r.end(); ++i) m = std::max(m, v[i]);
        return m;
      },
      [](uint16_t a, uint16_t b) { return std::max(a, b); });
}

std::vector<uint64_t> LabelVolume::histogram() const {
  std::vector<uint64_t> h(static_cast<size_t>(maxId()) + 1, 0);
  for (uint16_t id : ids_.voxels()) ++h[id];
  return h;
}

std::array<uint8_t, 3> defaultLabelColor(uint16_t id) {
  // A fixed palette of well-separated colours, then golden-angle hues beyond it.
  static const std::array<std::array<uint8_t, 3>, 12> palette{{{230, 190, 160},
                                                               {255, 220, 130},
                                                               {200, 70, 60},
                                                               {240, 235, 215},
                                                               {205, 160, 90},
                                                               {90, 170, 220},
                                                               {120, 200, 110},
                                                               {170, 120, 200},
                                                               {240, 150, 60},
                                                               {80, 200, 190},
                                                               {220, 100, 160},
                                                               {160, 160, 160}}};
  if (id == 0) return {0, 0, 0};
  if (id <= palette.size()) return palette[id - 1];
  const double h = std::fmod(id * 137.508, 360.0) / 60.0;
  const double x = 1 - std::abs(std::fmod(h, 2.0) - 1);
  double r = 0, g = 0, b = 0;
  switch (static_cast<int>(h)) {
    case 0: r = 1; g = x; break;
    case 1: r = x; g = 1; break;
    case 2: g = 1; b = x; break;
    case 3: g = x; b = 1; break;
    case 4: r = x; b = 1; break;
    default: r = 1; b = x; break;
  }
  auto c = [](double v) { return static_cast<uint8_t>(60 + v * 180); };
  return {c(r), c(g), c(b)};
}

}  // namespace vellum
