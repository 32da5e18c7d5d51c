#include "cli_util.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "cli_params.hpp"
#include "vellum/app/table_removal.hpp"
#include "vellum/core/error.hpp"

namespace vellum::cli {

namespace {
// The options that name inputs (true) and outputs (false). Only looked up with the live app's
// options, never dereferenced: an app that is gone (the demo's inner commands) leaves a
// harmless entry.
std::map<const CLI::Option*, bool>& pathOptions() {
  static std::map<const CLI::Option*, bool> options;
  return options;
}
}  // namespace

std::function<void()> resultCommand(std::function<int()> work) {
  return [work = std::move(work)] {
    int code = ExitCode::Success;
    try {
      code = work();
    } catch (const Cancelled&) {
      throw;
    } catch (const std::exception& e) {
      std::cerr << "vellum: error: " << e.what() << "\n";
      code = ExitCode::Usage;
    }
    std::cout.flush();
    if (code != ExitCode::Success) throw CLI::RuntimeError(code);  // main.cpp exits with it, silently
  };
}

CLI::Option* markPath(CLI::Option* option, bool input) {
  pathOptions()[option] = input;
  return option;
}

bool isCommandInput(const CLI::App& app, const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto normal = [&ec](const fs::path& p) { return fs::weakly_canonical(fs::absolute(p, ec), ec).lexically_normal(); };
  const fs::path p = normal(path);
  bool input = false;
  for (const CLI::App* sub : app.get_subcommands())
    for (const CLI::Option* o : sub->get_options()) {
      const auto kind = pathOptions().find(o);
      if (kind == pathOptions().end()) continue;
      for (const std::string& v : o->results()) {
        if (v.empty()) continue;
        const fs::path named = normal(v);
        // The path itself, or a file inside its folder (a DICOM slice, a shape folder's file).
        if (std::mismatch(named.begin(), named.end(), p.begin(), p.end()).first != named.end()) continue;
        if (!kind->second) return false;  // an output's problem (also one that is an input)
        input = true;
      }
    }
  return input;
}

const params::Table<InputOptions>& inputOptionsTable() {
  using IO = InputOptions;
  static const params::Table<IO> t{
      params::text<IO>("series", &IO::seriesUid, {"Series", "DICOM: SeriesInstanceUID to load (default: largest CT series)", ""}),
      params::text<IO>("raw_type", &IO::rawType, {"RAW voxel type", "bare .raw without sidecar: the voxel type", ""},
                       {"int16", "uint8", "uint16", "float32"}),
      params::text<IO>("raw_endian", &IO::rawEndian, {"RAW byte order", "bare .raw: the byte order", ""}, {"little", "big"}),
      params::integer<IO>("raw_header", &IO::rawHeader,
                          {"RAW header", "bare .raw: bytes to skip before the voxels", "bytes", 0}),
      params::integer<IO>("downsample", &IO::downsample,
                          {"Downsample", "reduce every N^3 block to one voxel on load (mean; label maps: most frequent id)",
                           "", 1, 16}),
      params::flag<IO>("allow_outside_data", &IO::allowOutsideData,
                       {"Data outside", ".nhdr/.mhd: read a data file the header names outside its own folder (absolute, "
                                        "'..', a symlink leading out)", ""}),
      params::flag<IO>("no_slice_repair", &IO::noSliceRepair,
                       {"No slice repair", "DICOM: keep a single mis-registered slice as it is (by default it is replaced "
                                           "by interpolating its neighbours, with a warning naming it)", ""}),
  };
  return t;
}

const ListTable<InputOptions>& inputListTable() {
  using IO = InputOptions;
  // Unset when absent (a table's vector is always set).
  static const ListTable<IO> t{
      numbers<IO>("raw_dims", &IO::rawDims, 3, "X Y Z",
                  {"RAW dimensions", "bare .raw without sidecar: dimensions X Y Z", "voxels"}),
      numbers<IO>("raw_spacing", &IO::rawSpacing, 3, "SX SY SZ", {"RAW spacing", "bare .raw: spacing", "mm"}),
      numbers<IO>("raw_origin", &IO::rawOrigin, 3, "X Y Z", {"RAW origin", "bare .raw: origin", "mm"}),
      numbers<IO>("raw_direction", &IO::rawDirection, 9, "9 NUMBERS",
                  {"RAW direction", "bare .raw: direction matrix, row by row (as `vellum info` prints it)", ""}),
      numbers<IO>("rescale", &IO::rescale, 2, "SLOPE INTERCEPT",
                  {"Rescale", "stored value * SLOPE + INTERCEPT = HU (e.g. 1 -1024 for CT numbers 0..4095 in a bare "
                              "RAW); the volume is then CT", ""}),
      numbers<IO>("crop", &IO::cropVoxels, 6, "I0 I1 J0 J1 K0 K1",
                  {"Crop", "keep voxels i0 i1 j0 j1 k0 k1 only (inclusive indices; label maps of the command get the "
                           "same region)", "voxels"}),
      numbers<IO>("crop_mm", &IO::cropMm, 6, "X0 X1 Y0 Y1 Z0 Z1",
                  {"Crop box", "keep the voxels inside the box x0 x1 y0 y1 z0 z1 (LPS)", "mm"}),
  };
  return t;
}

void InputOptions::addTo(CLI::App& cmd) {
  addFlags(cmd, *this, inputOptionsTable());
  addLists(cmd, *this, inputListTable());
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

const params::Table<TableRemovalOptions>& tableRemovalTable() {
  using T = TableRemovalOptions;
  static const params::Table<T> t = [] {
    params::Table<T> rows{params::flag<T>(
        "remove_table", &T::enabled,
        {"Remove table", "remove the CT table, pads and head holders: keep every body part above air at least "
                         "--table-min-part-volume large and --table-min-part-thickness thick (two legs, two feet)",
         ""})};
    for (auto& f : params::embed<T, segmentation::BodyMaskParams>("table_", &T::params, segmentation::bodyMaskParamsTable()))
      rows.push_back(std::move(f));
    return rows;
  }();
  return t;
}

void TableRemovalOptions::addTo(CLI::App& cmd) { addFlags(cmd, *this, tableRemovalTable()); }

namespace {
/// Runs one table-removal step with a progress bar, prints its one-line summary and keeps its report.
template <class Step>
auto withTableReport(std::optional<segmentation::BodyMaskReport>& report, Step step) {
  segmentation::BodyMaskReport r;
  auto out = [&] {
    ProgressBar bar;
    return step(bar.progress(), &r);
  }();
  std::cerr << app::tableRemovalSummary(r) << "\n";
  report = r;
  return out;
}
}  // namespace

AnyVolume TableRemovalOptions::apply(AnyVolume volume, const std::filesystem::path& path) {
  if (!enabled) return volume;
  return withTableReport(report, [&](Progress& p, segmentation::BodyMaskReport* r) {
    return app::withoutCtTable(volume, path, params, p, r);
  });
}

segmentation::Mask TableRemovalOptions::bodyMask(const AnyVolume& volume, const std::filesystem::path& path) {
  return withTableReport(report, [&](Progress& p, segmentation::BodyMaskReport* r) {
    return app::ctBodyMask(volume, path, params, p, r);
  });
}

void TableRemovalOptions::addToReport(nlohmann::json& j) const {
  if (report) j["table_removal"] = app::tableRemovalJson(*report);
}

const params::Table<FigureOptions>& figureOptionsTable() {
  using F = FigureOptions;
  using A = render::AnnotationOptions;
  static const params::Table<F> t{
      params::flag<F>("scale_bar", params::nested(&F::annotations, &A::scaleBar),
                      {"Scale bar", "draw a scale bar in mm (exact for --fov 0; in perspective it holds at the centre's "
                                    "depth)", ""}),
      params::real<F>("scale_bar_mm", params::nested(&F::annotations, &A::scaleBarMm),
                      {"Scale bar length", "0: a round length near a fifth of the width", "mm", 0}),
      params::flag<F>("orientation", params::nested(&F::annotations, &A::orientation),
                      {"Orientation", "draw the orientation letters (A/P, L/R, S/I) at the edges", ""}),
      params::real<F>("label_size", params::nested(&F::annotations, &A::textHeightPx),
                      {"Label size", "height of the annotation text's capitals (labels, scale bar, orientation "
                                     "letters); 0: scaled with the figure, else at least 4",
                       "px", 0, 400}),
      params::flag<F>("annotate", &F::annotateAll,
                      {"Annotate", "scale bar and orientation letters (and labels with --label-map / --labels)", ""}),
      params::flag<F>("labels", &F::labelFlag,
                      {"Labels", "`vellum illustrate`: name the visible structures, with leader lines", ""}),
      params::flag<F>("name_structures", &F::labelFlag,
                      {"Name structures", "`vellum animate`: name the structures of the --labels map, with leader "
                                          "lines that follow them", ""}),
  };
  return t;
}

const ListTable<FigureOptions>& figureListTable() {
  using F = FigureOptions;
  static const ListTable<F> t{
      commaList<F>("label_ids", &F::labelIds, "ID,ID..",
                   {"Label ids", "structures to name (default: every id of the label table)", ""}),
      repeated<F>("label_name", &F::labelNames, "NAME=TEXT",
                  {"Label name", "text of a structure's label instead of its table name: NAME=TEXT or ID=TEXT, e.g. "
                                 "--label-name bone=\"Tibia and fibula\" (repeat for more)", ""}),
  };
  return t;
}

void FigureOptions::addTo(CLI::App& cmd, LabelSource source) {
  // The label switch has the name of the command's label source (a file: --label-map).
  std::set<std::string> skip{"labels", "name_structures"};
  if (source == LabelSource::Input) skip.erase("labels");
  if (source == LabelSource::OtherOption) skip.erase("name_structures");
  const auto flags = addFlags(cmd, *this, figureOptionsTable(), skip);
  flags.at("label_size")->check([](const std::string& v) {  // 0 (automatic) or readable
    const double px = std::atof(v.c_str());
    return px == 0 || px >= 4 ? std::string() : std::string("0 (automatic) or at least 4 pixels");
  });
  if (source == LabelSource::File)
    addInput(cmd, "--label-map", labelMap, "label map on the volume's grid: name its visible structures, with leader lines");
  addLists(cmd, *this, figureListTable());
}

const params::Table<FigureFlags>& figureFlagsTable() {
  using F = FigureFlags;
  static const params::Table<F> t{
      params::text<F>("view", &F::view,
                      {"Views", "anterior | posterior | left | right | lateral (= left) | superior | inferior | AZ | "
                                "AZ:EL (degrees), or a comma list: one figure each from one upload, suffixed -VIEW "
                                "(overrides --azimuth/--elevation); empty: the camera's", ""}),
      params::flag<F>("plate", &F::plate,
                      {"Plate", "one contact sheet at --out instead of a file each: a row per preset or style, a "
                                "column per view", ""}),
      params::text<F>("size", &F::size, {"Size", "image size WxH, up to 4096x4096", "px"}),
      params::vector<F>("pan", &F::pan,
                        {"Pan", "shift of the look-at point (x y z, or x,y,z), after the framing", "mm"}),
      params::text<F>("background", &F::background,
                      {"Background", "background colour R,G,B or R,G,B,A, each 0..1 (spaces may stand for the "
                                     "commas); empty: the preset's or style's", ""}),
      params::flag<F>("transparent", &F::transparent, {"Transparent", "transparent background (PNG/TIFF alpha)", ""}),
  };
  return t;
}

void FigureFlags::addTo(CLI::App& cmd) {
  addFlags(cmd, *this, figureFlagsTable(), {"background"});
  // --background: the table's text, also as three or four words (the studio writes "R G B A").
  const auto* f = params::findField(figureFlagsTable(), "background");
  cmd.add_option_function<std::vector<std::string>>(
         "--background",
         [this, f](const std::vector<std::string>& words) {
           params::parse(*f, *this, joinWords(words));
           parseColour(background, "--background", true);  // a bad colour is a usage error now
         },
         flagHelp(f->info, params::rangeText(f->kind, f->info, f->choices)))
      ->expected(1, 4)
      ->type_name("R,G,B[,A]");
}

std::pair<int, int> FigureFlags::sizePixels() const { return parseSize(size); }

std::vector<app::FigureView> FigureFlags::views(double elevationDeg) const {
  std::vector<app::FigureView> out;
  if (!view.empty())
    for (const auto& v : app::splitList(view, "--view")) out.push_back(app::parseView(v, elevationDeg));
  return out;
}

std::optional<std::array<float, 4>> FigureFlags::backgroundColour() const {
  if (background.empty()) return std::nullopt;
  return parseColour(background, "--background", true);
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

void printTableRemoval(const std::string& summary) {
  if (!summary.empty()) std::cerr << summary << "\n";
}

void printLoadWarnings(const std::filesystem::path& input, const std::vector<std::string>& warnings) {
  for (const auto& w : warnings) std::cerr << "warning: " << input.string() << ": " << w << "\n";
}

std::array<float, 4> parseColour(const std::string& text, const char* what, bool alpha, double scale) {
  std::string spaced = text;
  std::replace(spaced.begin(), spaced.end(), ',', ' ');
  std::istringstream words(spaced);
  std::vector<double> c;
  std::string w;
  const std::string range = scale == 1.0 ? "0..1" : "0..255";
  const std::string form = alpha ? "R,G,B or R,G,B,A" : "R,G,B";
  while (words >> w) {
    try {
      size_t used = 0;
      c.push_back(std::stod(w, &used));
      if (used != w.size()) throw std::invalid_argument(w);
    } catch (const std::exception&) {
      throw Error(std::string(what) + " '" + text + "': expected " + form + " with numbers in " + range);
    }
  }
  if (c.size() != 3 && !(alpha && c.size() == 4))
    throw Error(std::string(what) + " '" + text + "': expected " + form + " (" + std::to_string(c.size()) + " numbers)");
  std::array<float, 4> rgba{0.f, 0.f, 0.f, 1.f};
  for (size_t i = 0; i < c.size(); ++i) {
    if (!(c[i] >= 0 && c[i] <= scale))
      throw Error(std::string(what) + " '" + text + "': components must be in " + range);
    rgba[i] = static_cast<float>(c[i] / scale);
  }
  return rgba;
}

void addColourOption(CLI::App& cmd, std::vector<ColourArg>& target, const std::string& valueName,
                     const std::string& help) {
  cmd.add_option_function<std::vector<std::string>>(
         "--colour", [&target](const std::vector<std::string>& v) { for (const auto& t : v) target.push_back({t, 1.0}); },
         help + " (R, G, B each 0..1)")
      ->type_name(valueName);
  // The old spelling with its old 0..255 scale: hidden (group ""), kept for old commands.
  cmd.add_option_function<std::vector<std::string>>(
         "--color", [&target](const std::vector<std::string>& v) { for (const auto& t : v) target.push_back({t, 255.0}); },
         help + " (old spelling: R, G, B each 0..255)")
      ->group("");
}

std::array<uint8_t, 3> colourBytes(const ColourArg& arg, const char* what) {
  const std::array<float, 4> c = parseColour(arg.text, arg.scale == 1.0 ? what : "--color", false, arg.scale);
  std::array<uint8_t, 3> rgb{};
  for (int i = 0; i < 3; ++i) rgb[i] = static_cast<uint8_t>(std::lround(c[i] * 255.0));
  return rgb;
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

std::string worstJacobianText(const nlohmann::json& after) {
  std::ostringstream s;
  s << "min Jacobian " << after.value("min_jacobian", 0.0);
  if (const auto at = after.find("min_jacobian_at_mm"); at != after.end() && at->is_array() && at->size() == 3)
    s << " at (" << (*at)[0].get<double>() << ", " << (*at)[1].get<double>() << ", " << (*at)[2].get<double>() << ") mm";
  return s.str();
}

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
    throw Error("--size '" + text + "': expected WxH, e.g. 1024x768");
  return {w, h};
}

std::string& commandLine() {
  static std::string line;
  return line;
}

void addForceFlag(CLI::App& cmd, bool& force) { addFlags(cmd, force, forceFlagTable()); }

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


}  // namespace vellum::cli
