// `vellum slice` as one call (slice_pipeline.hpp).
#include "vellum/app/slice_pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "vellum/app/figures.hpp"
#include "vellum/app/outputs.hpp"
#include "vellum/app/run_io.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/box_corners.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/render/contact_sheet.hpp"

namespace vellum::app {
namespace fs = std::filesystem;

const params::Table<SliceRequest>& sliceRequestTable() {
  using R = SliceRequest;
  static const params::Table<R> t{
      params::choice<R>("axis", &R::axis, {"axial", "coronal", "sagittal"},
                        {"Axis", "the slice plane: axial (seen from the feet), coronal (from the front) or sagittal "
                                 "(from the patient's right), as the studio's slice views", ""}),
      params::integer<R>("every", &R::every,
                         {"Every", "every N-th slice along the axis, from index 0 (0: only --index / --mm; neither: "
                                   "the middle slice)", "voxels", 0, 1e6}),
      params::flag<R>("plate", &R::plate, {"Contact sheet", "all slices as one contact sheet at --out instead of a "
                                                             "file each (OUT-INDEX.png), white lines between; with --beside a row per slice", ""}),
      params::integer<R>("columns", &R::columns, {"Columns", "the contact sheet's columns (0: about square; with --beside one per volume)", "", 0, 1000}),
      params::text<R>("window", &R::window,
                      {"Window", "a preset (soft-tissue 40/400, bone 400/1800, lung -600/1500, brain 40/80, abdomen "
                                 "60/350 HU, as the studio's) or auto: soft-tissue for a CT in HU (int16 below -100), "
                                 "else the value range", ""}),
      params::real<R>("window_center", &R::windowCenter,
                      {"Window centre", "grey 50 % (with --window-width, instead of --window)", "HU"}),
      params::real<R>("window_width", &R::windowWidth,
                      {"Window width", "black to white (0: --window decides)", "HU", 0, 1e6}),
      params::real<R>("zoom", &R::zoom,
                      {"Zoom", "pixels per voxel of the finest in-plane spacing; every pixel is a square of the "
                               "same mm, so anisotropic voxels keep their physical aspect", "", 0.05, 32}),
      params::real<R>("label_opacity", &R::labelOpacity,
                      {"Label fill", "opacity of the --labels fill in the label table's colours (0: outlines only)",
                       "", 0, 1}),
      params::flag<R>("label_outlines", &R::labelOutlines,
                      {"Label outlines", "opaque 1-pixel outlines where the label id changes", ""}),
      params::flag<R>("orientation", &R::orientation,
                      {"Orientation letters", "R/L, A/P, S/I at the picture's edges", ""}),
      params::flag<R>("scale_bar", &R::scaleBar, {"Scale bar", "a bar of a round length in mm", ""}),
      params::flag<R>("caption", &R::caption,
                      {"Caption", "the axis, voxel index and position (mm) under each picture (and the file's name with --beside)", ""}),
  };
  return t;
}

namespace {

/// The voxel axis (0, 1, 2) whose direction is nearest `normal`.
int voxelAxisAlong(const Geometry& g, const Vec3& normal) {
  int best = 0;
  double bestDot = -1;
  for (int d = 0; d < 3; ++d) {
    const double c = std::abs(g.direction(0, d) * normal.x + g.direction(1, d) * normal.y + g.direction(2, d) * normal.z);
    if (c > bestDot) {
      bestDot = c;
      best = d;
    }
  }
  return best;
}

/// The range of dot(p, axis) over the voxel box's corners (voxel edges, not centres).
std::pair<double, double> boxRange(const Geometry& g, const Vec3& axis) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec3& corner : voxelBoxCorners(g)) {
    const double s = dot(corner, axis);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  return {lo, hi};
}

/// The range of dot(p, axis) over the corners of a box x0 x1 y0 y1 z0 z1 (mm).
std::pair<double, double> boxRange(const std::vector<double>& b, const Vec3& axis) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec3& corner : boxCorners({b[0], b[2], b[4]}, {b[1], b[3], b[5]})) {
    const double s = dot(corner, axis);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  return {lo, hi};
}

/// The LPS axis a slice position is measured along: axial z, coronal y, sagittal x (the plane's
/// normal up to its sign).
Vec3 positionAxis(SliceAxis axis) {
  switch (axis) {
    case SliceAxis::Axial: return {0, 0, 1};
    case SliceAxis::Coronal: return {0, 1, 0};
    case SliceAxis::Sagittal: return {1, 0, 0};
  }
  return {0, 0, 1};
}

const char* axisLetter(const Vec3& normal) {
  if (std::abs(normal.z) > 0.5) return "z";
  return std::abs(normal.y) > 0.5 ? "y" : "x";
}

std::string formatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", std::abs(v) < 5e-5 ? 0.0 : v);
  return buf;
}

WindowLevel chooseWindow(const SliceRequest& r, const AnyVolume& v) {
  if (r.windowWidth > 0) return {r.windowCenter, r.windowWidth};
  if (r.window != "auto") {
    const WindowPreset* p = findWindowPreset(r.window);
    if (!p) {
      std::string names;
      for (const WindowPreset& q : windowPresets()) names += std::string(", ") + q.name;
      throw Error("--window: '" + r.window + "' is not one of auto" + names);
    }
    return {p->center, p->width};
  }
  const auto [lo, hi] = std::visit([](const auto& x) { return x.valueRange(); }, v);
  if (voxelTypeOf(v) == VoxelType::Int16 && lo < -100) {
    const WindowPreset* p = findWindowPreset("soft tissue");
    return {p->center, p->width};
  }
  return {0.5 * (lo + hi), std::max(1.0, hi - lo)};
}

bool isPicture(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == ".png" || e == ".tif" || e == ".tiff" || e == ".jpg" || e == ".jpeg";
}

}  // namespace

SlicePlane slicePlane(SliceAxis axis, const Geometry& g, double positionMm, double mmPerPixel,
                      const std::vector<double>& boxMm) {
  SlicePlane p = makePlane(axis, g, g.center(), 1, 1);  // its directions
  auto [u0, u1] = boxRange(g, p.u);
  auto [v0, v1] = boxRange(g, p.v);
  if (boxMm.size() == 6) {
    const auto [bu0, bu1] = boxRange(boxMm, p.u);
    const auto [bv0, bv1] = boxRange(boxMm, p.v);
    u0 = std::max(u0, bu0), u1 = std::min(u1, bu1), v0 = std::max(v0, bv0), v1 = std::min(v1, bv1);
    if (u0 >= u1 || v0 >= v1) throw Error("--box-mm: the box does not overlap the volume in the " +
                                          std::string(sliceAxisName(axis)) + " plane");
  }
  p.mmPerPixel = mmPerPixel;
  // Pixel centres fall on voxel centres when the box is the voxel box and mmPerPixel its spacing.
  p.width = std::max(1, static_cast<int>(std::ceil((u1 - u0) / mmPerPixel - 1e-6)));
  p.height = std::max(1, static_cast<int>(std::ceil((v1 - v0) / mmPerPixel - 1e-6)));
  if (double(p.width) * p.height > 64e6)
    throw Error("--zoom: a " + std::to_string(p.width) + " x " + std::to_string(p.height) + " picture is too large");
  p.center = p.u * (0.5 * (u0 + u1)) + p.v * (0.5 * (v0 + v1)) + positionAxis(axis) * positionMm;
  return p;
}

SliceResult runSlice(const SliceRequest& r, Progress& progress) {
  if (!isPicture(r.output)) throw Error("--out: " + r.output.string() + " is not a picture (.png, .tif, .jpg)");
  if (!r.boxMm.empty() && r.boxMm.size() != 6) throw Error("--box-mm takes 6 numbers: x0 x1 y0 y1 z0 z1");
  RunReport run(r.commandLine);
  run.input(r.input, "volume");
  run.input(r.labels, "label map");
  if (!r.beside.empty() && !r.plate) throw Error("--beside needs --plate (a column per volume)");
  io::OutputPlan first;
  first.input(r.input).input(r.labels, "the --labels map");
  for (const fs::path& b : r.beside) first.input(b, "--beside");
  first.output(r.output, "--out").json(r.report, "--report").check();
  io::LoadedVolume lv = loadInput(run, r.input, r.load, progress);
  SliceResult result;
  result.warnings = lv.warnings;
  const Geometry g = geometryOf(lv.volume);
  std::optional<LabelVolume> labels;
  if (!r.labels.empty()) {
    labels = loadLabelsLike(r.labels, r.load);
    requireSameGrid(*labels, g, r.labels);
  }
  result.window = chooseWindow(r, lv.volume);
  // The resampling reads int16 (the studio's CT); other types are rounded to it.
  std::optional<VolumeI16> converted;
  if (!std::holds_alternative<VolumeI16>(lv.volume)) converted = toInt16(lv.volume);
  const VolumeI16& ct = converted ? *converted : std::get<VolumeI16>(lv.volume);
  // --beside: more volumes, each resampled on the first one's planes (the same mm; outside
  // its box, its background), one column each.
  std::vector<VolumeI16> besides;
  for (const fs::path& b : r.beside) {
    run.input(b, "volume beside");
    io::LoadedVolume other = loadInput(run, b, r.load, progress);
    besides.push_back(std::holds_alternative<VolumeI16>(other.volume) ? std::move(std::get<VolumeI16>(other.volume))
                                                                       : toInt16(other.volume));
  }

  // Which slices: positions along the plane's normal, in the order asked.
  const Vec3 normal = positionAxis(r.axis);
  const int d = voxelAxisAlong(g, normal);
  const auto [n0, n1] = boxRange(g, normal);
  const Vec3 c = g.center();
  const auto indexPosition = [&](int64_t i) {
    Vec3 ijk = g.physicalToIndex(c);
    ijk[d] = double(i);
    return dot(g.indexToPhysical(ijk), normal);
  };
  const auto nearestIndex = [&](double mm) {
    return static_cast<int64_t>(std::lround(g.physicalToIndex(c + normal * (mm - dot(c, normal)))[d]));
  };
  std::vector<double> positions;
  for (int64_t i : r.indices) {
    if (i < 0 || i >= g.dims[d])
      throw Error("--index " + std::to_string(i) + ": outside 0.." + std::to_string(g.dims[d] - 1) + " (the " +
                  std::string(sliceAxisName(r.axis)) + " slices of " + r.input.string() + ")");
    positions.push_back(indexPosition(i));
  }
  for (double mm : r.positionsMm) {
    if (mm < n0 || mm > n1)
      throw Error("--mm " + formatNumber(mm) + ": outside the volume (" + axisLetter(normal) + " " + formatNumber(n0) +
                  " to " + formatNumber(n1) + " mm)");
    positions.push_back(mm);
  }
  if (r.every > 0)
    for (int64_t i = 0; i < g.dims[d]; i += r.every) positions.push_back(indexPosition(i));
  if (positions.empty()) positions.push_back(indexPosition(g.dims[d] / 2));

  // Output names: OUT-<index> (zero-padded) for index-based slices, OUT-<mm>mm for positions.
  const bool several = positions.size() > 1;
  std::vector<fs::path> paths;
  const int digits = static_cast<int>(std::to_string(g.dims[d] - 1).size());
  for (size_t n = 0; n < positions.size(); ++n) {
    if (!several || r.plate) {
      paths.push_back(r.output);
      continue;
    }
    const bool byMm = n >= r.indices.size() && n < r.indices.size() + r.positionsMm.size();
    std::string part;
    if (byMm) {
      part = formatNumber(positions[n]) + "mm";
    } else {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%0*lld", digits, static_cast<long long>(nearestIndex(positions[n])));
      part = buf;
    }
    paths.push_back(figurePath(r.output, {part}));
  }
  io::OutputPlan plan;
  plan.input(r.input).input(r.labels, "the --labels map");
  for (const fs::path& b : r.beside) plan.input(b, "--beside");
  for (size_t n = 0; n < (r.plate ? 1 : paths.size()); ++n) plan.output(paths[n], "--out");
  plan.json(r.report, "--report").check();

  // Square pixels of the finest in-plane spacing (/ zoom): physical aspect whatever the voxels.
  double finest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (a != d) finest = std::min(finest, g.spacing[a]);
  result.mmPerPixel = finest / r.zoom;
  SliceStyle style;
  style.window = result.window;
  style.labels = labels ? &*labels : nullptr;
  style.labelOpacity = r.labelOpacity;
  style.labelOutlines = r.labelOutlines;
  render::AnnotationOptions annotations;
  annotations.orientation = r.orientation;
  annotations.scaleBar = r.scaleBar;
  run.mark("load");

  ensureParentFolder(r.output);
  RunOutputs written;  // Ctrl-C between slices leaves no picture of this run
  std::vector<RgbaImage> tiles;
  nlohmann::json figures = nlohmann::json::array();
  progress.begin("slice", positions.size());
  for (size_t n = 0; n < positions.size(); ++n) {
    const SlicePlane plane = slicePlane(r.axis, g, positions[n], result.mmPerPixel, r.boxMm);
    RgbaImage image = renderSlice(ct, plane, style);
    const int64_t index = nearestIndex(positions[n]);
    if (anyAnnotation(annotations))
      render::annotate(image, render::Projection::plane(plane.center, plane.u, plane.v, plane.mmPerPixel, plane.width,
                                                        plane.height),
                       annotations);
    const std::string where = std::string(sliceAxisName(r.axis)) + " " + "ijk"[d] + " " + std::to_string(index) + "  " +
                              axisLetter(normal) + " " + formatNumber(positions[n]) + " mm";
    if (r.caption) render::drawCaption(image, (besides.empty() ? "" : r.input.stem().string() + "  ") + where);
    result.figures.push_back({paths[n], positions[n], index, image.width, image.height});
    figures.push_back({{"position_mm", positions[n]}, {"index", index}});
    if (r.plate) {
      tiles.push_back(std::move(image));
      SliceStyle plain = style;
      plain.labels = nullptr;  // the label map lies on the first volume's grid
      for (size_t b = 0; b < besides.size(); ++b) {
        RgbaImage other = renderSlice(besides[b], plane, plain);
        if (anyAnnotation(annotations))
          render::annotate(other, render::Projection::plane(plane.center, plane.u, plane.v, plane.mmPerPixel,
                                                            plane.width, plane.height),
                           annotations);
        if (r.caption) render::drawCaption(other, r.beside[b].stem().string() + "  " + where);
        tiles.push_back(std::move(other));
      }
    } else {
      io::saveImage(image, paths[n]);
      written.wrote(paths[n]);
      run.output(paths[n]);
      figures.back()["path"] = paths[n].string();
    }
    progress.advance();
  }
  progress.end();
  if (r.plate) {
    const int n = static_cast<int>(tiles.size());
    const int columns = !besides.empty()  ? 1 + static_cast<int>(besides.size())
                        : r.columns > 0 ? r.columns
                                        : static_cast<int>(std::ceil(std::sqrt(double(n)) - 1e-9));
    RgbaImage sheet = render::contactSheet(tiles, std::min(columns, n));
    for (size_t i = 3; i < sheet.pixels.size(); i += 4) sheet.pixels[i] = 255;  // empty cells black, not see-through
    // White 2-pixel lines between the pictures (a pixel of each side): dark tiles stay apart.
    const int tw = tiles.front().width, th = tiles.front().height;
    for (int y = 0; y < sheet.height; ++y)
      for (int x = 0; x < sheet.width; ++x) {
        const bool line = (x % tw == 0 && x > 0) || (x % tw == tw - 1 && x < sheet.width - 1) ||
                          (y % th == 0 && y > 0) || (y % th == th - 1 && y < sheet.height - 1);
        if (line) std::fill_n(sheet.at(x, y), 3, uint8_t(255));
      }
    io::saveImage(sheet, r.output);
    written.wrote(r.output);
    run.output(r.output);
  }
  run.mark("slices");
  if (!r.report.empty()) {
    nlohmann::json report = {{"slices", figures},
                             {"mm_per_pixel", result.mmPerPixel},
                             {"window", {result.window.center, result.window.width}},
                             {"settings", params::toJson(sliceRequestTable(), r)}};
    if (r.plate) report["output"] = r.output.string();
    run.stamp(report);
    writeJsonFile(report, r.report);
  }
  written.commit();
  return result;
}

}  // namespace vellum::app
