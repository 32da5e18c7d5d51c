// Shape-aware representation: per-segment signed distances of the closed meshes on the CT
// grid (OpenVDB meshToSignedDistanceField), the union distance and the segmentation volume.
//
// Distances are computed on an isotropic VDB grid aligned with the CT's index axes, voxel
// size h = the smallest CT spacing, with vertices expressed in mm along those axes (distance
// is invariant under the CT's rotation). For isotropic CT grids the VDB voxels coincide with
// the CT voxels; otherwise each CT voxel centre is sampled trilinearly. Within the narrow band
// (bandMm, widened per mesh for shells and grow offsets) the values are exact distances to the
// mesh (OpenVDB computes point-triangle distances to the closest primitive). Beyond the band
// the sign is exact (OpenVDB flood-fills the interior of the closed mesh) and the magnitude is
// a far-field estimate (see farField below).
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/MeshToVolume.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <mutex>

#include "shape_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::illustration {

namespace {
bool isotropic(const Vec3& s) {
  const double h = std::min({s.x, s.y, s.z});
  return std::abs(s.x - h) < 1e-6 * h && std::abs(s.y - h) < 1e-6 * h && std::abs(s.z - h) < 1e-6 * h;
}
}  // namespace

std::vector<VolumeF32> signedDistances(const std::vector<TriMesh>& meshes, const Geometry& g,
                                       const DistanceOptions& options,
                                       const std::vector<double>& extraBandMm) {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
  const Vec3 sp = g.spacing;
  const double h = std::min({sp.x, sp.y, sp.z});
  const bool iso = isotropic(sp);
  auto xform = openvdb::math::Transform::createLinearTransform(h);
  std::vector<VolumeF32> out;
  out.reserve(meshes.size());
  for (size_t m = 0; m < meshes.size(); ++m) {
    const TriMesh& mesh = meshes[m];
    std::vector<openvdb::Vec3s> pts;
    pts.reserve(mesh.vertices.size());
    for (const auto& v : mesh.vertices) {
      const Vec3 q = g.physicalToIndex(Vec3{v[0], v[1], v[2]});
      pts.emplace_back(float(q.x * sp.x), float(q.y * sp.y), float(q.z * sp.z));
    }
    std::vector<openvdb::Vec3I> tris;
    tris.reserve(mesh.faces.size());
    for (const auto& f : mesh.faces) tris.emplace_back(f[0], f[1], f[2]);
    const double extra = m < extraBandMm.size() ? extraBandMm[m] : 0.0;
    const double bandMm = std::max(options.bandMm, std::abs(extra) + 2 * h);
    const float bandVox = static_cast<float>(std::max(3.0, bandMm / h));
    const float farMm = static_cast<float>(bandVox * h);
    VolumeF32 dense(g, farMm, farMm);
    if (!tris.empty()) {
      auto grid = openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(
          *xform, pts, tris, std::vector<openvdb::Vec4I>{}, bandVox, bandVox);
      const auto& d = g.dims;
      parallelFor(d.z, [&](int64_t k0, int64_t k1) {
        auto acc = grid->getConstAccessor();
        for (int64_t k = k0; k < k1; ++k)
          for (int64_t j = 0; j < d.y; ++j)
            for (int64_t i = 0; i < d.x; ++i) {
              float v;
              if (iso) {
                v = acc.getValue(openvdb::Coord(int(i), int(j), int(k)));
              } else {
                const openvdb::Vec3d p(i * sp.x / h, j * sp.y / h, k * sp.z / h);
                v = openvdb::tools::BoxSampler::sample(acc, p);
              }
              dense(i, j, k) = v;
            }
      });
    }
    out.push_back(std::move(dense));
  }
  return out;
}

void buildRepresentation(std::vector<VolumeF32>& distances, const std::vector<Segment>& segments,
                         const std::vector<Shell>& shells, VolumeF32& unionDistance,
                         LabelVolume& segmentation) {
  if (distances.size() != segments.size() || distances.empty())
    throw Error("buildRepresentation: one distance volume per segment needed");
  const Geometry& g = distances.front().geometry();
  const size_t n = segments.size();
  if (n + shells.size() > 255) throw Error("too many segments and shells for a uint8 label map (max 255)");
  // Shell per segment (first one wins), with its label id.
  std::vector<double> shellT(n, 0.0);
  std::vector<uint16_t> shellId(n, 0);
  std::vector<Label> table;
  for (size_t i = 0; i < n; ++i)
    table.push_back({static_cast<uint16_t>(i + 1), segments[i].name, segments[i].rgb});
  for (size_t s = 0; s < shells.size(); ++s) {
    size_t idx = n;
    for (size_t i = 0; i < n; ++i)
      if (segments[i].name == shells[s].segment) idx = i;
    if (idx == n) throw Error("--shell: unknown segment '" + shells[s].segment + "'");
    if (!(shells[s].thicknessMm > 0)) throw Error("--shell " + shells[s].segment + ": thickness must be > 0 mm");
    const auto id = static_cast<uint16_t>(n + 1 + s);
    if (shellId[idx] == 0) {
      shellId[idx] = id;
      shellT[idx] = shells[s].thicknessMm;
    }
    auto rgb = segments[idx].rgb;
    for (auto& c : rgb) c = static_cast<uint8_t>(c / 2 + 64);  // a paler, distinct shade
    table.push_back({id, segments[idx].name + " boundary", rgb});
  }
  unionDistance = VolumeF32(g, 0.0f, distances.front().background());
  VolumeU16 ids(g, 0, 0.0);
  const size_t count = static_cast<size_t>(g.dims.voxelCount());
  parallelFor(g.dims.z, [&](int64_t k0, int64_t k1) {
    const size_t slice = static_cast<size_t>(g.dims.x * g.dims.y);
    for (size_t v = static_cast<size_t>(k0) * slice; v < static_cast<size_t>(k1) * slice && v < count; ++v) {
      float u = distances[0].data()[v];
      uint16_t label = 0;
      for (size_t i = 0; i < n; ++i) {
        const float d = distances[i].data()[v];
        u = std::min(u, d);
        if (label == 0 && d < 0) {
          label = static_cast<uint16_t>(i + 1);
          if (shellId[i] != 0 && d > -shellT[i]) label = shellId[i];
        }
      }
      unionDistance.data()[v] = u;
      ids.data()[v] = label;
    }
  });
  segmentation = LabelVolume(std::move(ids), std::move(table));
}

}  // namespace vellum::illustration
