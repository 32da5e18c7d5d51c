#pragma once
// The two steps every pipeline repeats around its work: read the main input (with progress,
// recorded in the run report) and write a label map as a run's output (folder, --force,
// recorded for the roll-back). Kept apart from run_report.hpp / outputs.hpp, which most of
// ui/app includes.
#include <filesystem>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::app {

/// The command's volume read with `load` and `progress`, recorded in `run` (loaded()) and timed
/// as its "load" stage.
io::LoadedVolume loadInput(RunReport& run, const std::filesystem::path& path, io::LoadOptions load, Progress& progress);

/// Writes `labels` to `path` (its folder created; --force as `force`) and records it in `outputs`.
void saveLabelsOutput(RunOutputs& outputs, const LabelVolume& labels, const std::filesystem::path& path, bool force);

}  // namespace vellum::app
