#pragma once
// Shared by `vellum deform` and `vellum animate`: the engine's flags, generated from the app's
// tables (the runs themselves are app::runDeform and app::runAnimate).
#include <CLI/CLI.hpp>

#include "vellum/app/deform_pipeline.hpp"

namespace vellum::cli {

/// Adds the engine's flags to `cmd`, writing into `engine`: deformParamsTable() (--method,
/// --power, --control-scale, --density-aware, --phi ... see `vellum params`), deformEngineTable()
/// (--upsampling, --labels, --rigid-falloff, --rigidity-stride) and --rigid-labels. After
/// parsing, engine.powerGiven says whether --power was given (a given power wins over a point
/// file's, even at its default).
void addEngineFlags(CLI::App& cmd, app::DeformEngine& engine);

using app::toJson;  // rigidity reports, beside cli_util's geometry overloads

}  // namespace vellum::cli
