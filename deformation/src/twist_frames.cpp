// The twist map as a frame's control volume (see twist_frames.hpp).
#include "vellum/deformation/twist_frames.hpp"

#include <algorithm>

#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::deformation {

LabelVolume labelsAtNodes(const LabelVolume& labels, int scale) {
  if (scale < 1) throw Error("labels at nodes: the scale must be >= 1");
  if (scale == 1) return labels;
  const Geometry& g = labels.geometry();
  const Geometry grid = controlGrid(g, scale);
  LabelVolume out(grid);
  for (const Label& l : labels.table()) out.setLabel(l);
  const Dims d = grid.dims, s = g.dims;
  const uint16_t* src = labels.ids().data();
  uint16_t* dst = out.ids().data();
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          // The last node may pass the last voxel (controlGrid): it reads that voxel.
          const int64_t si = std::min(i * scale, s.x - 1), sj = std::min(j * scale, s.y - 1),
                        sk = std::min(k * scale, s.z - 1);
          dst[(k * d.y + j) * d.x + i] = src[(sk * s.y + sj) * s.x + si];
        }
  });
  return out;
}

std::shared_ptr<const RigidBodies> nodeBodiesOf(const LabelVolume& nodeLabels,
                                                const std::vector<std::vector<uint16_t>>& groups, int scale,
                                                const FixedRegions& fixed) {
  const int64_t minVoxels = std::max<int64_t>(1, 20 / (int64_t(scale) * scale * scale));
  return std::make_shared<const RigidBodies>(RigidBodies::fromLabelGroups(nodeLabels, groups, minVoxels, fixed));
}

TwistFrames::TwistFrames(Pose pose, std::shared_ptr<const RigidBodies> nodeBodies, const Geometry& output, int scale,
                         TwistParams params)
    : pose_(std::move(pose)),
      nodeBodies_(std::move(nodeBodies)),
      output_(output),
      grid_(controlGrid(output, scale)),
      scale_(scale),
      params_(params) {
  if (!nodeBodies_) throw Error("twist frames: the rigid bodies at the nodes are missing");
  // twistMap() checks the node bodies against the node grid.
  // At scale > 1 the node map is upsampled to the voxels, and must not fold there either: by
  // the twist kernel (core TwistKernel: w interpolated, each sample turned by it) for up to its
  // 4 stages, whose det at the cells' corners the nodes' check bounds (knee movie frames: 17-23
  // folded voxels -> 0); a longer chain interpolates the turned positions, whose cells are
  // checked instead (feet frames at 20 deg: 0.0015 -> 0.0001 % of the tissue folded).
  if (scale_ > 1) {
    const bool kernel = pose_.joints.size() <= size_t(TwistKernel::kMaxStages);
    params_.kernelCheck = params_.kernel = kernel;
    params_.cellCheck = !kernel;
  }
}

ControlVolume TwistFrames::at(const std::vector<double>& anglesDeg, const RigidBodies& bodies, Progress& progress,
                              std::vector<TwistJointStats>* stats) const {
  return *sharedAt(anglesDeg, bodies, progress, stats);
}

std::shared_ptr<const ControlVolume> TwistFrames::sharedAt(const std::vector<double>& anglesDeg,
                                                           const RigidBodies& bodies, Progress& progress,
                                                           std::vector<TwistJointStats>* stats) const {
  {
    std::lock_guard lock(mutex_);
    if (last_.map && last_.anglesDeg == anglesDeg && last_.bodies == &bodies) {
      if (stats) *stats = last_.stats;
      return last_.map;
    }
  }
  TwistMap m = twistMap(pose_, anglesDeg, *nodeBodies_, grid_, params_, progress);
  const std::vector<TwistJointStats> joints = m.joints;
  if (stats) *stats = joints;
  auto shared = std::make_shared<ControlVolume>();
  ControlVolume& cv = *shared;
  cv.grid = grid_;
  cv.scale = scale_;
  cv.sourceMm = std::move(m.mapMm);
  cv.output = output_;
  cv.twist = m.kernel;
  if (scale_ > 1) {
    const Geometry& fine = bodies.classes().geometry();
    if (!(fine.dims == output_.dims) || !fine.approxEqual(output_, 1e-3))
      throw Error("twist frames: the rigid bodies' grid differs from the output grid");
    // Interpolating the node map is not rigid inside a bone thinner than a few cells: the
    // snap puts every voxel whose source lands in a bone on that bone's pose transform, as
    // twistMap()'s own snap does per voxel at scale 1. The interpolation errors are under a
    // node cell's diagonal, so it reaches that far and the bones are exact — unless the node
    // map's bones gave (soft rims, where bones touch along the turn): their rim voxels then lie
    // millimetres from the turn, and snapping them back is a jump beside blended tissue that
    // folds, so the snap reaches only snapMaxVoxels of an output voxel, as twistMap()'s own
    // (feet frames at 20 deg: folds 0.098 -> 0.0015 % of the tissue, bone RMS 0.81 -> 0.69 mm).
    std::vector<RigidTransform> backward;
    for (const auto& t : knownBodyTransforms(pose_, bodies, anglesDeg))
      backward.push_back(t.value_or(RigidTransform{}));  // fixed and unnamed bodies stay
    const bool softRims =
        std::any_of(joints.begin(), joints.end(), [](const TwistJointStats& j) { return j.softenedVoxels > 0; });
    const double voxelMm = fine.minSpacing();
    cv.rigidSnap = rigidSnapOf(bodies, backward, softRims ? params_.snapMaxVoxels * voxelMm : norm(grid_.spacing));
  }
  std::lock_guard lock(mutex_);
  last_ = {anglesDeg, &bodies, shared, joints};
  return shared;
}

std::shared_ptr<const ControlVolume> TwistFrames::atTime(double timeS, const RigidBodies& bodies,
                                                         Progress& progress) const {
  return sharedAt(pose_.anglesAt(timeS), bodies, progress);
}

}  // namespace vellum::deformation
