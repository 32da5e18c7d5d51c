// Silhouette loop of a closed mesh from an orthographic camera: the directed boundary of the
// front-facing triangles (each front face's half-edge whose twin face looks away). On a
// closed oriented mesh every vertex has as many outgoing as incoming boundary half-edges, so
// walking them always closes loops; the longest loop in the image is the outline.
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "vellum/core/error.hpp"
#include "vellum/illustration/curve_analogy.hpp"

namespace vellum::illustration {

Silhouette silhouetteLoop(const TriMesh& mesh, const render::Projection& proj) {
  if (proj.perspective()) throw Error("silhouette: orthographic cameras only (field of view 0)");
  const Vec3 fwd = proj.viewDirection();
  const size_t nf = mesh.faces.size();
  auto P = [&](uint32_t v) { return Vec3{mesh.vertices[v][0], mesh.vertices[v][1], mesh.vertices[v][2]}; };
  std::vector<char> front(nf);
  for (size_t f = 0; f < nf; ++f) {
    const auto& t = mesh.faces[f];
    front[f] = dot(cross(P(t[1]) - P(t[0]), P(t[2]) - P(t[0])), fwd) < 0;
  }
  auto key = [](uint32_t a, uint32_t b) { return (uint64_t(a) << 32) | b; };
  std::unordered_map<uint64_t, uint32_t> faceOf;  // directed half-edge -> face
  faceOf.reserve(3 * nf);
  for (size_t f = 0; f < nf; ++f)
    for (int i = 0; i < 3; ++i) faceOf[key(mesh.faces[f][i], mesh.faces[f][(i + 1) % 3])] = uint32_t(f);
  std::unordered_multimap<uint32_t, uint32_t> next;  // boundary half-edges a -> b
  for (size_t f = 0; f < nf; ++f) {
    if (!front[f]) continue;
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = mesh.faces[f][i], b = mesh.faces[f][(i + 1) % 3];
      const auto twin = faceOf.find(key(b, a));
      if (twin != faceOf.end() && !front[twin->second]) next.emplace(a, b);
    }
  }
  std::vector<Vec3> px(mesh.vertices.size());
  for (size_t v = 0; v < px.size(); ++v) px[v] = proj.toPixel(P(uint32_t(v))).value();
  std::vector<uint32_t> best;
  double bestLen = 0;
  while (!next.empty()) {
    std::vector<uint32_t> loop{next.begin()->first};
    double len = 0;
    for (;;) {
      auto it = next.find(loop.back());
      if (it == next.end()) break;  // open (only on a mesh with borders)
      const uint32_t b = it->second;
      next.erase(it);
      len += std::hypot(px[b].x - px[loop.back()].x, px[b].y - px[loop.back()].y);
      if (b == loop.front()) break;
      loop.push_back(b);
    }
    if (loop.size() >= 3 && len > bestLen) {
      bestLen = len;
      best = std::move(loop);
    }
  }
  if (best.empty()) throw Error("silhouette: the mesh has no closed silhouette loop");
  Silhouette s;
  s.vertices = best;
  for (uint32_t v : best) {
    s.pixels.push_back({px[v].x, px[v].y});
    s.depths.push_back(px[v].z);
  }
  return s;
}

std::vector<uint32_t> silhouetteVertices(const TriMesh& mesh, const render::Projection& proj) {
  const Vec3 fwd = proj.viewDirection();
  auto P = [&](uint32_t v) { return Vec3{mesh.vertices[v][0], mesh.vertices[v][1], mesh.vertices[v][2]}; };
  std::unordered_map<uint64_t, char> frontOf;  // undirected edge -> front flags seen (bit 0 back, 1 front)
  for (const auto& t : mesh.faces) {
    const bool front = dot(cross(P(t[1]) - P(t[0]), P(t[2]) - P(t[0])), fwd) < 0;
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = std::min(t[i], t[(i + 1) % 3]), b = std::max(t[i], t[(i + 1) % 3]);
      frontOf[(uint64_t(a) << 32) | b] |= front ? 2 : 1;
    }
  }
  std::vector<char> on(mesh.vertices.size(), 0);
  for (const auto& [key, flags] : frontOf)
    if (flags == 3) on[key >> 32] = on[key & 0xffffffffu] = 1;
  std::vector<uint32_t> out;
  for (size_t v = 0; v < on.size(); ++v)
    if (on[v]) out.push_back(uint32_t(v));
  return out;
}

}  // namespace vellum::illustration
