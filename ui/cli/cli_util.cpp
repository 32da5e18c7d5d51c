#include "cli_util.hpp"

#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <sstream>

#include "cli_params.hpp"
#include "vellum/app/table_removal.hpp"
#include "vellum/core/error.hpp"

namespace vellum::cli {

void InputOptions::addTo(CLI::App& cmd) {
  cmd.add_option("--series", seriesUid, "DICOM: SeriesInstanceUID to load (default: largest CT series)");
  cmd.add_option("--raw-dims", rawDims, "bare .raw without sidecar: dimensions X Y Z")->expected(3);
  cmd.add_option("--raw-type", rawType, "bare .raw: int16 | uint8 | uint16 | float32")
      ->capture_default_str();
  cmd.add_option("--raw-spacing", rawSpacing, "bare .raw: spacing in mm (sx sy sz)")->expected(3);
  cmd.add_option("--raw-origin", rawOrigin, "bare .raw: origin in mm (x y z)")->expected(3);
  cmd.add_option("--raw-direction", rawDirection,
                 "bare .raw: direction matrix, 9 numbers row by row (as `vellum info` prints it)")
      ->expected(9);
  cmd.add_option("--raw-endian", rawEndian, "bare .raw: little | big")
      ->check(CLI::IsMember({"little", "big"}))
      ->capture_default_str();
  cmd.add_option("--raw-header", rawHeader, "bare .raw: bytes to skip before the voxels");
  cmd.add_option("--rescale", rescale, "stored value * SLOPE + INTERCEPT = HU (e.g. 1 -1024 for CT numbers "
                                       "0..4095 in a bare RAW); the volume is then CT")->expected(2);
  cmd.add_option("--crop", cropVoxels, "keep voxels i0 i1 j0 j1 k0 k1 only (inclusive indices; label maps of the "
                                       "command get the same region)")->expected(6);
  cmd.add_option("--crop-mm", cropMm, "keep the voxels inside the box x0 x1 y0 y1 z0 z1 (mm, LPS)")->expected(6);
  cmd.add_option("--downsample", downsample, "reduce every N^3 block to one voxel on load (mean; label maps: "
                                             "most frequent id)")->check(CLI::Range(1, 16));
  cmd.add_flag("--allow-outside-data", allowOutsideData,
               ".nhdr/.mhd: read a data file the header names outside its own folder (absolute, '..', "
               "a symlink leading out)");
  cmd.add_flag("--no-slice-repair", noSliceRepair,
               "DICOM: keep a single mis-registered slice as it is (by default it is replaced by interpolating "
               "its neighbours, with a warning naming it)");
}

Region InputOptions::region() const {
  Region r;
  if (!cropVoxels.empty())
    r.cropVoxels = VoxelBox{{cropVoxels[0], cropVoxels[2], cropVoxels[4]}, {cropVoxels[1], cropVoxels[3], cropVoxels[5]}};
  if (!cropMm.empty()) r.cropMm = {{Vec3{cropMm[0], cropMm[2], cropMm[4]}, Vec3{cropMm[1], cropMm[3], cropMm[5]}}};
  r.downsample = downsample;
  return r;
}

LabelVolume InputOptions::loadLabelsOnInputGrid(const std::filesystem::path& path) const {
  io::LoadOptions o;
  o.region = region();
  o.allowOutsideData = allowOutsideData;
  return io::loadLabels(path, o);
}

io::LoadOptions InputOptions::toLoadOptions(Progress* progress) const {
  io::LoadOptions o;
  o.seriesUid = seriesUid;
  o.progress = progress;
  o.region = region();
  o.allowOutsideData = allowOutsideData;
  o.repairSlices = !noSliceRepair;
  if (!rescale.empty()) o.rescale = std::pair{rescale[0], rescale[1]};
  if (!rawDims.empty()) {
    io::RawLayout r;
    r.dims = {rawDims[0], rawDims[1], rawDims[2]};
    r.type = parseVoxelType(rawType);
    r.endian = rawEndian == "big" ? io::Endian::Big : io::Endian::Little;
    if (!rawSpacing.empty()) r.spacing = {rawSpacing[0], rawSpacing[1], rawSpacing[2]};
    if (!rawOrigin.empty()) r.origin = {rawOrigin[0], rawOrigin[1], rawOrigin[2]};
    if (!rawDirection.empty())
      for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 3; ++col) r.direction(row, col) = rawDirection[static_cast<size_t>(row * 3 + col)];
    r.headerBytes = rawHeader;
    o.raw = r;
  } else if (!rawSpacing.empty() || !rawOrigin.empty() || !rawDirection.empty()) {
    throw Error("--raw-spacing/--raw-origin/--raw-direction need --raw-dims");
  }
  return o;
}

void TableRemovalOptions::addTo(CLI::App& cmd) {
  cmd.add_flag("--remove-table", enabled,
               "remove the CT table, pads and head holders: keep every body part above air at least "
               "--table-min-part-volume large and --table-min-part-thickness thick (two legs, two feet)");
  addFlags(cmd, params, segmentation::bodyMaskParamsTable(), {}, "table_");
}

AnyVolume TableRemovalOptions::apply(AnyVolume volume, const std::filesystem::path& path) {
  if (!enabled) return volume;
  segmentation::BodyMaskReport r;
  {
    ProgressBar bar;
    volume = app::withoutCtTable(volume, path, params, bar.progress(), &r);
  }
  std::cerr << app::tableRemovalSummary(r) << "\n";
  report = r;
  return volume;
}

segmentation::Mask TableRemovalOptions::bodyMask(const AnyVolume& volume, const std::filesystem::path& path) {
  segmentation::BodyMaskReport r;
  segmentation::Mask body;
  {
    ProgressBar bar;
    body = app::ctBodyMask(volume, path, params, bar.progress(), &r);
  }
  std::cerr << app::tableRemovalSummary(r) << "\n";
  report = r;
  return body;
}

void TableRemovalOptions::addToReport(nlohmann::json& j) const {
  if (report) j["table_removal"] = app::tableRemovalJson(*report);
}

void FigureOptions::addTo(CLI::App& cmd, LabelSource source) {
  cmd.add_flag("--scale-bar", annotations.scaleBar,
               "draw a scale bar in mm (exact for --fov 0; in perspective it holds at the centre's depth)");
  cmd.add_option("--scale-bar-mm", annotations.scaleBarMm, "scale bar length (default: a round length near a fifth of the width)");
  cmd.add_flag("--orientation", annotations.orientation, "draw the orientation letters (A/P, L/R, S/I) at the edges");
  if (source == LabelSource::Input)
    cmd.add_flag("--labels", labelFlag, "name the visible structures, with leader lines");
  else if (source == LabelSource::OtherOption)
    cmd.add_flag("--name-structures", labelFlag, "name the structures of the --labels map, with leader lines that follow them");
  else
    cmd.add_option("--label-map", labelMap, "label map on the volume's grid: name its visible structures, with leader lines");
  cmd.add_option("--label-ids", labelIds, "structures to name (default: every id of the label table)")->delimiter(',');
  cmd.add_option("--label-name", labelNames,
                 "text of a structure's label instead of its table name: NAME=TEXT or ID=TEXT, e.g. "
                 "--label-name bone=\"Tibia and fibula\" (repeat for more)");
  cmd.add_option("--label-size", annotations.textHeightPx,
                 "height of the annotation text's capitals in pixels (labels, scale bar, orientation letters; "
                 "default: scaled with the figure)")
      ->check(CLI::Range(4.0, 400.0));
  cmd.add_flag("--annotate", annotateAll, "scale bar and orientation letters (and labels with --label-map / --labels)");
}

render::AnnotationOptions FigureOptions::resolved(bool haveLabels) const {
  render::AnnotationOptions o = annotations;
  if (annotateAll) o.scaleBar = o.orientation = true;
  o.labels = wantsLabels() && haveLabels;
  for (const std::string& n : labelNames) {
    const auto eq = n.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == n.size())
      throw Error("--label-name '" + n + "': expected NAME=TEXT or ID=TEXT");
    o.displayNames.emplace_back(n.substr(0, eq), n.substr(eq + 1));
  }
  return o;
}

render::AnnotationLayout FigureOptions::apply(RgbaImage& image, const Geometry& volume,
                                              const render::RenderSettings& settings,
                                              const std::vector<render::StructureAnchor>& anchors) const {
  if (!any()) return {};
  return render::annotate(image, render::Projection(volume, settings), resolved(true), anchors);
}

ProgressBar::ProgressBar()
    : progress_([this](const std::string& stage, double f) { report(stage, f); }),
      start_(std::chrono::steady_clock::now()),
      tty_(::isatty(STDERR_FILENO) != 0) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::report(const std::string& stage, double fraction) {
  if (secondsSince(start_) < 1.0) return;
  if (tty_) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth + 0.5);
    std::fprintf(stderr, "\r%-28.28s [%s%s] %3d%%", stage.c_str(), std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, ' ').c_str(), static_cast<int>(fraction * 100 + 0.5));
    std::fflush(stderr);
    shown_ = true;
  } else {
    const int quarter = static_cast<int>(fraction * 4);
    if (stage != lastStage_ || quarter != lastQuarter_) {
      std::fprintf(stderr, "%s: %d%%\n", stage.c_str(), quarter * 25);
      lastStage_ = stage;
      lastQuarter_ = quarter;
    }
  }
}

void ProgressBar::finish() {
  if (shown_ && tty_) std::fprintf(stderr, "\r%*s\r", 70, "");
  shown_ = false;
}

void printLoadWarnings(const std::filesystem::path& input, const std::vector<std::string>& warnings) {
  for (const auto& w : warnings) std::cerr << "warning: " << input.string() << ": " << w << "\n";
}

std::array<float, 4> backgroundColour(const std::vector<double>& c) {
  return {float(c[0]), float(c[1]), float(c[2]), c.size() > 3 ? float(c[3]) : 1.f};
}

io::LoadedVolume loadWithProgress(const std::filesystem::path& path, const InputOptions& in,
                                  bool quiet) {
  ProgressBar bar;
  io::LoadedVolume v = io::loadVolume(path, in.toLoadOptions(&bar.progress()));
  bar.finish();
  if (!quiet) printLoadWarnings(path, v.warnings);
  return v;
}

nlohmann::json toJson(const Vec3& v) { return {v.x, v.y, v.z}; }

nlohmann::json toJson(const Mat3& m) {
  return {{m(0, 0), m(0, 1), m(0, 2)}, {m(1, 0), m(1, 1), m(1, 2)}, {m(2, 0), m(2, 1), m(2, 2)}};
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::pair<int, int> parseSize(const std::string& text) {
  int w = 0, h = 0;
  char x = 0;
  if (std::sscanf(text.c_str(), "%d%c%d", &w, &x, &h) != 3 || (x != 'x' && x != 'X') || w <= 0 ||
      h <= 0)
    throw Error("invalid size '" + text + "' (expected WxH, e.g. 1024x768)");
  return {w, h};
}

std::string& commandLine() {
  static std::string line;
  return line;
}

void addForceFlag(CLI::App& cmd, bool& force) {
  cmd.add_flag("--force", force,
               "let an output folder replace a folder Vellum wrote as another kind of output (never a folder "
               "Vellum did not write)");
}

std::vector<double> parseNumberList(const std::string& text, size_t n, const char* what) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw Error(std::string(what) + ": '" + text + "' is not " + std::to_string(n) + " comma-separated numbers");
    }
  }
  if (v.size() != n) throw Error(std::string(what) + ": '" + text + "' needs " + std::to_string(n) + " numbers");
  return v;
}

std::array<uint8_t, 3> parseRgb255(const std::string& text, const char* what) {
  const std::vector<double> c = parseNumberList(text, 3, what);
  std::array<uint8_t, 3> rgb{};
  for (int i = 0; i < 3; ++i) {
    if (!(c[i] >= 0 && c[i] <= 255)) throw Error(std::string(what) + ": components must be in 0..255");
    rgb[i] = static_cast<uint8_t>(c[i]);
  }
  return rgb;
}

}  // namespace vellum::cli
