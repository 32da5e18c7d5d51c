#pragma once
// File > Export figure and Copy CLI command: the 3D view as a figure at any size, made by the
// CLI's own code (app::runRender, or app::runIllustrate when the view draws an illustration)
// on a worker, and the `vellum render` / `vellum illustrate` command line that writes the same
// file. Both come from one FigurePlan, so the figure and the command cannot drift apart.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "background_job.hpp"
#include "scene.hpp"
#include "vellum/app/illustrate_pipeline.hpp"
#include "vellum/app/render_pipeline.hpp"

namespace vellum::studio {

/// What the Export figure dialog asks.
struct FigureOptions {
  int width = 2048, height = 2048;  ///< 1..4096
  bool scaleBar = false, orientation = false;
  bool labels = false;  ///< name the visible structures (needs the label map saved to a file)
};

/// One figure of the 3D view: the request handed to the CLI's pipeline and the command line
/// that makes the CLI run the same request.
struct FigurePlan {
  bool illustrate = false;
  app::RenderRequest render;
  app::IllustrateRequest illustration;
  /// An edited style is written here (beside the figure) before the run and named by
  /// `--style`; empty when the style is a built-in preset (`--preset`).
  std::filesystem::path styleFile;
  illustration::Style style;  ///< what styleFile gets
  std::string command;  ///< `vellum render ...` or `vellum illustrate ...`
  /// What the 3D view shows that the figure leaves out (a deformation, unsaved labels ...),
  /// one short phrase each.
  std::vector<std::string> leftOut;
};

/// The `vellum render` line that writes the 3D view's ray cast at width x height into `out`
/// (the View panel's Copy CLI command): Export figure's render plan without annotations.
std::string renderCommand(const Scene& scene, const std::filesystem::path& out, int width, int height);

/// The plan for `scene`'s 3D view written to `out`. Throws vellum::Error when the view cannot
/// be written by the CLI (no volume; an illustration whose shapes have no folder).
FigurePlan planFigure(const Scene& scene, const std::filesystem::path& out, const FigureOptions& options);

/// Runs a plan on a worker with progress and cancel (the window keeps drawing).
class FigureJob {
 public:
  struct Outcome {
    std::string error;  ///< "" on success
    std::filesystem::path path;
    double seconds = 0;
  };
  FigureJob();
  /// False when an export is already running.
  bool start(FigurePlan plan);
  bool busy() const { return job_.busy(); }
  void cancel() { job_.cancel(); }
  std::pair<std::string, double> progress() const { return job_.progress(); }
  std::optional<Outcome> take() { return job_.take(); }

 private:
  BackgroundJob<Outcome> job_;
};

/// The studio's Export figure dialog and the last export's outcome (the window polls it once
/// a frame through StudioTools).
struct FigureExportState {
  FigureOptions options;
  char path[1024] = "figure.png";
  std::string command;  ///< the last Copy CLI command (also on the clipboard)
  std::string lastError, lastWritten;
  bool dialogOpen = false;
  FigureJob job;
};

}  // namespace vellum::studio
