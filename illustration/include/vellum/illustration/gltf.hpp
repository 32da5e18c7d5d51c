#pragma once
// Animated glTF 2.0 export (binary .glb): posed bones as rigid nodes with keyframed
// transforms, soft tissue (skin) as one mesh with a morph target per keyframe — what slide
// software, web viewers (three.js, <model-viewer>) and AR viewers play without Vellum.
//
// Coordinates: Vellum meshes are in millimetres, patient LPS; glTF is metres, +Y up, +Z the
// asset's front. The file maps L -> +X, S -> +Y, A (= -P) -> +Z (a proper rotation), scaled
// by 0.001, so a patient standing in the scanner stands up in the viewer, facing the camera.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/illustration/shape.hpp"

namespace vellum::illustration {

/// A rigid motion x -> rotation * x + translation in millimetres (LPS), rotation row-major.
struct RigidMotion {
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 3> translationMm{0, 0, 0};
};

/// One mesh of the animated scene. Exactly one of `motions` / `posedVertices` may be
/// non-empty (or neither: the mesh stands still); either has one entry per key time.
struct AnimatedMesh {
  std::string name;                     ///< node and mesh name ("tibia", "skin")
  TriMesh mesh;                         ///< rest pose, mm LPS, counter-clockwise outside
  std::array<float, 4> rgba{0.9f, 0.87f, 0.78f, 1.0f};  ///< base colour; alpha < 1 blends
  std::vector<RigidMotion> motions;     ///< a rigid bone: its motion at each key time
  /// Soft tissue: the vertex positions (mm LPS, same count and order as mesh.vertices) at
  /// each key time; each becomes a morph target, played by weights.
  std::vector<std::vector<std::array<float, 3>>> posedVertices;
};

struct AnimatedScene {
  std::string name = "Vellum pose";
  std::vector<double> keyTimesS;  ///< strictly increasing, >= 0; empty for a still scene
  std::vector<AnimatedMesh> meshes;
};

/// Writes `scene` as a binary glTF 2.0 file (.glb) atomically. Vertex normals are
/// area-weighted; a rigid node rotates about its mesh's centroid, so linear interpolation
/// between keys (rotation slerp, translation lerp) bends about the bone, not the origin.
/// Throws vellum::Error naming the mesh for inconsistent input (key counts, vertex counts,
/// indices out of range, times not increasing).
void saveAnimatedGltf(const AnimatedScene& scene, const std::filesystem::path& path);

}  // namespace vellum::illustration
