#pragma once
// Moving-least-squares backward mapping ([HVD 1.1, 1.2] in docs/references.md): for an OUTPUT position v,
// the INPUT position u = f_s(v) it is fetched from.
//
//   w_i = 1 / |v - y_i|^n        (times rho_i with density-aware weights, see density.hpp)
//   x^, y^ weighted centroids;  p_i = x_i - x^,  q_i = y_i - y^
//   A = sum w_i q_i^T q_i,  B = sum w_i q_i^T p_i,  u = (v - y^) A^-1 B + x^
//
// Regularisation (never NaN, also for < 4 or coplanar points): with the normalised conditioning
// c = det(A) / (trace(A)/3)^3 in [0,1], lambda = eps * (eps / (eps + c))^2 * trace(A)/3 and
//   M = (A + lambda I)^-1 (B + lambda I).
// Adding lambda I to B as well pulls the under-determined directions towards the identity
// (a pure translation) instead of collapsing them; lambda vanishes (~eps^3) for well-spread
// points, so an exact affine configuration is reproduced to ~1e-12 relative.
// When trace(A) is 0 (one point, or all weight on one point) M = I.
// At v == y_i (|v - y_i| < 1e-9 mm) the map returns x_i exactly.
#include <array>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
#include "vellum/deformation/control_point.hpp"

namespace vellum::deformation {

enum class MlsMethod {
  Affine,      ///< default; the attribute extension builds on it
  Similarity,  ///< rotation + uniform scale: R, mu from the SVD of B (Kabsch)
  Rigid,       ///< rotation only: R from the SVD of B
};
const params::EnumTable<MlsMethod>& mlsMethods();  ///< "affine", "similarity", "rigid"
inline const char* mlsMethodName(MlsMethod m) { return mlsMethods().name(m); }
inline MlsMethod parseMlsMethod(const std::string& name) { return mlsMethods().parse(name); }

struct MlsParams {
  MlsMethod method = MlsMethod::Affine;
  double power = 2.0;            ///< n in w = 1/|v-y|^n (paper: 2..4); range in mlsParamsTable()
  double regularisation = 1e-6;  ///< eps above
};

/// Evaluates u(v) (mm) at each position in `outputMm` (mm), in double precision, in parallel.
/// The reference path for tests and picking; the engine evaluates grids with the same kernel.
/// `attributesOut`, when non-null, receives 4 values per position (PointAttributes order).
std::vector<Vec3> evaluateMls(const ControlPoints& points, const MlsParams& params,
                              const std::vector<Vec3>& outputMm,
                              std::vector<std::array<double, 4>>* attributesOut = nullptr);

}  // namespace vellum::deformation
