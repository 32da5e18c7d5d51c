#pragma once
// Mean value coordinates of points with respect to a closed triangle mesh (a "cage"), after
// Ju, Schaefer and Warren (2005). A point x gets one weight per cage vertex; the weights sum
// to one and reproduce x (sum w_i p_i = x) and every affine function, so moving the cage's
// vertices moves the points smoothly with it (curve analogy: M1 carries M0 and the CT).
#include <array>
#include <cstdint>
#include <vector>

#include "vellum/core/vec.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::illustration {

/// A closed, outward-oriented triangle mesh in mm, kept in double precision.
struct Cage {
  std::vector<Vec3> vertices;
  std::vector<std::array<uint32_t, 3>> faces;
};
Cage cageOf(const TriMesh& mesh);

struct MvcOptions {
  /// A point closer than this to a face (relative to the cage's bounding-box diagonal) is
  /// treated as lying on it and gets the face's barycentric coordinates (the MVC integral
  /// is singular there; its limit is the barycentric interpolation).
  double surfaceTolerance = 1e-9;
};

/// The weights of `x` (one per cage vertex, summing to 1). Works inside, outside and on the
/// surface (face, edge or vertex: barycentric).
std::vector<double> meanValueCoordinates(const Cage& cage, const Vec3& x,
                                         const MvcOptions& options = {});

/// For every point: its coordinates with respect to `rest`, applied to `deformedVertices`
/// (same count and order as rest.vertices). TBB-parallel over points; no weight matrix is
/// stored, so memory stays O(points + cage).
std::vector<Vec3> transferByMeanValueCoordinates(const Cage& rest,
                                                 const std::vector<Vec3>& deformedVertices,
                                                 const std::vector<Vec3>& points,
                                                 const MvcOptions& options = {});

}  // namespace vellum::illustration
