// Animated glTF export: the file is valid binary glTF 2.0 and carries the motions exactly
// (read back from the binary chunk and compared with the analytic values).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <fstream>

#include "test_data.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/gltf.hpp"

using namespace vellum;
using namespace vellum::illustration;
namespace fs = std::filesystem;

namespace {

struct Glb {
  nlohmann::json doc;
  std::vector<uint8_t> bin;
  uint32_t declaredLength = 0;
  size_t fileLength = 0;

  // The floats of accessor `a` (tightly packed, as the writer makes them).
  std::vector<float> floats(int a) const {
    const auto& acc = doc["accessors"][a];
    const auto& view = doc["bufferViews"][acc["bufferView"].get<int>()];
    std::vector<float> out(view["byteLength"].get<size_t>() / 4);
    std::memcpy(out.data(), bin.data() + view["byteOffset"].get<size_t>(), out.size() * 4);
    return out;
  }
};

Glb readGlb(const fs::path& path) {
  std::ifstream is(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  Glb g;
  g.fileLength = bytes.size();
  auto u32 = [&](size_t at) {
    uint32_t v;
    std::memcpy(&v, bytes.data() + at, 4);
    return v;
  };
  EXPECT_EQ(std::string(bytes.data(), 4), "glTF");
  EXPECT_EQ(u32(4), 2u);
  g.declaredLength = u32(8);
  const uint32_t jsonLength = u32(12);
  EXPECT_EQ(std::string(bytes.data() + 16, 4), "JSON");
  EXPECT_EQ(jsonLength % 4, 0u);
  g.doc = nlohmann::json::parse(std::string(bytes.data() + 20, jsonLength));
  const size_t binAt = 20 + jsonLength;
  const uint32_t binLength = u32(binAt);
  EXPECT_EQ(std::string(bytes.data() + binAt + 4, 3), "BIN");
  g.bin.assign(bytes.begin() + static_cast<std::ptrdiff_t>(binAt + 8),
               bytes.begin() + static_cast<std::ptrdiff_t>(binAt + 8 + binLength));
  return g;
}

TriMesh triangle() {
  TriMesh m;
  m.vertices = {{10, 20, 30}, {12, 20, 30}, {10, 23, 30}};
  m.faces = {{0, 1, 2}};
  return m;
}

// Rotation by `deg` about the patient's superior (z) axis.
RigidMotion turnAboutZ(double deg, std::array<double, 3> t = {0, 0, 0}) {
  const double a = deg * M_PI / 180, c = std::cos(a), s = std::sin(a);
  return {{c, -s, 0, s, c, 0, 0, 0, 1}, t};
}

}  // namespace

TEST(Gltf, RigidBoneKeysAreTheMotionsInGltfFrame) {
  const fs::path dir = test::tempDir("gltf-rigid");
  AnimatedScene scene;
  scene.keyTimesS = {0, 1, 2};
  AnimatedMesh bone{"bone", triangle(), {0.9f, 0.87f, 0.78f, 1}, {}, {}};
  bone.motions = {turnAboutZ(0), turnAboutZ(90), turnAboutZ(180, {5, 0, 0})};
  scene.meshes = {bone};
  saveAnimatedGltf(scene, dir / "pose.glb");
  const Glb g = readGlb(dir / "pose.glb");
  EXPECT_EQ(g.declaredLength, g.fileLength);
  EXPECT_EQ(g.doc["asset"]["version"], "2.0");
  EXPECT_EQ(g.doc["buffers"][0]["byteLength"].get<size_t>(), g.bin.size());

  // The node holds its vertices about the centroid; its translation is the centroid (m, L S A).
  const double cx = 32.0 / 3, cy = 21, cz = 30;  // LPS mm
  const auto& node = g.doc["nodes"][0];
  EXPECT_NEAR(node["translation"][0].get<double>(), cx * 1e-3, 1e-7);
  EXPECT_NEAR(node["translation"][1].get<double>(), cz * 1e-3, 1e-7);
  EXPECT_NEAR(node["translation"][2].get<double>(), -cy * 1e-3, 1e-7);
  const auto positions = g.floats(g.doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]);
  EXPECT_NEAR(positions[0], (10 - cx) * 1e-3, 1e-7);
  EXPECT_NEAR(positions[2], -(20 - cy) * 1e-3, 1e-7);

  const auto& anim = g.doc["animations"][0];
  ASSERT_EQ(anim["channels"].size(), 2u);
  const auto& samplers = anim["samplers"];
  const auto times = g.floats(samplers[0]["input"]);
  EXPECT_EQ(times, (std::vector<float>{0, 1, 2}));
  const auto q = g.floats(samplers[0]["output"]);  // rotation: x y z w per key
  ASSERT_EQ(q.size(), 12u);
  // 90 degrees about S (glTF +Y): (0, sin 45, 0, cos 45) up to sign, w > 0 at key 0.
  EXPECT_NEAR(q[3], 1, 1e-6);
  EXPECT_NEAR(std::abs(q[5]), std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(std::abs(q[7]), std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(q[4] * q[4] + q[6] * q[6], 0, 1e-12);
  // Neighbouring keys in one hemisphere (the short way round).
  for (int k = 1; k < 3; ++k)
    EXPECT_GT(q[4 * k] * q[4 * k - 4] + q[4 * k + 1] * q[4 * k - 3] + q[4 * k + 2] * q[4 * k - 2] + q[4 * k + 3] * q[4 * k - 1], 0);
  // The rotation's sense: glTF's node rotation applied to the local vertex must give the
  // LPS motion. Check key 1 on vertex 0: R_z(90) about the origin, then to glTF.
  const double x = 10, y = 20;  // LPS
  const double mx = -y, my = x;  // turned by 90 degrees about z
  const double w = q[7], qy = q[5];
  // Rotation about glTF Y by angle theta: (X, Z) -> (X cos + Z sin, -X sin + Z cos); theta = 2 atan2(qy, w).
  const double th = 2 * std::atan2(qy, w);
  const double lx = (10 - cx) * 1e-3, lz = -(20 - cy) * 1e-3;  // local vertex 0
  const auto t = g.floats(samplers[1]["output"]);
  const double gx = lx * std::cos(th) + lz * std::sin(th) + t[3], gz = -lx * std::sin(th) + lz * std::cos(th) + t[5];
  EXPECT_NEAR(gx, mx * 1e-3, 1e-6);
  EXPECT_NEAR(gz, -my * 1e-3, 1e-6);
  // Key 2 adds a 5 mm translation along L.
  EXPECT_NEAR(t[6], (-cx + 5) * 1e-3, 1e-6);
}

TEST(Gltf, SoftTissuePosesAreMorphTargetsPlayedOneHot) {
  const fs::path dir = test::tempDir("gltf-morph");
  AnimatedScene scene;
  scene.keyTimesS = {0, 0.5};
  AnimatedMesh skin{"skin", triangle(), {0.95f, 0.8f, 0.7f, 0.4f}, {}, {}};
  auto moved = triangle().vertices;
  moved[2][1] += 4;  // 4 mm posterior
  skin.posedVertices = {triangle().vertices, moved};
  scene.meshes = {skin};
  saveAnimatedGltf(scene, dir / "skin.glb");
  const Glb g = readGlb(dir / "skin.glb");
  const auto& prim = g.doc["meshes"][0]["primitives"][0];
  ASSERT_EQ(prim["targets"].size(), 2u);
  const auto d0 = g.floats(prim["targets"][0]["POSITION"]);
  const auto d1 = g.floats(prim["targets"][1]["POSITION"]);
  for (float v : d0) EXPECT_EQ(v, 0.0f);
  EXPECT_NEAR(d1[8], -4e-3, 1e-7);  // vertex 2's glTF Z = -P
  EXPECT_EQ(g.doc["materials"][0]["alphaMode"], "BLEND");
  const auto weights = g.floats(g.doc["animations"][0]["samplers"][0]["output"]);
  EXPECT_EQ(weights, (std::vector<float>{1, 0, 0, 1}));
}

TEST(Gltf, InconsistentInputIsRefusedNamingTheMesh) {
  const fs::path dir = test::tempDir("gltf-bad");
  AnimatedScene scene;
  scene.keyTimesS = {0, 1};
  AnimatedMesh bone{"tibia", triangle(), {1, 1, 1, 1}, {turnAboutZ(0)}, {}};
  scene.meshes = {bone};
  try {
    saveAnimatedGltf(scene, dir / "bad.glb");
    FAIL() << "one motion for two key times was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("tibia"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "bad.glb"));
  scene.meshes[0].motions.push_back(turnAboutZ(10));
  scene.keyTimesS = {1, 1};
  EXPECT_THROW(saveAnimatedGltf(scene, dir / "bad.glb"), Error);
}
