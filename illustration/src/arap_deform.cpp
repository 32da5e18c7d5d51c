// As-rigid-as-possible surface deformation (CGAL Surface_mesh_deformation, Sorkine & Alexa
// 2007) behind a plain interface: this is the only translation unit with CGAL's deformation
// headers (CGAL headers cost ~17 s and 1.2 GB per algorithm per TU to compile).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_deformation.h>

#include "curve_analogy_internal.hpp"
#include "vellum/core/error.hpp"

namespace vellum::illustration::detail {

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<K::Point_3>;
using Deformation = CGAL::Surface_mesh_deformation<Mesh>;
}  // namespace

std::vector<Vec3> arapDeform(const TriMesh& in, const std::vector<uint32_t>& handles,
                             const std::vector<Vec3>& targets, const std::vector<uint32_t>& fixed,
                             int iterations) {
  if (handles.size() != targets.size()) throw Error("ARAP: one target per handle");
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vi;
  vi.reserve(in.vertices.size());
  for (const auto& v : in.vertices) vi.push_back(mesh.add_vertex(K::Point_3(v[0], v[1], v[2])));
  for (const auto& f : in.faces)
    if (mesh.add_face(vi[f[0]], vi[f[1]], vi[f[2]]) == Mesh::null_face())
      throw Error("ARAP: the proxy mesh is not a manifold surface");
  Deformation d(mesh);
  d.insert_roi_vertices(mesh.vertices().begin(), mesh.vertices().end());  // ROI = whole mesh
  for (uint32_t h : handles) d.insert_control_vertex(vi[h]);
  for (uint32_t h : fixed) d.insert_control_vertex(vi[h]);  // controls left in place
  if (!d.preprocess()) throw Error("ARAP: factorisation failed (degenerate proxy mesh?)");
  for (size_t k = 0; k < handles.size(); ++k)
    d.set_target_position(vi[handles[k]], K::Point_3(targets[k].x, targets[k].y, targets[k].z));
  d.deform(static_cast<unsigned>(iterations), 1e-4);
  std::vector<Vec3> out;
  out.reserve(in.vertices.size());
  for (auto v : vi) {
    const auto& p = mesh.point(v);
    out.push_back({p.x(), p.y(), p.z()});
  }
  return out;
}

}  // namespace vellum::illustration::detail
