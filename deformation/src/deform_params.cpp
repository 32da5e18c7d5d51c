#include "vellum/deformation/deform_params.hpp"

namespace vellum::deformation {

using params::Info;
using P = DeformParams;

const params::Table<DeformParams>& deformParamsTable() {
  static const params::Table<P> table{
      params::choice<P>("method", params::nested(&P::mls, &MlsParams::method), {"affine", "similarity", "rigid"},
                        {"MLS method", "affine, or rotation + uniform scale, or rotation only (from the SVD of B)", ""}),
      params::real<P>("power", params::nested(&P::mls, &MlsParams::power),
                      {"Weight power", "n in w_i = 1/|v - y_i|^n; [HVD] uses 2..4", "", 0.5, 8}),
      params::real<P>("regularisation", params::nested(&P::mls, &MlsParams::regularisation),
                      {"Regularisation", "eps of the MLS moment-matrix regularisation (docs/deformation.md)", "", 0, 1e-2}),
      params::integer<P>("control_scale", &P::controlScale,
                         {"Control scale", "the map is evaluated on a grid coarser by s per axis, then upsampled", "voxels", 1, 16}),
      params::integer<P>("rho_scale", &P::rhoScale,
                         {"Rho-field scale", "grid factor of the cached rho fields; 0 = the control scale", "voxels", 0, 16}),
      params::flag<P>("single_precision_grid", &P::singlePrecisionGrid,
                      {"Single-precision grid", "solve well-conditioned grid nodes in float (about 2x faster, < 2e-3 mm)", ""}),
      params::flag<P>("attributes", &P::attributes,
                      {"Attribute fields", "interpolate non-spatial point attributes when some point has them", ""}),
      params::flag<P>("density_aware", params::nested(&P::density, &DensityParams::enabled),
                      {"Density-aware weights", "w_i = rho_i / |v - y_i|^n: dense tissue (bone) deforms less", ""}),
      params::choice<P>("phi", params::nested(&P::density, &DensityParams::phi), {"min", "mean", "none"},
                        {"Density normaliser", "phi: min of I along the segment, mean of I over the volume, or 1", ""}),
      params::real<P>("phi_min", params::nested(&P::density, &DensityParams::phiMin),
                      {"Density floor", "floor of the normalised density I and of phi", "", 1e-4, 1}),
      params::real<P>("window_low", params::nested(&P::density, &DensityParams::windowLowHu),
                      {"Density window low", "I = 0 at and below this value", "HU", -32768, 32767}),
      params::real<P>("window_high", params::nested(&P::density, &DensityParams::windowHighHu),
                      {"Density window high", "I = 1 at and above this value", "HU", -32768, 32767}),
      params::integer<P>("iterations", params::nested(&P::density, &DensityParams::iterations),
                         {"Fixed-point iterations", "K: rho is re-evaluated at the moved positions K times", "", 1, 10}),
      params::real<P>("tolerance", params::nested(&P::density, &DensityParams::toleranceMm),
                      {"Iteration tolerance", "stop early once no node moved more than this; 0 = always K", "mm", 0, 100}),
      params::choice<P>("rays", params::nested(&P::density, &DensityParams::rays), {"linear", "conic"},
                        {"Density rays", "fixed steps on the full volume, or steps growing with distance on a mip pyramid", ""}),
      params::real<P>("linear_step", params::nested(&P::density, &DensityParams::linearStepVoxels),
                      {"Linear ray step", "step of linear rays", "voxels", 0.05, 8}),
      params::real<P>("cone_slope", params::nested(&P::density, &DensityParams::coneSlope),
                      {"Cone slope", "conic rays: step and footprint = slope x distance", "", 0.01, 1}),
      params::choice<P>("mip", params::nested(&P::density, &DensityParams::reduction), {"mean", "max"},
                        {"Mip reduction", "conic rays: how the pyramid reduces (max keeps thin cortex)", ""}),
      params::flag<P>("rho_cache", params::nested(&P::density, &DensityParams::useRhoCache),
                      {"Rho-field cache", "one rho field per control point, reused across iterations and frames", ""}),
      params::flag<P>("length_normalised_rho", params::nested(&P::density, &DensityParams::lengthNormalised),
                      {"Length-normalised rho", "divide rho by the segment length; false = [HVD]'s rho (docs/deformation.md)", ""}),
  };
  return table;
}

void validate(const DeformParams& p) { params::validate(deformParamsTable(), p); }

}  // namespace vellum::deformation
