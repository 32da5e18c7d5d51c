#include "vellum/core/rigid_fit.hpp"

#include <Eigen/Dense>

#include "vellum/core/error.hpp"

namespace vellum {

void RigidFitSums::add(const Vec3& s, const Vec3& t, double w) {
  weight += w;
  source += s * w;
  target += t * w;
  sourceSq += w * dot(s, s);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) cross(r, c) += w * s[r] * t[c];
}

void RigidFitSums::merge(const RigidFitSums& o) {
  weight += o.weight;
  source += o.source;
  target += o.target;
  sourceSq += o.sourceSq;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) cross(r, c) += o.cross(r, c);
}

// Eigen's fixed-size SVD trips a false -Wmaybe-uninitialized at -O2 (GCC 12).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
Mat3 nearestRotation(const Mat3& m, double* signedTrace) {
  Eigen::Matrix3d b;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) b(r, c) = m(r, c);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(b, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // A reflection (det U V^T = -1) is turned into the nearest rotation by flipping the axis of
  // the smallest singular value.
  const double d = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Matrix3d corr = Eigen::Matrix3d::Identity();
  corr(2, 2) = d;
  const Eigen::Matrix3d r = svd.matrixU() * corr * svd.matrixV().transpose();
  if (signedTrace) {
    const Eigen::Vector3d s = svd.singularValues();
    *signedTrace = s(0) + s(1) + d * s(2);
  }
  Mat3 out;
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) out(i, c) = r(i, c);
  return out;
}
#pragma GCC diagnostic pop

RigidTransform fitRigid(const RigidFitSums& s, bool withScale) {
  if (!(s.weight > 0)) throw Error("rigid fit: the point pairs have no positive total weight");
  const Vec3 cs = s.source / s.weight, ct = s.target / s.weight;
  // H = sum w (s - cs)(t - ct)^T; R maximises trace(R H) = trace(R^T H^T).
  Mat3 ht;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) ht(c, r) = s.cross(r, c) - s.weight * cs[r] * ct[c];
  RigidTransform f;
  double traceRH = 0;
  f.rotation = nearestRotation(ht, &traceRH);
  if (withScale) {
    const double spread = s.sourceSq - s.weight * dot(cs, cs);  // sum w |s - cs|^2
    if (spread > 0) f.scale = traceRH / spread;
  }
  f.translation = ct - f.rotation * cs * f.scale;
  return f;
}

RigidTransform fitRigid(const std::vector<Vec3>& source, const std::vector<Vec3>& target,
                        const std::vector<double>& weights, bool withScale) {
  if (source.size() != target.size() || (!weights.empty() && weights.size() != source.size()))
    throw Error("rigid fit: source, target and weights differ in length");
  RigidFitSums sums;
  for (size_t n = 0; n < source.size(); ++n) sums.add(source[n], target[n], weights.empty() ? 1.0 : weights[n]);
  return fitRigid(sums, withScale);
}

}  // namespace vellum
