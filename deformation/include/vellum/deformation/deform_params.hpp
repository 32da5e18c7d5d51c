#pragma once
// The parameter table of DeformParams (see vellum/core/params.hpp): key, label, help, unit
// and range of every engine parameter, written once. The CLI flags of `vellum deform` and
// `vellum animate`, their reports, the scene file and docs/parameters.md come from it.
#include "vellum/core/params.hpp"
#include "vellum/deformation/deformer.hpp"

namespace vellum::deformation {

const params::Table<DeformParams>& deformParamsTable();
/// The MLS and density parts of deformParamsTable(), for code that holds only those structs
/// (evaluateMls, DensityVolume, control-point files): one range per parameter.
const params::Table<MlsParams>& mlsParamsTable();
const params::Table<DensityParams>& densityParamsTable();

/// Throws vellum::Error naming the first parameter outside its range.
void validate(const DeformParams& p);

}  // namespace vellum::deformation
