#include "vellum/illustration/figure.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "vellum/core/error.hpp"
#include "vellum/render/framing.hpp"
#include "vellum/render/projection.hpp"

namespace vellum::illustration {

namespace {

int maxId(const LabelVolume& segments) {
  int m = 0;
  for (const Label& l : segments.table()) m = std::max(m, int(l.id));
  for (const uint16_t id : segments.ids().voxels()) m = std::max(m, int(id));
  return m;
}

bool draws(const SegmentStyle& r) {
  // A fill, or ink alone (as the style table's ink flag): a skin drawn as an outline only is
  // drawn, so it is framed and labelled.
  const bool fill = r.opacity > 0 && r.lambdaIllum + r.lambdaColouring + r.lambdaTexture > 0;
  const bool ink = r.lineOpacity > 0 && (r.lineWidthPx > 0 || r.hatchSpacingPx > 0 || r.creaseWidthPx > 0);
  return r.visible && (fill || ink);
}

}  // namespace

std::vector<uint8_t> styleDrawnIds(const Style& style, const LabelVolume& segments) {
  const int top = maxId(segments);
  const std::vector<SegmentStyle> rows = resolveRows(style, segments.table(), top);
  std::vector<uint8_t> present(size_t(top) + 1, 0);
  for (const uint16_t id : segments.ids().voxels()) present[id] = 1;
  std::vector<uint8_t> out(size_t(top) + 1, 0);
  for (size_t id = 0; id < out.size(); ++id) out[id] = present[id] && draws(rows[id]);
  return out;
}

const params::EnumTable<Framing>& framings() {
  static const params::EnumTable<Framing> t{"framing", {"drawn", "segments", "volume"}};
  return t;
}

render::Camera frameFigure(const LabelVolume& segments, const Style& style, const render::RenderSettings& settings,
                           Framing framing, const render::ImageInsets& insets) {
  if (framing == Framing::Volume) return settings.camera;
  std::vector<uint8_t> wanted;
  if (framing == Framing::Drawn) {
    wanted = styleDrawnIds(style, segments);
  } else {
    wanted.assign(65536, 1);
    wanted[0] = 0;
  }
  if (!wanted.empty() && wanted[0]) {
    // Unclassified voxels drawn (a plain DVR style): the whole grid shows.
    wanted.assign(65536, 1);
  }
  return render::fitCamera(segments.geometry(), settings, render::outlinePoints(segments.ids(), wanted), 0.06, insets);
}

std::vector<render::StructureAnchor> drawnSegmentAnchors(IllustrationRenderer& renderer, const Style& style,
                                                         const IllustrationSettings& settings,
                                                         const LabelVolume& segments, const RgbaImage& figure,
                                                         const LabelSearch& search) {
  const int w = settings.render.width, h = settings.render.height;
  if (figure.width != w || figure.height != h) throw Error("drawn segment labels: figure and settings sizes differ");
  const std::vector<uint8_t> drawable = styleDrawnIds(style, segments);
  std::vector<uint16_t> candidates = search.ids;
  if (candidates.empty())
    for (const Label& l : segments.table()) candidates.push_back(l.id);
  std::vector<uint16_t> ids;
  for (const uint16_t id : candidates)
    if (id != 0 && id < drawable.size() && drawable[id]) ids.push_back(id);
  if (ids.empty()) return {};

  // Probes: the figure and the figure without one segment, small. The camera fits the
  // shorter side, so a probe of the same aspect sees the same picture.
  const double f = std::min(1.0, double(search.probeSize) / std::max(w, h));
  IllustrationSettings probe = settings;
  probe.interpolation = Interpolation::Nearest;  // what shows where, not how fine: fast
  probe.render.width = std::max(1, int(std::lround(w * f)));
  probe.render.height = std::max(1, int(std::lround(h * f)));
  const RgbaImage base = renderer.render(style, probe);
  const std::vector<SegmentStyle> rows = resolveRows(style, segments.table(), int(drawable.size()) - 1);

  const render::Projection projection(segments.geometry(), settings.render);
  std::vector<uint16_t> footprint;  // where each candidate alone projects (smallest wins)
  render::structureAnchors(segments, ids, projection, figure, 1, &footprint, render::AnchorOcclusion::InnerFirst);

  std::vector<render::StructureAnchor> anchors;
  for (const uint16_t id : ids) {
    const auto label = segments.label(id);
    if (!label || label->name.empty()) continue;  // a row cannot name it: it cannot be hidden
    Style hidden = style;
    SegmentStyle off = rows[id];
    off.match = label->name;  // an exact name match comes before every other row
    off.visible = false;
    hidden.segments.insert(hidden.segments.begin(), off);
    const RgbaImage without = renderer.render(hidden, probe);
    std::vector<uint8_t> shows(base.pixels.size() / 4, 0);
    int64_t showing = 0;
    for (size_t p = 0; p < shows.size(); ++p) {
      int change = 0;
      for (int c = 0; c < 4; ++c) change = std::max(change, std::abs(int(base.pixels[4 * p + c]) - int(without.pixels[4 * p + c])));
      showing += shows[p] = change > search.minChange;
    }
    if (double(showing) / (f * f) < double(search.minPixels)) continue;  // not drawn
    // Where it shows, at figure size; where it alone projects if that is enough.
    RgbaImage where(w, h);
    int64_t alone = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int px = std::min(probe.render.width - 1, int(x * f)), py = std::min(probe.render.height - 1, int(y * f));
        const bool s = shows[size_t(py) * probe.render.width + px] != 0;
        where.at(x, y)[3] = s ? 255 : 0;
        alone += s && footprint[size_t(y) * w + x] == id;
      }
    if (alone >= search.minPixels)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          if (footprint[size_t(y) * w + x] != id) where.at(x, y)[3] = 0;
    auto a = render::structureAnchors(segments, {id}, projection, where, search.minPixels);
    if (!a.empty()) anchors.push_back(a.front());
  }
  return anchors;
}

}  // namespace vellum::illustration
