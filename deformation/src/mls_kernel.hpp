#pragma once
// Internal: the MLS kernel, vectorised over a row of output nodes (structure of arrays, x
// fastest, no allocation per node). Used by evaluateMls() and the Deformer.
#include <vector>

#include "vellum/deformation/control_point.hpp"
#include "vellum/deformation/mls.hpp"

namespace vellum::deformation::detail {

/// Control points, centred (targets on their mean, sources on theirs) for precision.
struct PointData {
  int count = 0;
  Vec3 sourceCentre, targetCentre;
  std::vector<double> sx, sy, sz, tx, ty, tz;
  std::vector<float> sxf, syf, szf, txf, tyf, tzf;  ///< the same, rounded once for float lanes
  bool attributes = false;
  std::vector<double> z[PointAttributes::kCount];
  std::vector<Vec3> sourceMm;  ///< exact x_i for hits
  std::vector<std::array<double, PointAttributes::kCount>> zi;

  static PointData from(const ControlPoints& points, bool withAttributes);
};

/// Evaluates u at nodes v_k = base + k * step (mm), k < len. One instance per thread.
class RowEvaluator {
 public:
  RowEvaluator(const PointData& points, const MlsParams& params, int maxLen);

  /// Positions of the row and the plain weights 1/|v-y_i|^n.
  void setRow(const Vec3& baseMm, const Vec3& stepMm, int len);
  /// Same for arbitrary positions (mm).
  void setPositions(const Vec3* positionsMm, int len);
  /// Solves the row. `rho` (point-major: rho[i*len + k]) multiplies the weights when given.
  /// u: 3 doubles per node (mm). attr: 4 per node, or null.
  void solve(const float* rho, double* u, double* attr);
  int length() const { return len_; }
  /// Grids: solve well-conditioned nodes in single precision (8 per AVX2 register); the
  /// result is stored as float anyway. Ill-conditioned nodes and hits stay double.
  void setSinglePrecision(bool on) { singlePrecision_ = on; }

 private:
  static constexpr int kLanes = 4;  // doubles per AVX2 register: rows are padded to a multiple
  void computeWeights();
  // The lane solver over nodes [kBegin, kEnd) in double precision (with attributes when attr).
  void solveBlocked(const double* w, double* u, double* attr, int kBegin, int kEnd);
  // The same in float lanes, 8 nodes at a time; blocks not well-posed in float are redone in double.
  void solveBlockedFloat(const double* w, double* u);
  const PointData& p_;
  MlsParams params_;
  int maxLen_, len_ = 0, stride_ = 0;
  bool singlePrecision_ = false;
  std::vector<double> w0_, w_;  // point-major weights
  std::vector<double> vx_, vy_, vz_;  // node positions relative to the targets' centre
  std::vector<double> md2_, mid_;  // per node: the nearest point's squared distance and index
  std::vector<int> hit_;
};

}  // namespace vellum::deformation::detail
