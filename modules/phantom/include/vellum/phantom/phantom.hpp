#pragma once
// The built-in synthetic CT phantom: a knee (femur, tibia, fibula, patella) in soft tissue.
// Deterministic for a given seed (independent of thread count), in HU, with its ground-truth
// label volume. Used by the demo, the tests and the benchmarks, so nobody needs a download.
//
// Anatomy (a right knee, LPS mm: +x patient left = medial, +y posterior, +z superior; the
// joint line is z = 0; the physical anatomy does not depend on dims or spacing):
//  - leg: elliptic cylinder, half-widths 60 x 54 mm at the knee, widening to ~64 x 58 (thigh
//    top) and ~63 x 57 (calf bottom); skin 2 mm; subcutaneous fat 6 mm (front) to 12 mm (back).
//  - femur (z 2.5..100): shaft radius 13 mm, cortex 4 mm; flaring metaphysis; two condyles
//    (x = +-19 mm, 26 mm wide, sagittal radius 22 mm about the flexion axis), cortex 1.2 mm.
//  - tibia (z -99..-2.5): plateau 72 x 50 mm with a 6 degree posterior slope, cortex 1.5 mm;
//    shaft radius 12 mm at (3, -6), cortex 4 mm. Bone-to-bone joint gap 5 mm, with 2 mm
//    cartilage caps on both sides (1 mm of joint space between them).
//  - fibula (z -95.5..-42.5) at (-33, 20): lateral-posterior, radius 5.5 mm (head 7.5 mm),
//    cortex 1.5 mm around a cancellous core.
//  - patella at (0, -35, 34): ellipsoid 40 x 17 x 40 mm, cortex 1.5 mm, cancellous core.
// Every structure is a signed distance function (samplePhantom gives the point truth).
//
// Voxel truth (labels) = the MAJORITY structure of the voxel, i.e. the label held by most of
// the same 64 sub-samples (subSampleOffsets: one jittered sample in each of 4x4x4 strata of
// a smooth point-spread function about one voxel wide) whose tissue HU average into the CT
// value (ties: bone cortex > bone marrow/core > cartilage > muscle > fat > skin > air).
// Voxels with no boundary within the PSF's reach (just under one voxel per axis) hold a
// single structure and take it unchanged. So the label is the
// tissue that dominates the voxel's HU: a threshold half-way between two tissues recovers it
// except where three tissues share a voxel. With partialVolume = false the CT samples the
// voxel centre only, and the labels do too (the structure containing the centre).
// Bones are separate 26-connected components (tested at 2.8 x 2.8 x 3.4 mm and finer,
// flexion 0..90 degrees; the 5 mm joint gap is the limit).
// Cortical-bone threshold: 700 HU (about half-way from cortex to marrow/muscle/cartilage)
// against isCorticalBone, default options: Dice 0.981 at 128^3 (best 0.981 at 725 HU),
// 0.990 at 256^3 (tests/phantom/phantom_intensity_test.cpp; with psfSmoothingVoxels = 0,
// a box PSF: 0.984 and 0.991). A +300 HU threshold also takes
// the cancellous cores (450 HU): it finds whole bones, not cortex.
#include <array>
#include <cstdint>

#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::phantom {

/// Label ids of the ground truth. Bones are separate rigid bodies: cortex and marrow (or
/// cancellous core) of one bone are adjacent, different bones are separated by the joint
/// space or soft tissue. Rigid body of each bone (see boneOf / boneMap):
///   femur = {4, 5}, tibia = {6, 7}, fibula = {8, 11 inside it}, patella = {9, 11 inside it}.
enum LabelId : uint16_t {
  kAir = 0,
  kSkin = 1,
  kFat = 2,          ///< subcutaneous fat
  kMuscle = 3,
  kFemurCortex = 4,
  kFemurMarrow = 5,
  kTibiaCortex = 6,
  kTibiaMarrow = 7,
  kFibula = 8,       ///< the fibula's cortical shell (1.5 mm) around a cancellous core (11)
  kPatella = 9,      ///< the patella's cortical shell (1.5 mm) around a cancellous core (11)
  kCartilage = 10,   ///< joint cartilage caps (soft tissue density ~ 100 HU)
  kCancellous = 11,  ///< cancellous bone: the cores of the fibula and the patella (~450 HU)
};

/// Nominal HU of each tissue before partial-volume mixing and noise. Cortex: labels 4, 6, 8,
/// 9; marrow: 5, 7; cancellous: 11.
struct TissueHu {
  double air = -1000, skin = 40, fat = -100, muscle = 50, cortex = 1400, marrow = 20,
         cartilage = 110, cancellous = 450;
};

/// The cortical-bone threshold for the default TissueHu (see the header comment): voxels at or
/// above it are, by majority, cortex (isCorticalBone).
inline constexpr double kCorticalThresholdHu = 700.0;

/// Default PhantomOptions::psfSmoothingVoxels.
inline constexpr double kDefaultPsfSmoothing = 0.9;

struct PhantomOptions {
  /// Voxels per axis. The field of view is fixed (physical size of the leg does not change
  /// with resolution): 180 x 180 x 220 mm, so spacing = fov / dims unless `spacing` is set.
  Dims dims{128, 128, 128};
  /// Spacing in mm; all three zero means fieldOfView / dims (anisotropic spacing allowed).
  /// With an explicit spacing the field of view is dims * spacing (fieldOfViewMm is unused).
  Vec3 spacing{0, 0, 0};
  Vec3 fieldOfViewMm{180, 180, 220};
  uint64_t seed = 1;
  double noiseSigmaHu = 15.0;  ///< Gaussian noise, deterministic per voxel
  /// Supersample tissue boundaries (subSampleOffsets at edges): CT = mean HU, label =
  /// majority. False: both from the voxel centre only.
  bool partialVolume = true;
  /// Width (voxels, 0..1) of the box that smooths the partial-volume point-spread function:
  /// the PSF per axis is the voxel's box convolved with a box this wide (a trapezoid; 1 = a
  /// tent). 0 averages over the voxel's box only, whose kinked edge profile the renderer's
  /// interpolation and gradients alias into "wood grain" rings along voxel layers; 0.9
  /// removes them while keeping thin cortex recoverable (see kCorticalThresholdHu). The
  /// smoother PSF lowers the peak HU of cortex thinner than a voxel (1.2 mm condyles on
  /// coarse grids): pass a smaller value where that matters more than smooth renders.
  double psfSmoothingVoxels = kDefaultPsfSmoothing;
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

/// Partial-volume sub-samples per voxel: one in each of 4 x 4 x 4 strata.
inline constexpr int kSubSamples = 64;

/// Index-space offsets from the centre of voxel (i, j, k) of the sub-samples whose mean
/// tissue HU is the voxel's CT value and whose majority structure is its label. They sample
/// the point-spread function (per axis: the voxel's box convolved with a box
/// `psfSmoothingVoxels` wide, clamped to [0, 1]; each coordinate within
/// (1 + psfSmoothingVoxels) / 2): sample a + 4b + 16c lies in quantile stratum (a, b, c) of
/// the PSF at a pseudo-random position (a deterministic hash of i, j, k; independent of the
/// seed, so the truth is too). Along each axis the 64 samples also lie in 64 distinct
/// quantile slices, so a voxel's tissue fraction follows a moving surface smoothly (at most
/// one sample off for axis-aligned surfaces) instead of in the steps of a regular grid.
std::array<Vec3, kSubSamples> subSampleOffsets(int64_t i, int64_t j, int64_t k,
                                               double psfSmoothingVoxels = kDefaultPsfSmoothing);

/// The four bones (rigid bodies) of the knee.
enum class Bone : uint8_t { kNone = 0, kFemur = 1, kTibia = 2, kFibula = 3, kPatella = 4 };

/// The anatomy at one physical point (mm, LPS), without partial volume or noise: the exact
/// point truth that makePhantom samples at voxel centres (and at the subSampleOffsets positions,
/// whose majority gives the voxel's label).
struct PhantomPoint {
  uint16_t label = kAir;
  double hu = -1000;       ///< nominal HU of the tissue there (from options.hu)
  Bone bone = Bone::kNone; ///< the bone the point lies in (resolves kCancellous)
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

/// True for the ids that are bone: 4 to 9 and 11 (cortex, marrow, cancellous core).
bool isBone(uint16_t id);
/// True for the cortical (dense, 1400 HU) bone ids 4, 6, 8, 9: what a cortical-bone
/// threshold should find (cancellous cores, 11, are ~450 HU: not cortical).
bool isCorticalBone(uint16_t id);

/// The bone an id belongs to: 4, 5 femur; 6, 7 tibia; 8 fibula; 9 patella; Bone::kNone for
/// non-bone ids AND for kCancellous, which is shared by the fibula's and the patella's cores
/// (a core lies inside its own shell: boneMap resolves it).
Bone boneOf(uint16_t id);

/// Per-voxel bone (Bone as uint8) of a phantom label volume, with the same geometry:
/// boneOf(id), and each 26-connected component of kCancellous voxels given the bone whose
/// cortical shell (8 or 9) it touches most (Bone::kNone if it touches neither). Use it for
/// per-bone rigid bodies; each bone of the phantom is one 26-connected component.
VolumeU8 boneMap(const LabelVolume& labels);

/// True for skin, fat, muscle, cartilage.
bool isSoftTissue(uint16_t id);

}  // namespace vellum::phantom
