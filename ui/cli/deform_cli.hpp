#pragma once
// Shared by `vellum deform`, `vellum animate` and the demo: engine options on the command
// line, rigid bodies from a label map, control volume -> renderer map, reports as JSON.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/render/backward_map.hpp"

namespace vellum::cli {

/// The engine's flags, generated from deformParamsTable() (--method, --power, --control-scale,
/// --density-aware, --phi ... see `vellum params`), plus --upsampling.
struct EngineOptions {
  deformation::DeformParams flags;  ///< what the flags wrote (defaults: the struct's own)
  std::string upsampling = "trilinear";
  std::map<std::string, CLI::Option*> options;

  void addTo(CLI::App& cmd);
  /// The parameters to run with: the flags, except that the point file's power stands
  /// when --power was not given.
  deformation::DeformParams params(std::optional<double> filePower) const;
};

/// --labels, --rigid-labels, --rigid-falloff, --rigidity-stride.
struct RigidOptions {
  std::string labels;
  std::vector<uint16_t> rigidIds;
  double falloffMm = 10;
  int measureStride = 1;  ///< voxel-level measures: every N-th voxel per axis

  void addTo(CLI::App& cmd);
  bool enabled() const { return !labels.empty(); }
  /// Loads the labels (reduced by the input's --crop/--downsample; then the same grid as
  /// `geometry` is required) and finds the rigid bodies.
  deformation::RigidBodies load(const Geometry& geometry, const InputOptions& in) const;
};

nlohmann::json toJson(const deformation::RigidityReport& r);

}  // namespace vellum::cli
