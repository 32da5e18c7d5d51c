// Posed bones and skin as animated glTF (see pose_gltf.hpp).
#include "vellum/app/pose_gltf.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/error.hpp"
#include "vellum/illustration/gltf.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/render/annotations.hpp"

namespace vellum::app {
using namespace vellum::deformation;
namespace ill = vellum::illustration;

const params::Table<PoseGltfOptions>& poseGltfOptionsTable() {
  using O = PoseGltfOptions;
  static const params::Table<O> t{
      params::real<O>("gltf_keys_per_second", &O::keysPerSecond,
                      {"glTF keys per second", "how densely the pose's keyframes are sampled into the glTF animation", "1/s", 1, 120}),
      params::integer<O>("gltf_bone_faces", &O::boneFaces,
                         {"glTF bone faces", "face budget of each bone mesh", "faces", 100, 10000000}),
      params::integer<O>("gltf_skin_faces", &O::skinFaces,
                         {"glTF skin faces", "face budget of the skin mesh", "faces", 100, 10000000}),
  };
  return t;
}

namespace {

ill::RigidMotion motionOf(const RigidTransform& t) {
  ill::RigidMotion m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.rotation[3 * r + c] = t.rotation(r, c) * t.scale;
  m.translationMm = {t.translation.x, t.translation.y, t.translation.z};
  return m;
}

}  // namespace

PoseGltfSummary writePoseGltf(const Pose& pose, const PoseSamples& samples, const LabelVolume& labels,
                              const MlsParams& mls, const PoseGltfOptions& options,
                              const std::filesystem::path& path, const PoseSkinMap& skinMap, Progress& progress) {
  if (skinMap.twist && !skinMap.bodies) throw Error("the glTF skin's twist map needs the pose's rigid bodies");
  // Key times over the keyframes (a still pose: two keys at 0 and 1 s, both the pose).
  const double duration = pose.lastKeyframeTimeS();
  const int keys = std::max(2, static_cast<int>(std::ceil(duration * options.keysPerSecond)) + 1);
  std::vector<double> times(keys);
  for (int k = 0; k < keys; ++k) times[k] = duration > 0 ? duration * k / (keys - 1) : static_cast<double>(k);
  std::vector<std::vector<RigidTransform>> transforms;  // per key, per joint
  std::vector<ControlPoints> forward;                   // per key: targets as handles, run forwards
  std::vector<std::vector<double>> keyAngles;
  for (double t : times) {
    const auto angles = pose.anglesAt(duration > 0 ? t : duration);
    transforms.push_back(jointTransforms(pose, angles));
    forward.push_back(posedPoints(samples, pose, angles));
    keyAngles.push_back(angles);
  }

  // The meshes: one per joint child, one per root joint's parent, and the skin.
  std::vector<ill::Segment> segments;
  std::vector<int> jointOf;  // per bone segment: the joint that moves it, -1 still
  for (size_t j = 0; j < pose.joints.size(); ++j) {
    const Joint& joint = pose.joints[j];
    if (joint.proximal < 0) {
      segments.push_back({joint.name + " parent", joint.parent, {232, 222, 196}});
      jointOf.push_back(-1);
    }
    segments.push_back({joint.name + " child", joint.child, {232, 222, 196}});
    jointOf.push_back(static_cast<int>(j));
  }
  const size_t bones = segments.size();
  std::vector<uint16_t> all;  // every id present: the skin is the outer surface of the whole map
  const std::vector<uint64_t> counts = labels.histogram();
  for (size_t id = 1; id < counts.size(); ++id)
    if (counts[id]) all.push_back(static_cast<uint16_t>(id));
  segments.push_back({"skin", all, {236, 196, 170}});

  ill::ShapeOptions shape;
  shape.targetFaces = options.boneFaces;
  ill::StageTimes stageTimes;
  std::vector<ill::SegmentShape> shapes = ill::buildShapes(labels, {segments.begin(), segments.end() - 1}, shape, stageTimes, progress);
  shape.targetFaces = options.skinFaces;
  auto skin = ill::buildShapes(labels, {segments.back()}, shape, stageTimes, progress);
  shapes.push_back(std::move(skin.front()));

  ill::AnimatedScene scene;
  scene.name = "Vellum pose";
  scene.keyTimesS = times;
  PoseGltfSummary summary;
  summary.keys = keys;
  summary.skinMap = skinMap.twist ? "twist" : "mls";
  for (size_t s = 0; s < shapes.size(); ++s) {
    ill::AnimatedMesh m;
    m.name = shapes[s].segment.name;
    m.mesh = std::move(shapes[s].mesh);
    summary.faces += static_cast<int64_t>(m.mesh.faces.size());
    const auto& rgb = shapes[s].segment.rgb;
    m.rgba = {rgb[0] / 255.0f, rgb[1] / 255.0f, rgb[2] / 255.0f, s < bones ? 1.0f : 0.45f};
    if (s < bones) {
      ++summary.bones;
      for (int k = 0; k < keys; ++k)
        m.motions.push_back(jointOf[s] < 0 ? ill::RigidMotion{} : motionOf(transforms[k][jointOf[s]]));
    } else {
      std::vector<Vec3> rest;
      rest.reserve(m.mesh.vertices.size());
      for (const auto& v : m.mesh.vertices) rest.push_back({v[0], v[1], v[2]});
      for (int k = 0; k < keys; ++k) {
        // evaluateMls maps output positions to sources; with sources and targets swapped it
        // maps rest positions to posed ones (the forward map).
        ControlPoints swapped = forward[k];
        for (auto& p : swapped) std::swap(p.source, p.target);
        std::vector<Vec3> posed = evaluateMls(swapped, mls, rest);
        if (skinMap.twist) {
          // The still pose's map at this key, inverted where each vertex is drawn (Newton from
          // the vertex, on the map as the renderer samples it); the MLS estimate where it fails.
          progress.checkCancelled();
          const ControlVolume cv = skinMap.twist->at(keyAngles[k], *skinMap.bodies, progress);
          const auto drawn = render::deformedPositions(cv, labels.geometry(), rest);
          for (size_t i = 0; i < posed.size(); ++i)
            if (drawn[i]) posed[i] = *drawn[i];
            else ++summary.skinUninverted;
        }
        std::vector<std::array<float, 3>> out(posed.size());
        for (size_t i = 0; i < posed.size(); ++i) {
          out[i] = {static_cast<float>(posed[i].x), static_cast<float>(posed[i].y), static_cast<float>(posed[i].z)};
          summary.skinMaxMoveMm = std::max(summary.skinMaxMoveMm, norm(posed[i] - rest[i]));
        }
        m.posedVertices.push_back(std::move(out));
      }
    }
    scene.meshes.push_back(std::move(m));
  }
  ill::saveAnimatedGltf(scene, path);
  return summary;
}

}  // namespace vellum::app
