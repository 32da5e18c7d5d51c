#pragma once
// The studio's measuring and figure tools (issue 22, sections 3 and 4), kept out of StudioApp:
// the ruler and angle in the slice views (measure_tools.hpp) and File > Export figure / Copy
// CLI command (export_figure.hpp). StudioApp owns one StudioTools and calls the hooks below.
#include <filesystem>
#include <optional>
#include <string>

#include "export_figure.hpp"
#include "measure_tools.hpp"

namespace vellum::studio {

class StudioApp;

struct StudioTools {
  Measurements measure;
  FigureExportState figure;
};

/// Plans the 3D view's figure at `out` with the dialog's options and starts it on the worker.
/// Throws vellum::Error when it cannot start (no volume, shapes without a folder, one running).
void startFigureExport(StudioApp& app, const std::filesystem::path& out);
/// The command line that writes that figure: put on the clipboard (GLFW's, through ImGui's
/// backend) and kept in the dialog's text field; returned.
std::string copyFigureCommand(StudioApp& app, const std::filesystem::path& out);
/// Once a frame: adopts a finished export (a notice, or the error box).
void pollStudioTools(StudioApp& app);
/// The panel section (Measure; Export figure...) and the Export figure window when open.
void studioToolsSection(StudioApp& app);
void drawFigureDialog(StudioApp& app);

}  // namespace vellum::studio
