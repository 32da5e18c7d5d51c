// CGAL Polygon Mesh Processing repair: soup repair and orientation (splits non-manifold
// vertices), stitching, degenerate faces, hole filling, self-intersection removal, outward
// orientation. Checks live in mesh_checks.cpp (separate TU: each PMP algorithm is a heavy
// compile).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/repair_self_intersections.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/stitch_borders.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include "shape_internal.hpp"

namespace vellum::illustration::detail {

namespace PMP = CGAL::Polygon_mesh_processing;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;

namespace {
/// Output meshes store float coordinates: round now so that the checks see what is saved
/// (rounding a near-degenerate configuration can create an intersection).
void roundToFloat(Mesh& mesh) {
  for (auto v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    mesh.point(v) = Point(double(float(p.x())), double(float(p.y())), double(float(p.z())));
  }
}

int64_t fillHoles(Mesh& mesh) {
  int64_t filled = 0;
  std::vector<Mesh::Halfedge_index> borders;
  for (auto h : mesh.halfedges())
    if (mesh.is_border(h)) borders.push_back(h);
  std::vector<bool> seen(mesh.number_of_halfedges(), false);
  for (auto h : borders) {
    if (seen[h.idx()] || !mesh.is_border(h)) continue;
    for (auto c : CGAL::halfedges_around_face(h, mesh)) seen[c.idx()] = true;
    std::vector<Mesh::Face_index> patch;
    PMP::triangulate_hole(mesh, h, std::back_inserter(patch));
    ++filled;
  }
  return filled;
}
}  // namespace

TriMesh repairMesh(const TriMesh& in, MeshChecks& stats) {
  std::vector<Point> points;
  points.reserve(in.vertices.size());
  for (const auto& v : in.vertices) points.emplace_back(v[0], v[1], v[2]);
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(in.faces.size());
  for (const auto& f : in.faces) polygons.push_back({f[0], f[1], f[2]});
  PMP::repair_polygon_soup(points, polygons);
  PMP::orient_polygon_soup(points, polygons);
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  points.clear();
  polygons.clear();
  PMP::stitch_borders(mesh);
  const auto facesBefore = mesh.number_of_faces();
  PMP::remove_degenerate_faces(mesh);
  mesh.collect_garbage();
  stats.degenerateRemoved = static_cast<int64_t>(facesBefore) - static_cast<int64_t>(mesh.number_of_faces());
  stats.holesFilled = fillHoles(mesh);
  // Self-intersections: CGAL's (experimental) local remeshing/hole filling, repeated while
  // it leaves some (each round works on what the previous one could not fix).
  roundToFloat(mesh);
  for (int round = 0; round < 4 && PMP::does_self_intersect<CGAL::Parallel_if_available_tag>(mesh); ++round) {
    PMP::experimental::remove_self_intersections(mesh, CGAL::parameters::preserve_genus(false));
    mesh.collect_garbage();
    stats.holesFilled += fillHoles(mesh);
    PMP::stitch_borders(mesh);
    roundToFloat(mesh);
    stats.selfIntersectionsRepaired = true;
  }
  if (CGAL::is_closed(mesh)) {
    PMP::orient_to_bound_a_volume(mesh);
  } else if (!PMP::is_outward_oriented(mesh)) {
    PMP::reverse_face_orientations(mesh);
  }
  mesh.collect_garbage();
  TriMesh out;
  out.vertices.reserve(mesh.number_of_vertices());
  for (auto v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    out.vertices.push_back({float(p.x()), float(p.y()), float(p.z())});
  }
  out.faces.reserve(mesh.number_of_faces());
  for (auto f : mesh.faces()) {
    std::array<uint32_t, 3> t{};
    int n = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
      if (n < 3) t[static_cast<size_t>(n)] = static_cast<uint32_t>(v.idx());
      ++n;
    }
    if (n == 3) out.faces.push_back(t);
  }
  return out;
}

}  // namespace vellum::illustration::detail
