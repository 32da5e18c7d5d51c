#pragma once
// The Gaussian map-upsampling kernel, shared by CPU synthesis (deformation) and the renderer
// (which must not depend on deformation): a sample at fraction f in [0, 1) between node n0 and
// n0 + 1 reads nodes n0 - 1 .. n0 + 2. The GLSL twin is gaussWeights() in
// modules/render/src/shader_source.cpp; change both together.
#include <array>
#include <cmath>

namespace vellum {

/// Standard deviation of the kernel, in node spacings.
constexpr double kGaussianUpsamplingSigma = 0.6;

/// Normalised weights of nodes n0 - 1 .. n0 + 2 for fraction f: Gaussian weights adjusted so
/// that the first moment about f is zero (a linear map is reproduced exactly). All positive.
inline std::array<double, 4> gaussianUpsamplingWeights(double f) {
  std::array<double, 4> w{};
  double m1 = 0, m2 = 0;
  for (int q = 0; q < 4; ++q) {
    const double x = (q - 1) - f;
    w[q] = std::exp(-0.5 * x * x / (kGaussianUpsamplingSigma * kGaussianUpsamplingSigma));
    m1 += w[q] * x;
    m2 += w[q] * x * x;
  }
  const double beta = -m1 / m2;  // w_q *= 1 + beta x_q: zero first moment about f
  double total = 0;
  for (int q = 0; q < 4; ++q) {
    w[q] *= 1.0 + beta * ((q - 1) - f);
    total += w[q];
  }
  for (double& v : w) v /= total;
  return w;
}

}  // namespace vellum
