#pragma once
// Illustrations that frame and label themselves on what the style draws: the default framing
// fits the drawn segments (not the volume's bounding sphere), and labels name only segments
// that show in the figure (issue 21).
#include <cstdint>
#include <string>
#include <vector>

#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/render/framing.hpp"

namespace vellum::illustration {

/// Which label ids (index = id, 0 = unclassified) `style` can draw: the segment has voxels and
/// its row is visible, with opacity > 0 and some weight on illumination, colour or texture.
std::vector<uint8_t> styleDrawnIds(const Style& style, const LabelVolume& segments);

/// What zoom 1 fits: the segments the style draws (default), every labelled segment (the same
/// framing for every style: plates that compare styles), or the volume's bounding sphere.
enum class Framing { Drawn, Segments, Volume };
const params::EnumTable<Framing>& framings();  ///< "drawn", "segments", "volume"
inline Framing parseFraming(const std::string& name) { return framings().parse(name); }
inline const char* framingName(Framing f) { return framings().name(f); }

/// The camera of `settings` fitted (render::fitCamera) to what `framing` names, inside the
/// image less `insets` (the annotations' room: render::annotationInsets); its zoom and pan act
/// on top of the fit. Volume, or nothing to fit: the camera unchanged.
render::Camera frameFigure(const LabelVolume& segments, const Style& style, const render::RenderSettings& settings,
                           Framing framing, const render::ImageInsets& insets = {});

struct LabelSearch {
  std::vector<uint16_t> ids;  ///< candidates (empty: every id of the label table)
  int64_t minPixels = 30;     ///< footprint a label needs, in figure pixels
  int probeSize = 256;        ///< longer side of the probe renders (nearest interpolation)
  int minChange = 6;          ///< a pixel shows a segment when hiding it changes a channel by more (of 255)
};

/// The labels of `figure`, which `renderer` drew with `style` and `settings`: an anchor for each
/// candidate that is drawn, i.e. its row draws at all (styleDrawnIds) and hiding it changes at
/// least minPixels pixels (probe renders with that segment hidden, at probeSize). The anchor
/// lies where the segment shows, where it alone projects when it can (see-through figures:
/// render::AnchorOcclusion::InnerFirst). A segment that is not drawn gets no label.
std::vector<render::StructureAnchor> drawnSegmentAnchors(IllustrationRenderer& renderer, const Style& style,
                                                         const IllustrationSettings& settings,
                                                         const LabelVolume& segments, const RgbaImage& figure,
                                                         const LabelSearch& search = {});

}  // namespace vellum::illustration
