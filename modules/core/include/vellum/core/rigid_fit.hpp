#pragma once
// Best rigid (or similarity) transform between point pairs: the weighted Kabsch / Procrustes
// fit, and the nearest rotation to a 3x3 matrix that it rests on (also used by the MLS
// deformation's rigid and similarity modes). Eigen's SVD stays inside the .cpp.
#include <vector>

#include "vellum/core/vec.hpp"

namespace vellum {

/// target ~ scale * rotation * source + translation (mm).
struct RigidTransform {
  Mat3 rotation;  ///< proper rotation (det +1)
  Vec3 translation{0, 0, 0};
  double scale = 1.0;
  Vec3 apply(const Vec3& p) const { return rotation * p * scale + translation; }
  /// The inverse map: p = R^T (q - t) / scale.
  RigidTransform inverse() const {
    const Mat3 rt = rotation.transposed();
    return RigidTransform{rt, rt * (-translation) * (1.0 / scale), 1.0 / scale};
  }
};

/// outer after inner: p -> outer.apply(inner.apply(p)).
inline RigidTransform compose(const RigidTransform& outer, const RigidTransform& inner) {
  return RigidTransform{outer.rotation * inner.rotation, outer.rotation * inner.translation * outer.scale + outer.translation,
                        outer.scale * inner.scale};
}

/// Weighted sums of point pairs, enough for the fit (pairs can be added in any order and
/// sums from several threads merged).
struct RigidFitSums {
  double weight = 0;              ///< sum w
  Vec3 source{0, 0, 0};           ///< sum w s
  Vec3 target{0, 0, 0};           ///< sum w t
  double sourceSq = 0;            ///< sum w |s|^2 (for the scale)
  Mat3 cross = Mat3::fromColumns({0, 0, 0}, {0, 0, 0}, {0, 0, 0});  ///< sum w s t^T
  void add(const Vec3& s, const Vec3& t, double w = 1.0);
  void merge(const RigidFitSums& o);
};

/// The rotation R (det +1) maximising trace(R^T m), i.e. U diag(1, 1, det(U V^T)) V^T for
/// m = U S V^T; `signedTrace` (optional) receives that maximum, s0 + s1 + det * s2.
Mat3 nearestRotation(const Mat3& m, double* signedTrace = nullptr);

/// Least-squares fit minimising sum w |target - (scale R source + t)|^2 with det R = +1 (a
/// reflection never comes out, even for mirrored or planar point sets); the scale stays 1
/// unless `withScale`. Throws vellum::Error when the total weight is not positive.
RigidTransform fitRigid(const RigidFitSums& sums, bool withScale = false);
/// The same from point lists (weights: empty = all 1; else one per pair).
RigidTransform fitRigid(const std::vector<Vec3>& source, const std::vector<Vec3>& target,
                        const std::vector<double>& weights = {}, bool withScale = false);

}  // namespace vellum
