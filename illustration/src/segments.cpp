// Segment specs, masks, and the mesh-to-binary-boundary distance (no heavy headers here).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "shape_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::illustration {

Segment parseSegmentSpec(const std::string& spec, const LabelVolume& labels) {
  Segment s;
  std::string idsText = spec;
  if (const auto eq = spec.find('='); eq != std::string::npos) {
    s.name = spec.substr(0, eq);
    idsText = spec.substr(eq + 1);
    if (s.name.empty()) throw Error("--segment '" + spec + "': empty name before '='");
  }
  if (idsText.empty()) throw Error("--segment '" + spec + "': no label ids (expected NAME=ID[,ID..])");
  const uint16_t maxId = labels.maxId();
  std::vector<std::string> parts(1);
  for (char c : idsText) {
    if (c == ',') parts.emplace_back();
    else parts.back() += c;
  }
  for (const std::string& part : parts) {
    long v = -1;
    try {
      size_t used = 0;
      v = std::stol(part, &used);
      if (used != part.size()) v = -1;
    } catch (const std::exception&) {
      v = -1;
    }
    if (v < 1 || v > 65535)
      throw Error("--segment '" + spec + "': '" + part + "' is not a label id (1..65535)");
    const auto id = static_cast<uint16_t>(v);
    if (!labels.label(id) && id > maxId)
      throw Error("--segment '" + spec + "': unknown label id " + std::to_string(id) +
                  " (not in the label table nor in the voxels)");
    if (std::find(s.ids.begin(), s.ids.end(), id) == s.ids.end()) s.ids.push_back(id);
  }
  if (s.ids.empty()) throw Error("--segment '" + spec + "': no label ids");
  const auto first = labels.label(s.ids.front());
  if (s.name.empty()) {
    if (s.ids.size() != 1)
      throw Error("--segment '" + spec + "': several ids need a name (NAME=ID,ID..)");
    if (!first || first->name.empty())
      throw Error("--segment '" + spec + "': label " + std::to_string(s.ids.front()) +
                  " has no name in the label table; use NAME=ID");
    s.name = first->name;
  }
  s.rgb = first ? first->rgb : defaultLabelColor(s.ids.front());
  return s;
}

namespace detail {

namespace {
template <class Pred>
MaskBox buildMask(const Dims& d, int pad, Pred inside) {
  // Bounding box of the inside voxels (per-slice, then reduced).
  std::vector<std::array<int64_t, 6>> slab(static_cast<size_t>(d.z));
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      std::array<int64_t, 6> b{d.x, d.y, d.z, -1, -1, -1};
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i)
          if (inside(i, j, k)) {
            b[0] = std::min(b[0], i); b[1] = std::min(b[1], j); b[2] = std::min(b[2], k);
            b[3] = std::max(b[3], i); b[4] = std::max(b[4], j); b[5] = std::max(b[5], k);
          }
      slab[static_cast<size_t>(k)] = b;
    }
  });
  std::array<int64_t, 6> b{d.x, d.y, d.z, -1, -1, -1};
  for (const auto& s : slab)
    for (int a = 0; a < 3; ++a) {
      b[a] = std::min(b[a], s[a]);
      b[a + 3] = std::max(b[a + 3], s[a + 3]);
    }
  MaskBox m;
  if (b[3] < 0) return m;
  m.ox = b[0] - pad; m.oy = b[1] - pad; m.oz = b[2] - pad;
  m.nx = b[3] - b[0] + 1 + 2 * pad; m.ny = b[4] - b[1] + 1 + 2 * pad; m.nz = b[5] - b[2] + 1 + 2 * pad;
  // Huge pages: a box of tens of MB is then a few dozen page faults, not thousands.
  resizeHugePaged(m.inside, static_cast<size_t>(m.nx * m.ny * m.nz), uint8_t{0});
  std::vector<int64_t> counts(static_cast<size_t>(m.nz), 0);
  parallelFor(m.nz, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      const int64_t gk = k + m.oz;
      if (gk < 0 || gk >= d.z) continue;
      int64_t c = 0;
      for (int64_t j = 0; j < m.ny; ++j) {
        const int64_t gj = j + m.oy;
        if (gj < 0 || gj >= d.y) continue;
        for (int64_t i = 0; i < m.nx; ++i) {
          const int64_t gi = i + m.ox;
          if (gi < 0 || gi >= d.x) continue;
          if (inside(gi, gj, gk)) {
            m.inside[static_cast<size_t>((k * m.ny + j) * m.nx + i)] = 1;
            ++c;
          }
        }
      }
      counts[static_cast<size_t>(k)] = c;
    }
  });
  for (auto c : counts) m.count += c;
  return m;
}
}  // namespace

MaskBox extractMask(const VolumeU16& labels, const std::vector<uint16_t>& ids, int pad) {
  auto lut = std::make_unique<std::array<bool, 65536>>();
  for (auto id : ids) (*lut)[id] = true;
  return buildMask(labels.dims(), pad,
                   [&](int64_t i, int64_t j, int64_t k) { return (*lut)[labels(i, j, k)]; });
}

MaskBox maskFromVolume(const VolumeU8& mask, int pad) {
  return buildMask(mask.dims(), pad,
                   [&](int64_t i, int64_t j, int64_t k) { return mask(i, j, k) != 0; });
}

void indexToPhysical(TriMesh& mesh, const Geometry& g) {
  for (auto& v : mesh.vertices) {
    const Vec3 p = g.indexToPhysical(Vec3{v[0], v[1], v[2]});
    v = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
  }
  if (g.direction.determinant() < 0)
    for (auto& f : mesh.faces) std::swap(f[1], f[2]);
}

double maxDistanceToBinaryBoundary(const TriMesh& mesh, const MaskBox& mask, const Geometry& g,
                                   int radius) {
  const Vec3 sp = g.spacing;
  const size_t n = mesh.vertices.size();
  std::vector<double> best(n, 0.0);
  parallelFor(static_cast<int64_t>(n), [&](int64_t b, int64_t e) {
    for (int64_t vi = b; vi < e; ++vi) {
      const auto& v = mesh.vertices[static_cast<size_t>(vi)];
      const Vec3 q = g.physicalToIndex(Vec3{v[0], v[1], v[2]});
      const int64_t ci = std::llround(q.x), cj = std::llround(q.y), ck = std::llround(q.z);
      double d2 = std::numeric_limits<double>::infinity();
      for (int64_t k = ck - radius; k <= ck + radius; ++k)
        for (int64_t j = cj - radius; j <= cj + radius; ++j)
          for (int64_t i = ci - radius; i <= ci + radius; ++i) {
            if (!mask.at(i, j, k)) continue;
            // Faces of voxel (i,j,k) towards outside neighbours: squares in index space.
            static const int nb[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
            for (const auto& o : nb) {
              if (mask.at(i + o[0], j + o[1], k + o[2])) continue;
              // Square centred at voxel centre + o/2, spanning +-0.5 on the other two axes.
              const double c[3] = {i + 0.5 * o[0], j + 0.5 * o[1], k + 0.5 * o[2]};
              const double p[3] = {q.x, q.y, q.z};
              const double s[3] = {sp.x, sp.y, sp.z};
              double acc = 0;
              for (int a = 0; a < 3; ++a) {
                double t = p[a] - c[a];
                if (o[a] == 0) t = std::max(0.0, std::abs(t) - 0.5);
                acc += (t * s[a]) * (t * s[a]);
              }
              d2 = std::min(d2, acc);
            }
          }
      best[static_cast<size_t>(vi)] =
          std::isfinite(d2) ? std::sqrt(d2) : radius * std::min({sp.x, sp.y, sp.z});
    }
  }, 1024);
  double m = 0;
  for (double d : best) m = std::max(m, d);
  return m;
}

}  // namespace detail
}  // namespace vellum::illustration
