#pragma once
// Analytic test meshes: an icosphere, or one scaled into an ellipsoid (outward, closed), for
// the shape pipeline's and the curve analogy's tests.
#include <algorithm>
#include <cmath>
#include <map>

#include "vellum/core/vec.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::test {

inline vellum::illustration::TriMesh ellipsoid(double rx, double ry, double rz, int level) {
  using vellum::Vec3;
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<uint32_t, 3>> f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
                                            {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                            {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
                                            {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (auto& p : v) p = vellum::normalized(p);
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back(vellum::normalized((v[a] + v[b]) * 0.5));
      return mid[key] = uint32_t(v.size() - 1);
    };
    std::vector<std::array<uint32_t, 3>> g;
    for (const auto& tri : f) {
      const uint32_t a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f = std::move(g);
  }
  vellum::illustration::TriMesh m;
  for (const auto& p : v) m.vertices.push_back({float(p.x * rx), float(p.y * ry), float(p.z * rz)});
  m.faces = f;
  return m;
}

/// Icosphere of `radius` mm (vertices on the sphere), `level` subdivisions, outward.
inline vellum::illustration::TriMesh icosphere(double radius, int level) { return ellipsoid(radius, radius, radius, level); }

}  // namespace vellum::test
