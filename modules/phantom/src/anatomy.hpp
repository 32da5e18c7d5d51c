#pragma once
// The knee's anatomy as signed distance functions (mm, LPS, negative inside).
// Right knee: +x = patient left = medial, +y = posterior, +z = superior. The joint line is
// z = 0; the knee flexes about the x axis through kAxis (the condyles' centre), so the
// femoral condyles (sagittal circles about that axis) keep a constant gap to the tibia.
//
// Structures come in groups that are evaluated together: the leg envelope (skin, fat,
// muscle), femur (+ its cartilage), tibia (+ cartilage), fibula, patella. The femur and
// patella live in the world frame, the tibia, fibula and calf in the flexed "calf frame".
// makePhantom re-evaluates only the groups with a boundary inside a voxel at sub-samples.
#include <cstdint>

#include "vellum/core/vec.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::phantom::detail {

/// Tissues (what gives HU); labels are finer (femur vs tibia cortex): each label has one tissue.
enum Tissue : uint8_t { tAir, tSkin, tFat, tMuscle, tCortex, tMarrow, tCancellous, tCartilage,
                        kTissueCount };

// ---- Anatomy constants (mm). Changing them changes the truth: keep tests in step. ----
inline constexpr double kAxisZ = 24.5;          ///< flexion axis height (condyle centres)
inline constexpr double kSkinMm = 2.0;          ///< skin thickness
inline constexpr double kKneeRadiusX = 60.0;    ///< leg half-width at the knee (x)
inline constexpr double kLegAspectY = 0.9;      ///< ry / rx of the leg's cross-section
// Femur
inline constexpr double kCondyleX = 19.0, kCondyleHalfWidth = 13.0, kCondyleRadius = 22.0;
inline constexpr double kFemurShaftR = 13.0, kFemurShaftY = 2.0, kFemurTopZ = 100.0;
inline constexpr double kFemurCortexShaft = 4.0, kFemurCortexCondyle = 1.2;
// Tibia (calf frame)
inline constexpr double kPlateauZ = -2.5, kTibiaHeadBottomZ = -32.0;  ///< at y = 0
inline constexpr double kTibialSlopeDeg = 6.0;  ///< plateau descends posteriorly (anatomical)
inline constexpr double kTibiaHeadRx = 36.0, kTibiaHeadRy = 25.0, kTibiaHeadY = 1.0;
inline constexpr double kTibiaShaftR = 12.0, kTibiaShaftX = 3.0, kTibiaShaftY = -6.0;
inline constexpr double kTibiaBottomZ = -99.0;
inline constexpr double kTibiaCortexShaft = 4.0, kTibiaCortexHead = 1.5;
// Fibula (calf frame), lateral (-x) and posterior (+y)
inline constexpr double kFibulaX = -33.0, kFibulaY = 20.0, kFibulaR = 5.5, kFibulaCortex = 1.5;
inline constexpr double kFibulaHeadZ = -50.0, kFibulaHeadR = 7.5, kFibulaBottomZ = -95.5;
// Patella (world frame), anterior (-y)
inline constexpr double kPatellaY = -35.0, kPatellaZ = 34.0;
inline constexpr double kPatellaA = 20.0, kPatellaB = 8.5, kPatellaC = 20.0, kPatellaCortex = 1.5;
inline constexpr double kCartilageMm = 2.0;

/// Signed distances of every structure at one point. Bones: outer surface and inner
/// (marrow / cancellous core) surface; cartilage is a capped shell outside the bone.
struct Distances {
  double legOuter = 1e9, legFat = 1e9, legMuscle = 1e9;
  double femurOuter = 1e9, femurInner = 1e9, femurCartilage = 1e9;
  double tibiaOuter = 1e9, tibiaInner = 1e9, tibiaCartilage = 1e9;
  double fibulaOuter = 1e9, fibulaInner = 1e9;
  double patellaOuter = 1e9, patellaInner = 1e9;
};

/// Group bits for "this group has a boundary near the point".
enum Group : uint32_t { gLeg = 1, gFemur = 2, gTibia = 4, gFibula = 8, gPatella = 16, gAll = 31 };

struct Classified {
  uint16_t label;
  Tissue tissue;
};

inline constexpr int kLabelCount = kCancellous + 1;

/// Tie-break rank of each label for the majority vote (higher wins): cortex > marrow/core >
/// cartilage > muscle > fat > skin > air, the order in which classify tests the structures.
/// Femur, tibia, fibula and patella never share a voxel, so their mutual order is moot.
inline constexpr uint8_t kTieRank[kLabelCount] = {
    /*air*/ 0, /*skin*/ 1, /*fat*/ 2, /*muscle*/ 3, /*femur cortex*/ 11, /*femur marrow*/ 7,
    /*tibia cortex*/ 10, /*tibia marrow*/ 6, /*fibula*/ 9, /*patella*/ 8, /*cartilage*/ 4,
    /*cancellous*/ 5};

/// The majority label of sub-sample counts (per label id), ties broken by kTieRank.
template <typename Count>
uint16_t majorityLabel(const Count* counts) {
  int best = 0;
  for (int l = 1; l < kLabelCount; ++l)
    if (counts[l] > counts[best] || (counts[l] == counts[best] && kTieRank[l] > kTieRank[best]))
      best = l;
  return static_cast<uint16_t>(best);
}

class Anatomy {
 public:
  explicit Anatomy(double flexionDeg);

  /// Evaluates the groups in `groups` at world point p into d (others untouched).
  void evaluate(const Vec3& p, uint32_t groups, Distances& d) const;

  /// Evaluates every group at p, skipping bones whose bounding box is farther than
  /// `nearMm` (their distances stay +1e9, which classifies the same). Returns the groups
  /// with some |distance| < nearMm: those whose boundary may cross a voxel around p.
  uint32_t evaluateNear(const Vec3& p, double nearMm, Distances& d) const;

  /// Label and tissue from the signs (priority bones > cartilage > muscle > fat > skin > air).
  static Classified classify(const Distances& d);

  /// Signed distance (mm) to the plane splitting the thigh from the calf envelope (thigh side
  /// positive); +infinity for a straight leg, where there is no seam.
  double seamDistance(const Vec3& p) const { return flexed_ ? bisector(p) : 1e300; }

  /// World -> calf frame (inverse flexion about the axis).
  Vec3 toCalf(const Vec3& p) const {
    const double dy = p.y, dz = p.z - kAxisZ;
    return {p.x, c_ * dy + s_ * dz, -s_ * dy + c_ * dz + kAxisZ};
  }
  /// Calf frame -> world.
  Vec3 fromCalf(const Vec3& q) const {
    const double dy = q.y, dz = q.z - kAxisZ;
    return {q.x, c_ * dy - s_ * dz, s_ * dy + c_ * dz + kAxisZ};
  }

 private:
  void leg(const Vec3& p, Distances& d) const;
  static void femur(const Vec3& p, Distances& d);
  static void tibia(const Vec3& q, Distances& d);
  static void fibula(const Vec3& q, Distances& d);
  static void patella(const Vec3& p, Distances& d);
  double bisector(const Vec3& p) const { return nby_ * p.y + nbz_ * (p.z - kAxisZ); }

  double c_ = 1, s_ = 0;             // cos / sin of the flexion angle
  double nby_ = 0, nbz_ = 1;         // normal of the thigh/calf bisector plane (thigh side +)
  bool flexed_ = false;
};

}  // namespace vellum::phantom::detail
