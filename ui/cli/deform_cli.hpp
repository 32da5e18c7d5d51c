#pragma once
// Shared by `vellum deform`, `vellum animate` and the demo: engine options on the command
// line, rigid bodies from a label map, control volume -> renderer map, reports as JSON.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/render/backward_map.hpp"

namespace vellum::cli {

/// --power, --method, --density-aware, --phi, --phi-min, --iterations, --tolerance, --rays,
/// --mip, --paper-rho, --control-scale, --upsampling.
struct EngineOptions {
  std::optional<double> power;  ///< unset: the point file's power, else 2
  std::string method = "affine";
  bool densityAware = false;
  std::string phi = "min";
  double phiMin = 0.05;
  int iterations = 3;
  double tolerance = 0;
  std::string rays = "conic";
  std::string mip = "mean";
  bool paperRho = false;
  int controlScale = 2;
  std::string upsampling = "trilinear";

  void addTo(CLI::App& cmd);
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
  /// Loads the labels (same grid as `geometry` required) and finds the rigid bodies.
  deformation::RigidBodies load(const Geometry& geometry) const;
};

render::BackwardMap toBackwardMap(const deformation::ControlVolume& cv);
nlohmann::json toJson(const deformation::RigidityReport& r);

}  // namespace vellum::cli
