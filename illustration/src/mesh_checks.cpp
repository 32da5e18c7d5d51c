// CGAL checks of an output mesh: closed, 2-manifold, self-intersections, volume, outward.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include "shape_internal.hpp"

namespace vellum::illustration {

namespace PMP = CGAL::Polygon_mesh_processing;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;

MeshChecks checkMesh(const TriMesh& in) {
  MeshChecks c;
  std::vector<Point> points;
  for (const auto& v : in.vertices) points.emplace_back(v[0], v[1], v[2]);
  std::vector<std::vector<std::size_t>> polygons;
  for (const auto& f : in.faces) polygons.push_back({f[0], f[1], f[2]});
  Mesh mesh;
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons)) {
    // Edges shared by more than two faces or inconsistent orientation: not a 2-manifold.
    c.manifold = false;
    c.closed = false;
    return c;
  }
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  c.closed = CGAL::is_closed(mesh);
  std::vector<Mesh::Halfedge_index> nm;
  PMP::non_manifold_vertices(mesh, std::back_inserter(nm));
  c.manifold = nm.empty();
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> pairs;
  PMP::self_intersections<CGAL::Parallel_if_available_tag>(mesh, std::back_inserter(pairs));
  c.selfIntersections = static_cast<int64_t>(pairs.size());
  if (c.closed) {
    c.volumeMm3 = PMP::volume(mesh);
    c.outward = c.volumeMm3 > 0;
  }
  return c;
}

}  // namespace vellum::illustration
