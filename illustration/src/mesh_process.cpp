// OpenMesh stage: light feature-preserving smoothing and quadric decimation.
//
// Smoothing is tangential only (JacobiLaplaceSmoother, Tangential, C1): it evens out the
// slivers that marching produces without moving the surface along its normal, so edges and
// ridges the level set kept are not rounded off. Decimation collapses edges by quadric error
// (ModQuadric, bounded by maxErrorMm), rejecting collapses that tilt a face normal by more than
// 25 degrees (ModNormalDeviation, preserves features) or create needles (ModAspectRatio).
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>

#include <OpenMesh/Tools/Decimater/ModAspectRatioT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalDeviationT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <OpenMesh/Tools/Smoother/JacobiLaplaceSmootherT.hh>

#include "shape_internal.hpp"

namespace vellum::illustration::detail {

namespace {
struct Traits : OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
  VertexAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::Normal);
  EdgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::Normal);
  HalfedgeAttributes(OpenMesh::Attributes::PrevHalfedge);
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<Traits>;
}  // namespace

TriMesh smoothAndDecimate(const TriMesh& in, int smoothingIterations, int64_t targetFaces,
                          double maxErrorMm, double maxNormalDeviationDeg) {
  OmMesh mesh;
  std::vector<OmMesh::VertexHandle> vh;
  vh.reserve(in.vertices.size());
  for (const auto& v : in.vertices) vh.push_back(mesh.add_vertex(OmMesh::Point(v[0], v[1], v[2])));
  for (const auto& f : in.faces) {
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
    // add_face refuses faces that would make the mesh non-manifold; CGAL fills the holes.
    mesh.add_face(vh[f[0]], vh[f[1]], vh[f[2]]);
  }
  mesh.update_normals();
  if (smoothingIterations > 0) {
    OpenMesh::Smoother::JacobiLaplaceSmootherT<OmMesh> smoother(mesh);
    smoother.initialize(OpenMesh::Smoother::SmootherT<OmMesh>::Tangential,
                        OpenMesh::Smoother::SmootherT<OmMesh>::C1);
    smoother.smooth(static_cast<unsigned>(smoothingIterations));
    mesh.update_normals();
  }
  if (targetFaces > 0 && static_cast<int64_t>(mesh.n_faces()) > targetFaces) {
    OpenMesh::Decimater::DecimaterT<OmMesh> dec(mesh);
    OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
    OpenMesh::Decimater::ModNormalDeviationT<OmMesh>::Handle normals;
    OpenMesh::Decimater::ModAspectRatioT<OmMesh>::Handle aspect;
    dec.add(quadric);
    if (maxNormalDeviationDeg > 0) dec.add(normals);
    dec.add(aspect);
    dec.module(quadric).set_max_err(maxErrorMm * maxErrorMm, false);
    if (maxNormalDeviationDeg > 0) dec.module(normals).set_normal_deviation(maxNormalDeviationDeg);
    dec.module(aspect).set_aspect_ratio(5.0);
    dec.initialize();
    dec.decimate_to_faces(0, static_cast<size_t>(targetFaces));
    mesh.garbage_collection();
  }
  TriMesh out;
  out.vertices.reserve(mesh.n_vertices());
  for (auto v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    out.vertices.push_back({float(p[0]), float(p[1]), float(p[2])});
  }
  out.faces.reserve(mesh.n_faces());
  for (auto f : mesh.faces()) {
    std::array<uint32_t, 3> t{};
    int n = 0;
    for (auto v : mesh.fv_range(f)) t[static_cast<size_t>(n++)] = static_cast<uint32_t>(v.idx());
    out.faces.push_back(t);
  }
  return out;
}

}  // namespace vellum::illustration::detail
