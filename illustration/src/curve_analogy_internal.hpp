#pragma once
// Internal interface of the curve analogy to its CGAL translation unit.
#include <cstdint>
#include <vector>

#include "vellum/core/vec.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::illustration::detail {

/// ARAP deformation of a closed manifold mesh (ROI = all vertices): `handles` move to
/// `targets`, `fixed` stay where they are; returns the new vertex positions (mm).
std::vector<Vec3> arapDeform(const TriMesh& mesh, const std::vector<uint32_t>& handles,
                             const std::vector<Vec3>& targets, const std::vector<uint32_t>& fixed,
                             int iterations);

}  // namespace vellum::illustration::detail
