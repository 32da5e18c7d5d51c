#pragma once
// `vellum pose --gltf`: the posed bones and skin as an animated glTF 2.0 file (for slides, the
// web and AR viewers): each joint's child bone and each root parent bone is a node with its
// keyframed rigid transform (exactly the joint rotations of the pose), the skin — the outer
// surface of the whole label map — one mesh whose keyframes are morph targets. The skin's
// vertices follow the map `--out` is made with: with the twist map, each key's twist map
// (deformation::TwistFrames) inverted at the vertices (render::deformedPositions: Newton on
// the map as drawn); with the MLS map, the forward MLS map of the pose's generated control
// points (the volume deformation's map, run forwards), an approximation of `--out` near the bones.
#include <filesystem>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/deformation/mls.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/deformation/twist_frames.hpp"

namespace vellum::app {

struct PoseGltfOptions {
  double keysPerSecond = 10;  ///< key times sampled over the pose's keyframes (at least 2 keys)
  int64_t boneFaces = 8000;   ///< face budget per bone mesh (decimation)
  int64_t skinFaces = 40000;  ///< face budget of the skin mesh
};
const params::Table<PoseGltfOptions>& poseGltfOptionsTable();

/// What the file holds, for the report.
struct PoseGltfSummary {
  int bones = 0, keys = 0;
  int64_t faces = 0;
  double skinMaxMoveMm = 0;  ///< the largest skin vertex displacement over the keys
  std::string skinMap = "mls";  ///< "twist" or "mls": the map the skin's morph targets follow
  /// Twist: vertex-keys the inversion did not reach (left at the forward MLS estimate).
  int64_t skinUninverted = 0;
};

/// The skin's map: empty = the forward MLS map; `twist` (with the full-resolution `bodies` its
/// snap keeps exact) = the still pose's twist map at each key.
struct PoseSkinMap {
  const deformation::TwistFrames* twist = nullptr;
  const deformation::RigidBodies* bodies = nullptr;
};

/// Meshes the pose's bones and the skin from `labels`, poses them at the keys and writes
/// `path` (.glb) atomically. Error for a pose bone with no voxel.
PoseGltfSummary writePoseGltf(const deformation::Pose& pose, const deformation::PoseSamples& samples,
                              const LabelVolume& labels, const deformation::MlsParams& mls,
                              const PoseGltfOptions& options, const std::filesystem::path& path,
                              const PoseSkinMap& skinMap = {}, Progress& progress = Progress::none());

}  // namespace vellum::app
