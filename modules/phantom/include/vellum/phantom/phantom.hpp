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
  kFibula = 8,       ///< thin bone: a thin cortical tube with marrow, labelled as one
  kPatella = 9,      ///< small dense bone in front of the joint
  kCartilage = 10,   ///< joint cartilage caps (soft tissue density ~ 100 HU)
};

/// Nominal HU of each tissue before partial-volume mixing and noise.
struct TissueHu {
  double air = -1000, skin = 40, fat = -100, muscle = 50, cortex = 1400, marrow = 20,
         cartilage = 110;
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

/// Generates the phantom. Dims from 16^3 to 1024^3 (memory budget checked first); throws
/// vellum::Error on bad options and vellum::Cancelled if `progress` is cancelled.
Phantom makePhantom(const PhantomOptions& options = {}, Progress& progress = Progress::none());

/// True for the ids that are bone (cortex, marrow, fibula, patella).
bool isBone(uint16_t id);
/// True for the cortical (dense) bone ids: what a bone threshold should find.
bool isCorticalBone(uint16_t id);
/// True for skin, fat, muscle, cartilage.
bool isSoftTissue(uint16_t id);

}  // namespace vellum::phantom
