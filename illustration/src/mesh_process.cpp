// OpenMesh stage: light feature-preserving smoothing and quadric decimation.
//
// Decimation collapses edges by quadric error (ModQuadric, bounded by maxErrorMm), rejecting
// collapses that tilt a face normal by more than 25 degrees (ModNormalDeviation, preserves
// features) or create needles (ModAspectRatio); looser passes follow when the face budget is
// not met (see smoothAndDecimate). Smoothing, on the decimated mesh, is tangential only
// (JacobiLaplaceSmoother, Tangential, C1): it evens out the triangles without moving the
// surface along its normal, so edges and ridges the level set kept are not rounded off.
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>

#include <OpenMesh/Tools/Decimater/ModAspectRatioT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalDeviationT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <OpenMesh/Tools/Smoother/JacobiLaplaceSmootherT.hh>

#include <cmath>
#include <cstdio>
#include <cstdlib>

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
  // Decimation first, smoothing after: the smoothing then works on the (much smaller)
  // decimated mesh, and the face budget is honoured. Passes from strict to loose, each only
  // while the budget is not met: (1) quadric error <= maxErrorMm, normals within
  // maxNormalDeviationDeg (keeps features); (2) error <= 2 maxErrorMm, normals within 45
  // degrees; (3) error <= 4 maxErrorMm (two voxels in the pipeline), normals within 80 degrees
  // (no fold-overs). All keep the aspect-ratio guard. The budget is reached unless that
  // error, folds or topology forbid it (a closed component cannot go below 4 faces). What the looser passes cost in accuracy is measured
  // afterwards (MeshChecks::maxBoundaryDistanceMm).
  static const bool profile = std::getenv("VELLUM_SHAPE_PROFILE") != nullptr;
  for (int pass = 0; pass < 3 && targetFaces > 0 && static_cast<int64_t>(mesh.n_faces()) > targetFaces; ++pass) {
    OpenMesh::Decimater::DecimaterT<OmMesh> dec(mesh);
    OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
    OpenMesh::Decimater::ModNormalDeviationT<OmMesh>::Handle normals;
    OpenMesh::Decimater::ModAspectRatioT<OmMesh>::Handle aspect;
    dec.add(quadric);
    // The normal guard widens pass by pass (25 -> 45 -> 80 degrees) but never goes: a
    // collapse that folds a face over would make self-intersections.
    const double deviation = pass == 0 ? maxNormalDeviationDeg : (pass == 1 ? 45.0 : 80.0);
    const bool guard = maxNormalDeviationDeg > 0;  // 0: the curve analogy's coarse proxy, no guard
    if (guard) dec.add(normals);
    dec.add(aspect);
    dec.module(quadric).set_max_err(std::pow(maxErrorMm * (pass == 0 ? 1 : 2 * pass), 2), false);
    if (guard) dec.module(normals).set_normal_deviation(std::max(deviation, maxNormalDeviationDeg));
    dec.module(aspect).set_aspect_ratio(5.0);
    dec.initialize();
    dec.decimate_to_faces(0, static_cast<size_t>(targetFaces));
    mesh.garbage_collection();
    if (profile) std::fprintf(stderr, "  decimate pass %d -> %zu faces\n", pass, size_t(mesh.n_faces()));
    mesh.update_normals();
  }
  if (smoothingIterations > 0) {
    OpenMesh::Smoother::JacobiLaplaceSmootherT<OmMesh> smoother(mesh);
    smoother.initialize(OpenMesh::Smoother::SmootherT<OmMesh>::Tangential,
                        OpenMesh::Smoother::SmootherT<OmMesh>::C1);
    smoother.smooth(static_cast<unsigned>(smoothingIterations));
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
