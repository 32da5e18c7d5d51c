#pragma once
// The built-in synthetic CT phantom: a knee (femur, tibia, fibula, patella) in soft tissue.
// Deterministic for a given seed (independent of thread count), in HU, with its ground-truth
// label volume. Used by the demo, the tests and the benchmarks, so nobody needs a download.
#include <cstdint>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::phantom {

/// Label ids of the ground truth. Bones are separate rigid bodies: cortex and marrow of one
/// bone are adjacent, different bones are separated by the joint space or soft tissue.
enum LabelId : uint16_t {
  kAir = 0,
  kSkin = 1,
  kFat = 2,          ///< subcutaneous fat
  kMuscle = 3,
  kFemurCortex = 4,
  kFemurMarrow = 5,
  kTibiaCortex = 6,
  kTibiaMarrow = 7,
  kFibula = 8,       ///< thin bone: thin cortical tube around a cancellous core, one label
  kPatella = 9,      ///< small bone in front of the joint: thin cortex + cancellous core
  kCartilage = 10,   ///< joint cartilage caps (soft tissue density ~ 100 HU)
};

/// Nominal HU of each tissue before partial-volume mixing and noise.
/// `cancellous` fills the fibula and the patella (both labelled as one cortical-bone id), so
/// that every voxel of a cortical-bone label is dense: a bone threshold finds all of it.
struct TissueHu {
  double air = -1000, skin = 40, fat = -100, muscle = 50, cortex = 1400, marrow = 20,
         cartilage = 110, cancellous = 450;
};

struct PhantomOptions {
  /// Voxels per axis. The field of view is fixed (physical size of the leg does not change
  /// with resolution): 180 x 180 x 220 mm, so spacing = fov / dims unless `spacing` is set.
  Dims dims{128, 128, 128};
  /// Spacing in mm; zero means fieldOfView / dims (anisotropic spacing allowed).
  Vec3 spacing{0, 0, 0};
  Vec3 fieldOfViewMm{180, 180, 220};
  uint64_t seed = 1;
  double noiseSigmaHu = 15.0;  ///< Gaussian noise, deterministic per voxel
  bool partialVolume = true;   ///< supersample tissue boundaries (4x4x4 at edges)
  double kneeFlexionDeg = 0.0; ///< tibia rotated about the joint's medio-lateral axis
  TissueHu hu;
};

struct Phantom {
  VolumeI16 ct;        ///< HU, background -1000
  LabelVolume labels;  ///< ground truth with a named, coloured label table
};

/// Generates the phantom. Dims from 16 to 1024 per axis (memory budget for CT + labels
/// checked first); spacing and field of view must be positive and finite, noiseSigmaHu >= 0,
/// kneeFlexionDeg in [0, 90]. Throws vellum::Error on bad options and vellum::Cancelled if
/// `progress` is cancelled. The volume is centred on (0,0,0) mm with identity direction.
Phantom makePhantom(const PhantomOptions& options = {}, Progress& progress = Progress::none());

/// The anatomy at one physical point (mm, LPS), without partial volume or noise: the exact
/// ground truth that makePhantom samples at voxel centres (and 4x4x4 sub-voxel positions).
struct PhantomPoint {
  uint16_t label = kAir;
  double hu = -1000;  ///< nominal HU of the tissue there (from options.hu)
};
/// Evaluates the anatomy at `pMm`; uses only options.kneeFlexionDeg and options.hu.
PhantomPoint samplePhantom(const Vec3& pMm, const PhantomOptions& options = {});

/// The knee flexes about the x (medio-lateral) axis through this point (mm): the centre of
/// the femoral condyles' sagittal circles, ~24.5 mm above the joint line (z = 0).
/// A tibia point q at flexion 0 moves to  A + Rx(deg) (q - A), with
/// Rx(a): (y, z) -> (y cos a - z sin a, y sin a + z cos a)  (the foot moves posteriorly, +y).
Vec3 flexionAxisPointMm();
/// Where a calf point (tibia, fibula, calf soft tissue) at flexion 0 lies at `flexionDeg`.
Vec3 flexCalfPoint(const Vec3& pMm, double flexionDeg);

/// True for the ids that are bone (cortex, marrow, fibula, patella).
bool isBone(uint16_t id);
/// True for the cortical (dense) bone ids: what a bone threshold should find.
bool isCorticalBone(uint16_t id);
/// True for skin, fat, muscle, cartilage.
bool isSoftTissue(uint16_t id);

}  // namespace vellum::phantom
