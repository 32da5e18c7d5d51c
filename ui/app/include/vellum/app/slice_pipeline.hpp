#pragma once
// `vellum slice` as a request: slices of a volume as PNG pictures, at physical aspect (each
// pixel a square of the same mm), with window/level, a label map's colours, orientation
// letters and a scale bar; one file per slice or one contact sheet. The resampling is the
// studio's slice views' own (vellum/app/mpr.hpp).
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/app/mpr.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::app {

struct SliceRequest {
  std::filesystem::path input;   ///< volume file or DICOM folder
  std::filesystem::path output;  ///< the picture, the stem of several, or the contact sheet
  std::filesystem::path labels;  ///< a label map on the volume's grid drawn over it; empty: none
  std::filesystem::path report;  ///< JSON with the shared report keys; empty: none
  /// More volumes resampled on the same planes (the same mm), a column each beside the first
  /// (needs `plate`): before | after comparisons.
  std::vector<std::filesystem::path> beside;
  io::LoadOptions load;
  std::string commandLine;

  SliceAxis axis = SliceAxis::Axial;
  std::vector<int64_t> indices;     ///< voxel indices along the voxel axis nearest the slice normal
  std::vector<double> positionsMm;  ///< LPS positions: axial z, coronal y, sagittal x (mm)
  int every = 0;                    ///< every N-th slice (0: not)
  bool plate = false;               ///< one contact sheet instead of a file each
  int columns = 0;                  ///< the sheet's columns (0: about square)
  std::string window = "auto";      ///< a windowPresets() name, or auto
  double windowCenter = 0, windowWidth = 0;  ///< HU; width > 0 overrides `window`
  double zoom = 1;                  ///< pixels per finest in-plane voxel
  std::vector<double> boxMm;        ///< x0 x1 y0 y1 z0 z1: the in-plane part shown (empty: all)
  float labelOpacity = 0.4f;
  bool labelOutlines = true;
  bool orientation = true;
  bool scaleBar = false;
  bool caption = false;             ///< the axis, index and position under each picture
};

/// The request's numbers and switches, described once (docs/parameters.md, `vellum slice`).
const params::Table<SliceRequest>& sliceRequestTable();

/// One slice that was drawn.
struct SliceFigure {
  std::filesystem::path path;  ///< its file (the sheet's for a sheet's tile)
  double positionMm = 0;       ///< LPS z (axial), y (coronal) or x (sagittal)
  int64_t index = -1;          ///< voxel index along the normal's voxel axis (nearest)
  int width = 0, height = 0;
};

struct SliceResult {
  std::vector<SliceFigure> figures;
  double mmPerPixel = 0;
  WindowLevel window;
  std::vector<std::string> warnings;  ///< the load's
};

/// The plane of `axis` at `positionMm` (LPS: axial z, coronal y, sagittal x), covering the volume's voxel box (or
/// the part of it inside `boxMm`) at `mmPerPixel`.
SlicePlane slicePlane(SliceAxis axis, const Geometry& g, double positionMm, double mmPerPixel,
                      const std::vector<double>& boxMm = {});

/// Loads, resamples, annotates and writes (under the output policy, atomically).
SliceResult runSlice(const SliceRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
