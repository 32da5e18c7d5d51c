#include "vellum/deformation/mls.hpp"

#include <algorithm>

#include "mls_kernel.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::deformation {

bool hasAttributes(const ControlPoints& points) {
  return std::any_of(points.begin(), points.end(),
                     [](const ControlPoint& p) { return !p.attributes.isDefault(); });
}

const params::EnumTable<MlsMethod>& mlsMethods() {
  static const params::EnumTable<MlsMethod> t{"MLS method", {"affine", "similarity", "rigid"}};
  return t;
}

std::vector<Vec3> evaluateMls(const ControlPoints& points, const MlsParams& params,
                              const std::vector<Vec3>& outputMm,
                              std::vector<std::array<double, 4>>* attributesOut) {
  const auto data = detail::PointData::from(points, attributesOut != nullptr);
  std::vector<Vec3> result(outputMm.size());
  if (attributesOut) attributesOut->assign(outputMm.size(), {0, 0, 0, 1});
  constexpr int64_t kChunk = 256;
  const int64_t chunks = (static_cast<int64_t>(outputMm.size()) + kChunk - 1) / kChunk;
  parallelFor(chunks, [&](int64_t c0, int64_t c1) {
    detail::RowEvaluator eval(data, params, kChunk);
    std::vector<double> u(3 * kChunk), attr(4 * kChunk);
    for (int64_t c = c0; c < c1; ++c) {
      const size_t begin = static_cast<size_t>(c * kChunk);
      const int len = static_cast<int>(std::min<size_t>(kChunk, outputMm.size() - begin));
      eval.setPositions(outputMm.data() + begin, len);
      eval.solve(nullptr, u.data(), attributesOut ? attr.data() : nullptr);
      for (int k = 0; k < len; ++k) {
        result[begin + static_cast<size_t>(k)] = {u[3 * k], u[3 * k + 1], u[3 * k + 2]};
        if (attributesOut)
          for (int a = 0; a < 4; ++a)
            (*attributesOut)[begin + static_cast<size_t>(k)][static_cast<size_t>(a)] =
                attr[4 * static_cast<size_t>(k) + static_cast<size_t>(a)];
      }
    }
  });
  return result;
}

}  // namespace vellum::deformation
