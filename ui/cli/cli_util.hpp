#pragma once
// Shared pieces of the `vellum` subcommands: input options, progress bar, output checks,
// JSON helpers.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "vellum/app/outputs.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/segmentation/body_mask.hpp"

namespace vellum::cli {

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

  /// Adds --series, --raw-dims, --raw-type, --raw-spacing, --raw-origin, --raw-direction,
  /// --raw-endian, --raw-header, --rescale, --crop, --crop-mm, --downsample,
  /// --allow-outside-data, --no-slice-repair to `cmd`.
  void addTo(CLI::App& cmd);
  /// Turns the flags into io::LoadOptions (with `progress` attached).
  io::LoadOptions toLoadOptions(Progress* progress) const;
  /// --crop / --crop-mm / --downsample.
  Region region() const;
  /// A label map on the input volume's grid, reduced by the same region as the volume.
  LabelVolume loadLabelsOnInputGrid(const std::filesystem::path& path) const;
};

/// --remove-table and its parameters (--table-air-threshold, --table-opening-radius,
/// --table-min-part-volume, --table-min-part-thickness).
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
  /// Draws what was asked for into `image` rendered with `settings` around `volume`, with the
  /// labels' anchors found by the caller (illustrate: only drawn segments).
  render::AnnotationLayout apply(RgbaImage& image, const Geometry& volume, const render::RenderSettings& settings,
                                 const std::vector<render::StructureAnchor>& anchors) const;
};

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

/// --background R G B [A] in 0..1 (alpha 1 when three numbers are given).
std::array<float, 4> backgroundColour(const std::vector<double>& rgba);

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

/// The command line as typed ("vellum render ..."), for reports; main() sets it.
std::string& commandLine();

/// JSON for geometry pieces.
nlohmann::json toJson(const Vec3& v);
nlohmann::json toJson(const Mat3& m);  ///< row-major array of 3 rows

/// Seconds since `t0`.
double secondsSince(std::chrono::steady_clock::time_point t0);

/// Parses "WxH" (e.g. "1920x1080") into width and height; throws vellum::Error.
std::pair<int, int> parseSize(const std::string& text);

/// Exactly `n` comma-separated numbers ("x,y,z"); throws vellum::Error naming the flag `what`.
std::vector<double> parseNumberList(const std::string& text, size_t n, const char* what);
/// "R,G,B" with each component in 0..255; throws vellum::Error naming the flag `what`.
std::array<uint8_t, 3> parseRgb255(const std::string& text, const char* what);

}  // namespace vellum::cli
