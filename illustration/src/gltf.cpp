// Animated glTF 2.0 (.glb) export; see gltf.hpp for the conventions.
#include "vellum/illustration/gltf.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "vellum/core/error.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::illustration {
namespace {
using json = nlohmann::json;
using V3 = std::array<float, 3>;

// glTF component and target codes (glTF 2.0 specification, accessors and bufferViews).
constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// mm LPS -> metres in glTF's frame: (L, S, A) = (x, z, -y).
V3 toGltf(const std::array<double, 3>& p) {
  return {static_cast<float>(p[0] * 1e-3), static_cast<float>(p[2] * 1e-3), static_cast<float>(-p[1] * 1e-3)};
}
V3 toGltf(const V3& p) { return toGltf(std::array<double, 3>{p[0], p[1], p[2]}); }

// The rotation in glTF's frame, C R C^T with C the LPS -> (L, S, A) change of basis, as a
// unit quaternion (x, y, z, w).
std::array<float, 4> quaternion(const std::array<double, 9>& r) {
  // C = [[1,0,0],[0,0,1],[0,-1,0]]; (C R C^T)_ij = sum C_ik R_kl C_jl.
  const double C[3][3] = {{1, 0, 0}, {0, 0, 1}, {0, -1, 0}};
  double m[3][3] = {};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) m[i][j] += C[i][k] * r[3 * k + l] * C[j][l];
  // Shepperd's method: pick the largest of w, x, y, z to divide by (stable for any angle).
  double q[4];
  const double tr = m[0][0] + m[1][1] + m[2][2];
  if (tr > 0) {
    const double s = 2 * std::sqrt(1 + tr);
    q[3] = s / 4, q[0] = (m[2][1] - m[1][2]) / s, q[1] = (m[0][2] - m[2][0]) / s, q[2] = (m[1][0] - m[0][1]) / s;
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = 2 * std::sqrt(1 + m[0][0] - m[1][1] - m[2][2]);
    q[3] = (m[2][1] - m[1][2]) / s, q[0] = s / 4, q[1] = (m[0][1] + m[1][0]) / s, q[2] = (m[0][2] + m[2][0]) / s;
  } else if (m[1][1] > m[2][2]) {
    const double s = 2 * std::sqrt(1 + m[1][1] - m[0][0] - m[2][2]);
    q[3] = (m[0][2] - m[2][0]) / s, q[0] = (m[0][1] + m[1][0]) / s, q[1] = s / 4, q[2] = (m[1][2] + m[2][1]) / s;
  } else {
    const double s = 2 * std::sqrt(1 + m[2][2] - m[0][0] - m[1][1]);
    q[3] = (m[1][0] - m[0][1]) / s, q[0] = (m[0][2] + m[2][0]) / s, q[1] = (m[1][2] + m[2][1]) / s, q[2] = s / 4;
  }
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return {static_cast<float>(q[0] / n), static_cast<float>(q[1] / n), static_cast<float>(q[2] / n),
          static_cast<float>(q[3] / n)};
}

// The binary chunk and the JSON that describes it, grown one accessor at a time.
struct Builder {
  json doc;
  std::vector<uint8_t> bin;

  // Appends raw bytes (4-byte aligned, as accessors of floats and uint32 need) as a bufferView.
  int view(const void* data, size_t bytes, int target) {
    while (bin.size() % 4) bin.push_back(0);
    const size_t offset = bin.size();
    bin.resize(offset + bytes);
    std::memcpy(bin.data() + offset, data, bytes);
    json v = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}};
    if (target) v["target"] = target;
    doc["bufferViews"].push_back(v);
    return static_cast<int>(doc["bufferViews"].size()) - 1;
  }
  int accessor(int view, int componentType, size_t count, const char* type) {
    doc["accessors"].push_back({{"bufferView", view}, {"componentType", componentType}, {"count", count}, {"type", type}});
    return static_cast<int>(doc["accessors"].size()) - 1;
  }
  int vec3(const std::vector<V3>& v, bool withBounds, int target = kArrayBuffer) {
    const int a = accessor(view(v.data(), v.size() * sizeof(V3), target), kFloat, v.size(), "VEC3");
    if (withBounds) {  // required for POSITION (also of morph targets)
      V3 lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
      V3 hi{-lo[0], -lo[1], -lo[2]};
      for (const auto& p : v)
        for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p[c]), hi[c] = std::max(hi[c], p[c]);
      if (v.empty()) lo = hi = V3{0, 0, 0};
      doc["accessors"][a]["min"] = lo;
      doc["accessors"][a]["max"] = hi;
    }
    return a;
  }
  // `components` floats an element: 1 SCALAR, 3 VEC3, 4 VEC4.
  int floats(const std::vector<float>& v, int components, bool withBounds) {
    const char* type = components == 4 ? "VEC4" : components == 3 ? "VEC3" : "SCALAR";
    const int a = accessor(view(v.data(), v.size() * sizeof(float), 0), kFloat, v.size() / components, type);
    if (withBounds && !v.empty()) {  // animation input (times) needs min and max
      doc["accessors"][a]["min"] = {*std::min_element(v.begin(), v.end())};
      doc["accessors"][a]["max"] = {*std::max_element(v.begin(), v.end())};
    }
    return a;
  }
};

std::vector<V3> vertexNormals(const std::vector<V3>& p, const std::vector<std::array<uint32_t, 3>>& faces) {
  std::vector<V3> n(p.size(), V3{0, 0, 0});
  for (const auto& f : faces) {
    const V3 &a = p[f[0]], &b = p[f[1]], &c = p[f[2]];
    const V3 u{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const V3 x{u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};  // 2 x area
    for (uint32_t i : f)
      for (int k = 0; k < 3; ++k) n[i][k] += x[k];
  }
  for (auto& v : n) {
    const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v = len > 0 ? V3{v[0] / len, v[1] / len, v[2] / len} : V3{0, 1, 0};
  }
  return n;
}

void check(const AnimatedScene& scene) {
  const auto& t = scene.keyTimesS;
  for (size_t k = 0; k < t.size(); ++k)
    if (!(t[k] >= 0) || (k && !(t[k] > t[k - 1])))
      throw Error("glTF export: key times must be >= 0 and strictly increasing (key " + std::to_string(k) + ")");
  for (const auto& m : scene.meshes) {
    const std::string what = "glTF export: mesh '" + m.name + "'";
    if (!m.motions.empty() && !m.posedVertices.empty()) throw Error(what + " is both rigid and morphing");
    if (!m.motions.empty() && m.motions.size() != t.size())
      throw Error(what + " has " + std::to_string(m.motions.size()) + " motions for " + std::to_string(t.size()) + " key times");
    if (!m.posedVertices.empty() && m.posedVertices.size() != t.size())
      throw Error(what + " has " + std::to_string(m.posedVertices.size()) + " poses for " + std::to_string(t.size()) + " key times");
    for (const auto& pose : m.posedVertices)
      if (pose.size() != m.mesh.vertices.size()) throw Error(what + ": a pose's vertex count differs from the mesh's");
    for (const auto& f : m.mesh.faces)
      for (uint32_t i : f)
        if (i >= m.mesh.vertices.size()) throw Error(what + ": a face index is out of range");
  }
}

}  // namespace

void saveAnimatedGltf(const AnimatedScene& scene, const std::filesystem::path& path) {
  check(scene);
  Builder b;
  b.doc["asset"] = {{"version", "2.0"}, {"generator", "Vellum"}};
  b.doc["scene"] = 0;
  b.doc["scenes"] = json::array({{{"name", scene.name}, {"nodes", json::array()}}});
  std::vector<float> times(scene.keyTimesS.begin(), scene.keyTimesS.end());
  const int timeAccessor = times.empty() ? -1 : b.floats(times, 1, true);
  json channels = json::array(), samplers = json::array();
  auto animate = [&](int node, const char* pathName, const std::vector<float>& values, int components) {
    samplers.push_back({{"input", timeAccessor}, {"output", b.floats(values, components, false)}, {"interpolation", "LINEAR"}});
    channels.push_back({{"sampler", samplers.size() - 1}, {"target", {{"node", node}, {"path", pathName}}}});
  };

  for (const auto& m : scene.meshes) {
    // Rigid nodes hold their vertices about the centroid (see gltf.hpp); others as they are.
    std::array<double, 3> pivot{0, 0, 0};
    if (!m.motions.empty() && !m.mesh.vertices.empty()) {
      for (const auto& v : m.mesh.vertices)
        for (int k = 0; k < 3; ++k) pivot[k] += v[k];
      for (double& c : pivot) c /= static_cast<double>(m.mesh.vertices.size());
    }
    std::vector<V3> positions;
    positions.reserve(m.mesh.vertices.size());
    for (const auto& v : m.mesh.vertices) positions.push_back(toGltf(std::array<double, 3>{v[0] - pivot[0], v[1] - pivot[1], v[2] - pivot[2]}));
    json primitive = {{"attributes", {{"POSITION", b.vec3(positions, true)},
                                      {"NORMAL", b.vec3(vertexNormals(positions, m.mesh.faces), false)}}},
                      {"mode", 4}};
    const int indices = b.view(m.mesh.faces.data(), m.mesh.faces.size() * sizeof(m.mesh.faces[0]), kElementArrayBuffer);
    primitive["indices"] = b.accessor(indices, kUnsignedInt, m.mesh.faces.size() * 3, "SCALAR");
    json material = {{"name", m.name},
                     {"pbrMetallicRoughness", {{"baseColorFactor", m.rgba}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.65}}},
                     {"doubleSided", true}};
    if (m.rgba[3] < 1) material["alphaMode"] = "BLEND";
    b.doc["materials"].push_back(material);
    primitive["material"] = b.doc["materials"].size() - 1;
    json mesh = {{"name", m.name}};
    if (!m.posedVertices.empty()) {
      // One morph target per key: its displacement from the rest pose. The weights animate
      // one-hot from key to key, so linear interpolation blends neighbouring poses.
      for (const auto& pose : m.posedVertices) {
        std::vector<V3> delta(positions.size());
        for (size_t i = 0; i < pose.size(); ++i) {
          const V3 p = toGltf(pose[i]);
          for (int k = 0; k < 3; ++k) delta[i][k] = p[k] - positions[i][k];
        }
        primitive["targets"].push_back({{"POSITION", b.vec3(delta, true)}});
      }
      mesh["weights"] = std::vector<float>(m.posedVertices.size(), 0.0f);
    }
    mesh["primitives"] = json::array({primitive});
    b.doc["meshes"].push_back(mesh);
    json node = {{"name", m.name}, {"mesh", b.doc["meshes"].size() - 1}};
    if (!m.motions.empty()) node["translation"] = toGltf(pivot);
    b.doc["nodes"].push_back(node);
    const int nodeIndex = static_cast<int>(b.doc["nodes"].size()) - 1;
    b.doc["scenes"][0]["nodes"].push_back(nodeIndex);

    if (!m.motions.empty()) {
      std::vector<float> rotations, translations;
      for (const auto& mo : m.motions) {
        auto q = quaternion(mo.rotation);
        if (rotations.size() >= 4) {  // q and -q are one rotation: keep neighbours in one hemisphere so slerp takes the short way
          const float* prev = &rotations[rotations.size() - 4];
          if (prev[0] * q[0] + prev[1] * q[1] + prev[2] * q[2] + prev[3] * q[3] < 0)
            for (float& c : q) c = -c;
        }
        rotations.insert(rotations.end(), q.begin(), q.end());
        std::array<double, 3> c{};  // where the pivot goes: R c + t
        for (int i = 0; i < 3; ++i)
          c[i] = mo.rotation[3 * i] * pivot[0] + mo.rotation[3 * i + 1] * pivot[1] + mo.rotation[3 * i + 2] * pivot[2] + mo.translationMm[i];
        const V3 g = toGltf(c);
        translations.insert(translations.end(), g.begin(), g.end());
      }
      animate(nodeIndex, "rotation", rotations, 4);
      animate(nodeIndex, "translation", translations, 3);
    } else if (!m.posedVertices.empty()) {
      const size_t n = m.posedVertices.size();
      std::vector<float> weights(n * n, 0.0f);
      for (size_t k = 0; k < n; ++k) weights[k * n + k] = 1.0f;
      animate(nodeIndex, "weights", weights, 1);
    }
  }
  if (!channels.empty()) b.doc["animations"] = json::array({{{"name", scene.name}, {"channels", channels}, {"samplers", samplers}}});
  while (b.bin.size() % 4) b.bin.push_back(0);
  b.doc["buffers"] = json::array({{{"byteLength", b.bin.size()}}});

  std::string text = b.doc.dump();
  while (text.size() % 4) text.push_back(' ');  // the JSON chunk is padded with spaces
  const uint32_t total = static_cast<uint32_t>(12 + 8 + text.size() + 8 + b.bin.size());
  io::writeAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream os(tmp, std::ios::binary);
    if (!os) throw FileError(path, "cannot open for writing");
    auto u32 = [&](uint32_t v) { os.write(reinterpret_cast<const char*>(&v), 4); };  // little endian host
    os.write("glTF", 4);
    u32(2);
    u32(total);
    u32(static_cast<uint32_t>(text.size()));
    os.write("JSON", 4);
    os.write(text.data(), static_cast<std::streamsize>(text.size()));
    u32(static_cast<uint32_t>(b.bin.size()));
    os.write("BIN\0", 4);
    os.write(reinterpret_cast<const char*>(b.bin.data()), static_cast<std::streamsize>(b.bin.size()));
    os.flush();
    if (!os) throw FileError(path, "write failed (disk full?)");
  });
}

}  // namespace vellum::illustration
