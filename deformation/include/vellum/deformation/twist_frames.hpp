#pragma once
// The twist map (twist_map.hpp) as a movie frame's control volume: `vellum pose --map twist`'s
// movie, glTF skin and the studio's joint tool draw the same map as the still pose (--out).
// At scale 1 the nodes are the output voxels and the control volume's nodes ARE twistMap()'s
// map (bit for bit). At scale s > 1 (a 512^2 x 350 movie: the full-size map costs ~20 s and
// 1.1 GB a frame) the twist map is made on the node grid (controlGrid(output, s)) from the
// bones sampled at the nodes, and the full-resolution bones are put back by the voxel snap
// (RigidSnap) with each bone's pose transform — exactly, or, in a frame whose node map made
// bones give (soft rims), only where that moves a voxel's source by at most
// TwistParams::snapMaxVoxels (a longer snap would fold beside the tissue); fixed regions
// exact (held), the tissue between them the coarse twist upsampled by its own kernel (core
// TwistKernel: each voxel turned by the interpolated weights, so it folds no more than the
// nodes' weights allow; poses of at most 4 joints, longer chains interpolate positions).
#include <memory>
#include <mutex>
#include <vector>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/deformation/control_volume.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/twist_map.hpp"

namespace vellum::deformation {

/// `labels` at the nodes of controlGrid(labels' grid, scale): each node takes the label of the
/// voxel it sits on (node i on voxel min(i s, d - 1)). Scale 1: a copy.
LabelVolume labelsAtNodes(const LabelVolume& labels, int scale);

/// The pose's bodies on the nodes: RigidBodies::fromLabelGroups of `nodeLabels` (labelsAtNodes()
/// at `scale`) with the full-resolution bodies' groups and fixed regions, their 20-voxel minimum
/// scaled to the nodes (at least 1): what TwistFrames takes.
std::shared_ptr<const RigidBodies> nodeBodiesOf(const LabelVolume& nodeLabels,
                                                const std::vector<std::vector<uint16_t>>& groups, int scale,
                                                const FixedRegions& fixed);

/// Frame maps of one pose on one output grid. `nodeBodies` are the pose's bodies on
/// controlGrid(output, scale) (RigidBodies::fromLabelGroups of labelsAtNodes(), the same groups
/// and fixed regions as the full-resolution bodies). at() is const and may run on several
/// threads at once. The last map is kept: a frame at the same angles (a held keyframe: half
/// of a movie that turns and then holds) is a copy of it, not made again.
class TwistFrames {
 public:
  TwistFrames(Pose pose, std::shared_ptr<const RigidBodies> nodeBodies, const Geometry& output, int scale,
              TwistParams params = {});
  /// The control volume at `anglesDeg` (one per joint): nodes from twistMap() on the node grid,
  /// grid = controlGrid(output, scale), scale and `output` set. Scale > 1: the voxel snap of
  /// `bodies` (full resolution, on `output`; they must outlive the result, whose snap shares
  /// their class voxels) with the pose's transforms. `stats` (optional): twistMap()'s per joint.
  ControlVolume at(const std::vector<double>& anglesDeg, const RigidBodies& bodies,
                   Progress& progress = Progress::none(), std::vector<TwistJointStats>* stats = nullptr) const;
  /// at() without its copy: the map kept for the next call (shared: a movie frame's is
  /// 138 MB at 512^2 x 350, and a held frame's is the frame before's).
  std::shared_ptr<const ControlVolume> sharedAt(const std::vector<double>& anglesDeg, const RigidBodies& bodies,
                                                Progress& progress = Progress::none(),
                                                std::vector<TwistJointStats>* stats = nullptr) const;
  /// sharedAt() at the pose's angles at time t (Pose::anglesAt).
  std::shared_ptr<const ControlVolume> atTime(double timeS, const RigidBodies& bodies,
                                              Progress& progress = Progress::none()) const;
  const Pose& pose() const { return pose_; }
  int scale() const { return scale_; }

 private:
  Pose pose_;
  std::shared_ptr<const RigidBodies> nodeBodies_;
  Geometry output_, grid_;
  int scale_ = 1;
  TwistParams params_;
  struct Last {
    std::vector<double> anglesDeg;
    const RigidBodies* bodies = nullptr;
    std::shared_ptr<const ControlVolume> map;
    std::vector<TwistJointStats> stats;
  };
  mutable std::mutex mutex_;
  mutable Last last_;
};

/// The voxel snap of `bodies` with known backward transforms (bodies() order, output -> source:
/// every body valid), its reach bounded as the MLS map's (applyRigidity), a snap made only
/// where it moves the source by at most `maxSnapMm`. Defined beside applyRigidity's own snap
/// (rigidity.cpp).
std::shared_ptr<const RigidSnap> rigidSnapOf(const RigidBodies& bodies, const std::vector<RigidTransform>& backward,
                                             double maxSnapMm);

}  // namespace vellum::deformation
