#include "vellum/deformation/deform_params.hpp"

namespace vellum::deformation {

using params::Info;
using P = DeformParams;

const params::Table<MlsParams>& mlsParamsTable() {
  using M = MlsParams;
  static const params::Table<M> table{
      params::choice<M>("method", &M::method, mlsMethods().names,
                        {"MLS method", "affine, or rotation + uniform scale, or rotation only (from the SVD of B)", ""}),
      params::real<M>("power", &M::power, {"Weight power", "n in w_i = 1/|v - y_i|^n; [HVD] uses 2..4", "", 0.5, 8}),
      // > 0: eps = 0 leaves coplanar point sets singular (docs/deformation.md).
      params::real<M>("regularisation", &M::regularisation,
                      {"Regularisation", "eps of the MLS moment-matrix regularisation (docs/deformation.md)", "", 1e-12, 1e-2}),
  };
  return table;
}

const params::Table<DensityParams>& densityParamsTable() {
  using D = DensityParams;
  static const params::Table<D> table{
      params::flag<D>("density_aware", &D::enabled,
                      {"Density-aware weights", "w_i = rho_i / |v - y_i|^n: dense tissue (bone) deforms less", ""}),
      params::choice<D>("phi", &D::phi, phiRules().names,
                        {"Density normaliser", "phi: min of I along the segment, mean of I over the volume, or 1", ""}),
      params::real<D>("phi_min", &D::phiMin,
                      {"Density floor", "floor of the normalised density I and of phi", "", 1e-4, 1}),
      params::real<D>("window_low", &D::windowLowHu,
                      {"Density window low", "I = 0 at and below this value", "HU", -32768, 32767}),
      params::real<D>("window_high", &D::windowHighHu,
                      {"Density window high", "I = 1 at and above this value", "HU", -32768, 32767}),
      params::integer<D>("iterations", &D::iterations,
                         {"Fixed-point iterations", "K: rho is re-evaluated at the moved positions K times", "", 1, 10}),
      params::real<D>("tolerance", &D::toleranceMm,
                      {"Iteration tolerance", "stop early once no node moved more than this; 0 = always K", "mm", 0, 100}),
      params::choice<D>("rays", &D::rays, rayModes().names,
                        {"Density rays", "fixed steps on the full volume, or steps growing with distance on a mip pyramid", ""}),
      params::real<D>("linear_step", &D::linearStepVoxels,
                      {"Linear ray step", "step of linear rays", "voxels", 0.05, 8}),
      params::real<D>("cone_slope", &D::coneSlope,
                      {"Cone slope", "conic rays: step and footprint = slope x distance", "", 0.01, 1}),
      params::choice<D>("mip", &D::reduction, mipReductions().names,
                        {"Mip reduction", "conic rays: how the pyramid reduces (max keeps thin cortex)", ""}),
      params::flag<D>("rho_cache", &D::rhoCache,
                      {"Rho-field cache", "one rho field per control point, reused across iterations and frames", ""}),
      params::flag<D>("length_normalised_rho", &D::lengthNormalisedRho,
                      {"Length-normalised rho", "divide rho by the segment length; false = [HVD]'s rho (docs/deformation.md)", ""}),
  };
  return table;
}

const params::Table<DeformParams>& deformParamsTable() {
  static const params::Table<P> table = [] {
    params::Table<P> t = params::embed<P>("", &P::mls, mlsParamsTable());
    t.insert(t.end(), {
        params::integer<P>("control_scale", &P::controlScale,
                           {"Control scale", "the map is evaluated on a grid coarser by s per axis, then upsampled", "voxels", 1, 16}),
        params::integer<P>("rho_scale", &P::rhoScale,
                           {"Rho-field scale", "grid factor of the cached rho fields; 0 = the control scale", "voxels", 0, 16}),
        params::flag<P>("single_precision_grid", &P::singlePrecisionGrid,
                        {"Single-precision grid", "solve well-conditioned grid nodes in float (about 2x faster, < 2e-3 mm)", ""}),
        params::flag<P>("attributes", &P::attributes,
                        {"Attribute fields", "interpolate non-spatial point attributes when some point has them", ""}),
    });
    const params::Table<P> density = params::embed<P>("", &P::density, densityParamsTable());
    t.insert(t.end(), density.begin(), density.end());
    return t;
  }();
  return table;
}

void validate(const DeformParams& p) { params::validate(deformParamsTable(), p); }

}  // namespace vellum::deformation
