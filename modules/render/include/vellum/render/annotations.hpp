#pragma once
// Annotations that make a rendering a publishable figure: a scale bar in mm, an orientation
// marker (A/P, L/R, S/I) and structure labels with leader lines, placed automatically in the
// margins without overlapping. Drawn into the image at its own resolution (stroke fonts and
// anti-aliased lines: crisp at any size).
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <optional>

#include "vellum/core/image.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/render/backward_map.hpp"
#include "vellum/render/framing.hpp"
#include "vellum/render/projection.hpp"

namespace vellum::render {

struct AnnotationOptions {
  bool scaleBar = false;
  double scaleBarMm = 0;  ///< 0: a round length (1, 2, 5 x 10^k mm) near a fifth of the width
  bool orientation = false;
  bool labels = false;
  /// Height of capital letters of the annotation text (labels, scale-bar caption, orientation
  /// letters) in pixels; 0 = scaled with the image (about its shorter side / 43).
  double textHeightPx = 0;
  /// The text drawn for a structure instead of its label-table name: (key, text), the key a
  /// table name (case-insensitive) or an id ("bone", "Tibia and fibula").
  std::vector<std::pair<std::string, std::string>> displayNames;
  /// Which margin column a label goes to: the nearer side of its anchor, or all to one side
  /// (a figure framed on its anatomy keeps room for one column only).
  enum class LabelSide { Nearest, Left, Right };
  LabelSide labelSide = LabelSide::Nearest;
};

/// The text annotate() draws for structure `id` named `name` in the label table.
std::string displayName(const AnnotationOptions& options, uint16_t id, const std::string& name);

/// A structure to label: its name and the pixel its leader line points at.
struct StructureAnchor {
  uint16_t id = 0;
  std::string name;
  int x = 0, y = 0;
  int64_t visiblePixels = 0;  ///< size of its footprint in the image
};

/// Which structure a pixel belongs to when several project onto it.
enum class AnchorOcclusion {
  FrontMost,   ///< the nearest one: opaque renderings (bone in front of bone)
  InnerFirst,  ///< the one with the smallest footprint: see-through illustrations, where bone
               ///< shows through translucent muscle and the muscle is named where it alone is
};

/// For each of `ids` (all ids of the table when empty), the pixel deepest inside the part of
/// the image that belongs to it (see AnchorOcclusion) where the rendering is not transparent
/// (alpha > 0); structures with fewer than `minPixels` such pixels are left out. `footprint`,
/// when given, receives per pixel the id it belongs to (0 = none).
std::vector<StructureAnchor> structureAnchors(const LabelVolume& labels, std::vector<uint16_t> ids,
                                              const Projection& projection, const RgbaImage& rendered,
                                              int64_t minPixels = 30, std::vector<uint16_t>* footprint = nullptr,
                                              AnchorOcclusion occlusion = AnchorOcclusion::FrontMost);

/// A point on each structure of `ids` (all ids of the table when empty) that stays on it: the
/// voxel of the label nearest the label's centroid (mm). Ids without voxels are left out.
struct StructureCentre {
  uint16_t id = 0;
  Vec3 mm;
};
std::vector<StructureCentre> structureCentres(const LabelVolume& labels, std::vector<uint16_t> ids);

/// Where source points (mm) are drawn in a render deformed by `map`: the output positions x
/// with u(x) = p for the map as the renderer samples it (interpolated, then snapped), found by
/// Newton iterations from x = p with the map's central-difference Jacobian. nullopt where they
/// do not reach p to within a hundredth of the source's smallest spacing.
std::vector<std::optional<Vec3>> deformedPositions(const BackwardMap& map, const Geometry& source,
                                                   const std::vector<Vec3>& sourceMm);

/// Deformed frames: moves each anchor to where its structure's centre is drawn (`drawnMm`,
/// by id), when that pixel belongs to the structure in `footprint` (structureAnchors'; so the
/// leader line still ends on visible anatomy); otherwise the anchor stays where it was.
void moveAnchorsToCentres(std::vector<StructureAnchor>& anchors, const std::vector<StructureCentre>& drawnMm,
                          const Projection& projection, const std::vector<uint16_t>& footprint);

/// Where things were drawn (for tests and reports).
struct AnnotationLayout {
  double scaleBarMm = 0, scaleBarPixels = 0;
  std::array<int, 2> scaleBarStart{0, 0};  ///< left end of the bar (pixel)
  struct Box {
    int x0, y0, x1, y1;  ///< inclusive text box
  };
  std::vector<Box> labelBoxes;                       ///< in the order of the anchors drawn
  std::vector<std::string> labelTexts;               ///< the text of each box
  std::vector<std::array<int, 4>> leaderLines;       ///< x0 y0 (box side) x1 y1 (anchor)
  std::array<std::string, 4> orientationLetters;     ///< right, left, top, bottom
};

/// The room annotate() takes at the image's edges (orientation letters, scale bar and caption,
/// label columns wide enough for `labelTexts` on the sides options.labelSide allows), so that a figure framed on its
/// anatomy (render::fitCamera) leaves the annotations on paper.
ImageInsets annotationInsets(const AnnotationOptions& options, int width, int height,
                             const std::vector<std::string>& labelTexts);

/// Draws the chosen annotations into `image` (white ink on dark backgrounds, black on light).
AnnotationLayout annotate(RgbaImage& image, const Projection& projection, const AnnotationOptions& options,
                          const std::vector<StructureAnchor>& anchors = {});

/// A caption: `text` centred near the bottom edge of `image` (above the scale bar's row), in
/// the annotations' ink with its halo; shrunk to fit the width. `textHeightPx` as
/// AnnotationOptions::textHeightPx (0: scaled with the image). Nothing for empty text.
void drawCaption(RgbaImage& image, const std::string& text, double textHeightPx = 0);

/// A title card: `image` filled with `background` (RGB 0..255, opaque), `title` centred and,
/// when not empty, `subtitle` beneath it at two thirds of its size; each shrunk to fit.
void drawTitleCard(RgbaImage& image, const std::string& title, const std::string& subtitle,
                   std::array<uint8_t, 3> background = {0, 0, 0});

/// The anatomical letters of a physical (LPS) direction: "L", "P", "S" ... or two letters for
/// oblique directions ("LA"), strongest first.
std::string anatomicalLetters(const Vec3& direction);

}  // namespace vellum::render
