#pragma once
// Shared pieces of the `vellum` subcommands: input options, progress bar, output checks,
// JSON helpers.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <filesystem>
#include <functional>
#include <type_traits>
#include <optional>
#include <string>
#include <vector>

#include "cli_params.hpp"
#include "vellum/app/figures.hpp"
#include "vellum/app/outputs.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::cli {

/// Exit codes of every command, decided in one place (main.cpp; docs/user-guide.md).
namespace ExitCode {
inline constexpr int Success = 0;
inline constexpr int Failure = 1;    ///< a runtime failure (an output not written, no GL context, ...)
inline constexpr int Usage = 2;      ///< a bad flag or value, a missing or unreadable input, bad JSON
inline constexpr int Cancelled = 130;
}  // namespace ExitCode

/// The callback of a command whose exit 1 is its result ("checks failed": compare, qa): runs
/// `work`, which returns the exit code, and reports any error as exit 2, so that 1 keeps one
/// meaning; cancelling stays 130.
std::function<void()> resultCommand(std::function<int()> work);

/// Marks `option` as naming an input, or an output (addInput / addOutput do; a table's path
/// field after addFlags).
CLI::Option* markPath(CLI::Option* option, bool input);
inline CLI::Option* markInput(CLI::Option* option) { return markPath(option, true); }

/// The I/O options, one line each: `addInput` for a file or folder the command reads (a
/// vellum::FileError naming it, or a file inside it, exits 2: an input error), `addOutput`
/// for one it writes (a failure there exits 1, also where the output is an input too: the
/// output policy's refusal). `name` as CLI11 takes it ("input", "--labels,-l"); the target
/// is a path or string member of the command's request.
template <class T>
CLI::Option* addInput(CLI::App& cmd, const std::string& name, T& target, const std::string& help) {
  return markPath(cmd.add_option(name, target, help), true);
}
template <class T>
CLI::Option* addOutput(CLI::App& cmd, const std::string& name, T& target, const std::string& help) {
  return markPath(cmd.add_option(name, target, help), false);
}
/// Whether a problem with `path` is an input error: it is (or lies in) the value of an input
/// option of the subcommand `app` parsed, and not in an output's.
bool isCommandInput(const CLI::App& app, const std::filesystem::path& path);

/// Options every command that reads a volume accepts: --series and the bare-.raw layout.
struct InputOptions {
  std::string seriesUid;
  std::vector<int64_t> rawDims;
  std::string rawType = "int16";
  std::vector<double> rawSpacing;
  std::vector<double> rawOrigin;
  std::vector<double> rawDirection;
  std::string rawEndian = "little";
  uint64_t rawHeader = 0;
  std::vector<int64_t> cropVoxels;  ///< i0 i1 j0 j1 k0 k1
  std::vector<double> cropMm;       ///< x0 x1 y0 y1 z0 z1
  int downsample = 1;
  std::vector<double> rescale;      ///< slope intercept
  bool allowOutsideData = false;    ///< --allow-outside-data (io::LoadOptions::allowOutsideData)
  bool noSliceRepair = false;       ///< --no-slice-repair (io::LoadOptions::repairSlices off)

  /// Adds inputOptionsTable()'s flags (--series, --raw-type, --raw-endian, --raw-header,
  /// --downsample, --allow-outside-data, --no-slice-repair) and the number lists --raw-dims,
  /// --raw-spacing, --raw-origin, --raw-direction, --rescale, --crop, --crop-mm to `cmd`.
  void addTo(CLI::App& cmd);
  /// Turns the flags into io::LoadOptions (with `progress` attached).
  io::LoadOptions toLoadOptions(Progress* progress) const;
  /// --crop / --crop-mm / --downsample.
  Region region() const;
  /// A label map on the input volume's grid, reduced by the same region as the volume.
  LabelVolume loadLabelsOnInputGrid(const std::filesystem::path& path) const;
};

/// The single-valued flags of InputOptions, described once (docs/parameters.md).
const params::Table<InputOptions>& inputOptionsTable();
/// Its number lists (--raw-dims, --raw-spacing, --raw-origin, --raw-direction, --rescale,
/// --crop, --crop-mm).
const ListTable<InputOptions>& inputListTable();

/// --remove-table and its parameters (--table-air-threshold, --table-opening-radius,
/// --table-min-part-volume, --table-min-part-thickness): tableRemovalTable().
struct TableRemovalOptions {
  bool enabled = false;
  segmentation::BodyMaskParams params;
  std::optional<segmentation::BodyMaskReport> report;  ///< what the last apply()/bodyMask() removed
  void addTo(CLI::App& cmd);
  /// The volume without the table when enabled (a CT is required), else unchanged; prints
  /// the one-line summary (app::tableRemovalSummary) to stderr.
  AnyVolume apply(AnyVolume volume, const std::filesystem::path& path);
  /// The body mask (app::ctBodyMask) with the same summary; for label maps on the CT's grid.
  segmentation::Mask bodyMask(const AnyVolume& volume, const std::filesystem::path& path);
  /// Adds "table_removal" (app::tableRemovalJson) to a command's report when it ran.
  void addToReport(nlohmann::json& report) const;
};

/// --remove-table and BodyMaskParams' fields as --table-<key>, described once.
const params::Table<TableRemovalOptions>& tableRemovalTable();

/// --scale-bar, --scale-bar-mm, --orientation, --label-ids, --annotate (and, where a command
/// takes one, --label-map): figure annotations for `render`, `illustrate` and `animate`, bound
/// here and handed to the app requests as render::AnnotationOptions (resolved()).
struct FigureOptions {
  render::AnnotationOptions annotations;
  std::vector<uint16_t> labelIds;
  bool annotateAll = false;
  bool labelFlag = false;  ///< --labels (commands whose structures come with their input)
  std::string labelMap;    ///< --label-map (commands without a label map of their own)
  std::vector<std::string> labelNames;  ///< --label-name KEY=TEXT (render::AnnotationOptions::displayNames)

  /// Where the names come from: a --label-map FILE, the command's own label map (illustrate:
  /// the shape's segments; flag --labels), or the label map another option already loads
  /// (animate: the rigid-bone --labels; flag --name-structures).
  enum class LabelSource { File, Input, OtherOption };
  void addTo(CLI::App& cmd, LabelSource source);
  /// The annotations to draw (--annotate resolved), labels only when a label map is at hand.
  render::AnnotationOptions resolved(bool haveLabels) const;
  bool wantsLabels() const { return labelFlag || !labelMap.empty(); }
  bool any() const { return annotateAll || annotations.scaleBar || annotations.orientation || wantsLabels(); }
  /// Sets a figure request's annotations (resolved(), labels when asked for) and label ids.
  template <class Request>
  void setAnnotations(Request& r) const {
    r.annotations = resolved(wantsLabels());
    r.labelIds = labelIds;
  }
  /// Draws what was asked for into `image` rendered with `settings` around `volume`, with the
  /// labels' anchors found by the caller (illustrate: only drawn segments).
  render::AnnotationLayout apply(RgbaImage& image, const Geometry& volume, const render::RenderSettings& settings,
                                 const std::vector<render::StructureAnchor>& anchors) const;
};

/// The switches and numbers of FigureOptions (--scale-bar, --scale-bar-mm, --orientation,
/// --label-size, --annotate, --labels / --name-structures), described once (docs/parameters.md).
const params::Table<FigureOptions>& figureOptionsTable();
/// Its lists: --label-ids, --label-name.
const ListTable<FigureOptions>& figureListTable();

/// The figure flags `render` and `illustrate` share, described once (figureFlagsTable()):
/// --view, --plate, --size, --pan, --background, --transparent.
struct FigureFlags {
  std::string view;               ///< "anterior,lateral", "30:10" (app::parseView)
  bool plate = false;             ///< one contact sheet instead of a file each
  std::string size = "512x512";  ///< WxH
  std::array<double, 3> pan{0, 0, 0};  ///< mm, added to the look-at point
  std::string background;         ///< "" (the command's own) or R,G,B[,A] in 0..1
  bool transparent = false;

  void addTo(CLI::App& cmd);
  /// --size as width and height.
  std::pair<int, int> sizePixels() const;
  /// --view as views (empty: the camera's azimuth and elevation; `elevationDeg` for "AZ").
  std::vector<app::FigureView> views(double elevationDeg) const;
  /// --background as RGBA, or nullopt when not given.
  std::optional<std::array<float, 4>> backgroundColour() const;
};
const params::Table<FigureFlags>& figureFlagsTable();

/// A progress bar on stderr. It stays silent for the first second (fast work prints
/// nothing); on a terminal it redraws one line, otherwise it prints a line per 25%.
class ProgressBar {
 public:
  ProgressBar();
  ~ProgressBar();
  Progress& progress() { return progress_; }
  /// Clears the bar line (call before printing results).
  void finish();

 private:
  void report(const std::string& stage, double fraction);
  Progress progress_;
  std::chrono::steady_clock::time_point start_;
  bool tty_ = false;
  bool shown_ = false;
  int lastQuarter_ = -1;
  std::string lastStage_;
};

/// Prints a loader's warnings about `input` to stderr, one "warning: INPUT: ..." line each.
void printLoadWarnings(const std::filesystem::path& input, const std::vector<std::string>& warnings);

/// The one colour syntax of the command line: "R,G,B" with each component in 0..1 (the scale of
/// style files and of every colour in the parameter tables); spaces may stand for the commas
/// ("R G B", how --background was first written). With `alpha`, a fourth number A (default
/// 1). `scale` 255: the old `--color` spelling's 0..255 components. Throws vellum::Error
/// naming `what` (the flag).
std::array<float, 4> parseColour(const std::string& text, const char* what, bool alpha = false, double scale = 1.0);

/// A colour as typed: its text and its scale (1, or 255 for the old spelling --color).
struct ColourArg {
  std::string text;
  double scale = 1.0;
};
/// Adds --colour `valueName` (repeatable when `target` grows) and its old spelling --color
/// (components 0..255, hidden from --help, so that old commands still work).
void addColourOption(CLI::App& cmd, std::vector<ColourArg>& target, const std::string& valueName,
                     const std::string& help);
/// `arg` as 8-bit RGB (a label table's colour).
std::array<uint8_t, 3> colourBytes(const ColourArg& arg, const char* what = "--colour");


/// The command line as typed ("vellum render ..."), for reports; main() sets it.
std::string& commandLine();

/// Sets the request's volume input (--series, the raw layout, --crop, --downsample), its
/// --remove-table when `table` asks for it, and the command line its report keeps.
template <class Request>
void setVolumeInput(Request& r, const InputOptions& in, const TableRemovalOptions* table = nullptr) {
  r.load = in.toLoadOptions(nullptr);
  if constexpr (requires { r.removeTable; })
    if (table && table->enabled) r.removeTable = table->params;
  r.commandLine = commandLine();
}

/// Prints a table-removal summary line to stderr (nothing when empty).
void printTableRemoval(const std::string& summary);

/// Runs a command's pipeline, `run(request, progress)` (app::runRender ...), behind a progress
/// bar, then prints to stderr what the run noticed: the loader's warnings about the input and,
/// where the result has one, the table-removal line.
template <class Request, class Run>
auto runPipeline(const Request& request, Run run) {
  auto result = [&] {
    ProgressBar bar;
    return run(request, bar.progress());
  }();
  printLoadWarnings(request.input, result.warnings);
  if constexpr (requires { result.tableRemoval; }) printTableRemoval(result.tableRemoval);
  return result;
}

/// Loads a volume with a progress bar; prints warnings to stderr unless `quiet`.
io::LoadedVolume loadWithProgress(const std::filesystem::path& path, const InputOptions& in,
                                  bool quiet = false);

// The output policy, the output's folder, JSON written atomically, no half-finished result:
// the rules the app pipelines follow too (vellum/app/outputs.hpp).
using app::ensureParentFolder;
using app::RunOutputs;
using app::writeJsonFile;
using io::OutputPlan;

/// --force: an output folder may replace a folder Vellum wrote as another kind of output (a
/// folder Vellum did not write is never replaced).
void addForceFlag(CLI::App& cmd, bool& force);


/// JSON for geometry pieces.
nlohmann::json toJson(const Vec3& v);
nlohmann::json toJson(const Mat3& m);  ///< row-major array of 3 rows

/// "min Jacobian J at (x, y, z) mm" from a rigidity report (`rigidity.after`): where the worst
/// fold is (the position is left out when the report has none).
std::string worstJacobianText(const nlohmann::json& after);

/// Seconds since `t0`.
double secondsSince(std::chrono::steady_clock::time_point t0);

/// Parses "WxH" (e.g. "1920x1080") into width and height; throws vellum::Error.
std::pair<int, int> parseSize(const std::string& text);

/// Exactly `n` comma-separated numbers ("x,y,z"); throws vellum::Error naming the flag `what`.
std::vector<double> parseNumberList(const std::string& text, size_t n, const char* what);

}  // namespace vellum::cli
