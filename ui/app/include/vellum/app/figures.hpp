#pragma once
// What `vellum render` and `vellum illustrate` share around their renderers: label maps read
// on the volume's grid, the annotation options, named views, and the file names of a call
// that draws several figures (presets x views) from one upload.
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/annotations.hpp"

namespace vellum::app {

/// A label map on the grid of a volume loaded with `volumeLoad`: the same region (crop,
/// downsample) and the same rule for data files outside the header's folder.
LabelVolume loadLabelsLike(const std::filesystem::path& path, const io::LoadOptions& volumeLoad);

/// FileError naming `path` when `labels` does not lie on `volume` (dims, spacing, origin,
/// direction within `tolerance`).
void requireSameGrid(const LabelVolume& labels, const Geometry& volume, const std::filesystem::path& path,
                     double tolerance = 1e-3);

/// Anything to draw (scale bar, orientation letters, labels)?
bool anyAnnotation(const render::AnnotationOptions& options);

/// Throws vellum::Error for a display name (--label-name KEY=TEXT) whose key names no
/// structure of `labels` (by name without case, or by id).
void checkDisplayNames(const render::AnnotationOptions& options, const LabelVolume& labels);

/// One camera direction of a figure. Named views look from the patient's side they name
/// (LPS: azimuth 0 looks from anterior, 90 from the patient's left).
struct FigureView {
  std::string name;  ///< file-name part: "anterior", "az30", "az30el10"
  double azimuthDeg = 0, elevationDeg = 0;
};

/// "anterior" | "posterior" | "left" | "right" | "lateral" (= left: the radiographic lateral)
/// | "superior" | "inferior" | AZ | AZ:EL (degrees; AZ alone keeps `elevationDeg`).
/// Throws vellum::Error naming the view and the choices.
FigureView parseView(const std::string& text, double elevationDeg);

/// "a,b,c" -> {"a", "b", "c"}; Error naming `what` for an empty item.
std::vector<std::string> splitList(const std::string& text, const char* what);

/// The file of one figure of a call that draws several: `out` with "-part" appended to its
/// stem for each part ("fig.png", {"pen", "lateral"} -> "fig-pen-lateral.png").
std::filesystem::path figurePath(const std::filesystem::path& out, const std::vector<std::string>& parts);

}  // namespace vellum::app
