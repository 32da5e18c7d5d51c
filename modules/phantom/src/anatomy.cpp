#include "anatomy.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sdf.hpp"

namespace vellum::phantom::detail {
namespace {

struct Box {
  double x0, x1, y0, y1, z0, z1;
  /// True when p is more than `margin` outside the box on some axis.
  bool farFrom(const Vec3& p, double margin) const {
    return p.x < x0 - margin || p.x > x1 + margin || p.y < y0 - margin || p.y > y1 + margin ||
           p.z < z0 - margin || p.z > z1 + margin;
  }
};

// Conservative bounds of each bone group including its cartilage and fillet bulges
// (checked by the tests against the distance functions themselves).
constexpr Box kFemurBox{-40, 40, -30, 30, -2, 104};          // world frame
constexpr Box kTibiaBox{-42, 42, -31, 32, -103, 6};          // calf frame (sloped rim)
constexpr Box kFibulaBox{-43, -23, 10, 30, -98, -40};        // calf frame
constexpr Box kPatellaBox{-23, 23, -46, -24, 11, 57};        // world frame

bool nearAny(double a, double b, double c, double nearMm) {
  return std::abs(a) < nearMm || std::abs(b) < nearMm || std::abs(c) < nearMm;
}

}  // namespace

Anatomy::Anatomy(double flexionDeg) {
  const double a = flexionDeg * std::numbers::pi / 180.0;
  c_ = std::cos(a);
  s_ = std::sin(a);
  flexed_ = flexionDeg != 0.0;
  // Thigh axis (0,0,1), calf axis (0, sin a, -cos a): the bisector's normal is their difference.
  const double ny = -s_, nz = 1.0 + c_;
  const double n = std::sqrt(ny * ny + nz * nz);
  nby_ = ny / n;
  nbz_ = nz / n;
}

void Anatomy::leg(const Vec3& p, Distances& d) const {
  // Thigh half (world frame) or calf half (calf frame), split at the bisector plane of the two
  // limb axes: across it the two cross-sections mirror each other, so the surface is
  // continuous (a crease behind a flexed knee, a rounded front).
  const bool thigh = !flexed_ || bisector(p) >= 0.0;
  const Vec3 q = thigh ? p : toCalf(p);
  const double u = q.z - kAxisZ;
  // Narrowest at the knee; the thigh widens faster above than the calf below.
  const double taper = (u >= 0 ? 0.07 : 0.03) * u * u / (std::abs(u) + 30.0);
  const double rx = kKneeRadiusX + taper, ry = kLegAspectY * rx;
  const double e = sdf::ellipse(q.x, q.y, rx, ry);
  // Subcutaneous fat: 6 mm anteriorly to 12 mm posteriorly.
  const double rho = std::sqrt(q.x * q.x + q.y * q.y);
  const double ny = rho > 1e-9 ? q.y / rho : 0.0;
  const double fat = 9.0 + 3.0 * ny;
  d.legOuter = e;
  d.legFat = e + kSkinMm;
  d.legMuscle = e + kSkinMm + fat;
}

void Anatomy::femur(const Vec3& p, Distances& d) {
  // Two condyles whose sagittal sections are circles about the flexion axis, blended into a
  // flaring metaphysis and the shaft.
  const double medial = sdf::ellipsoid(p.x - kCondyleX, p.y, p.z - kAxisZ, kCondyleHalfWidth,
                                       kCondyleRadius, kCondyleRadius);
  const double lateral = sdf::ellipsoid(p.x + kCondyleX, p.y, p.z - kAxisZ, kCondyleHalfWidth,
                                        kCondyleRadius, kCondyleRadius);
  const double condyles = sdf::smoothMin(medial, lateral, 6.0);
  const double meta = sdf::ellipsoid(p.x, p.y - 2.0, p.z - 40.0, 28.0, 19.0, 26.0);
  const double shaft = sdf::capsuleZ(p.x, p.y, p.z, 0.0, kFemurShaftY, 40.0,
                                     kFemurTopZ - kFemurShaftR, kFemurShaftR);
  const double outer = sdf::smoothMin(sdf::smoothMin(condyles, meta, 10.0), shaft, 12.0);
  // Cortex: thick in the shaft, thin (subchondral) at the condyles.
  const double t = kFemurCortexCondyle + (kFemurCortexShaft - kFemurCortexCondyle) *
                                             sdf::smoothstep(35.0, 65.0, p.z);
  d.femurOuter = outer;
  d.femurInner = outer + t;
  // Articular cartilage on the distal (weight-bearing) half of the condyles.
  d.femurCartilage = std::max(outer - kCartilageMm, p.z - 22.0);
}

void Anatomy::tibia(const Vec3& q, Distances& d) {
  // The head in a frame tilted about the x axis through the plateau centre: the posterior
  // slope keeps the plateau (and its thin cortex) off any one grid plane.
  static const double ca = std::cos(kTibialSlopeDeg * std::numbers::pi / 180.0);
  static const double sa = std::sin(kTibialSlopeDeg * std::numbers::pi / 180.0);
  const double ty = q.y * ca - (q.z - kPlateauZ) * sa;
  const double tz = kPlateauZ + (q.z - kPlateauZ) * ca + q.y * sa;
  const double zc = 0.5 * (kPlateauZ + kTibiaHeadBottomZ);
  const double h = 0.5 * (kPlateauZ - kTibiaHeadBottomZ);
  const double radial = sdf::ellipse(q.x, ty - kTibiaHeadY, kTibiaHeadRx, kTibiaHeadRy);
  const double head = sdf::roundedCap(radial, std::abs(tz - zc) - h, 3.0);
  const double shaft = sdf::capsuleZ(q.x, q.y, q.z, kTibiaShaftX, kTibiaShaftY,
                                     kTibiaBottomZ + kTibiaShaftR, -40.0, kTibiaShaftR);
  const double outer = sdf::smoothMin(head, shaft, 14.0);
  const double t = kTibiaCortexHead + (kTibiaCortexShaft - kTibiaCortexHead) *
                                          sdf::smoothstep(-25.0, -55.0, q.z);
  d.tibiaOuter = outer;
  d.tibiaInner = outer + t;
  d.tibiaCartilage = std::max(outer - kCartilageMm, -(tz + 6.0));  // on the plateau only
}

void Anatomy::fibula(const Vec3& q, Distances& d) {
  const double shaft = sdf::capsuleZ(q.x, q.y, q.z, kFibulaX, kFibulaY, kFibulaBottomZ + kFibulaR,
                                     kFibulaHeadZ, kFibulaR);
  const double dx = q.x - kFibulaX, dy = q.y - kFibulaY, dz = q.z - kFibulaHeadZ;
  const double head = std::sqrt(dx * dx + dy * dy + dz * dz) - kFibulaHeadR;
  const double outer = sdf::smoothMin(shaft, head, 4.0);
  d.fibulaOuter = outer;
  d.fibulaInner = outer + kFibulaCortex;
}

void Anatomy::patella(const Vec3& p, Distances& d) {
  const double outer =
      sdf::ellipsoid(p.x, p.y - kPatellaY, p.z - kPatellaZ, kPatellaA, kPatellaB, kPatellaC);
  d.patellaOuter = outer;
  d.patellaInner = outer + kPatellaCortex;
}

void Anatomy::evaluate(const Vec3& p, uint32_t groups, Distances& d) const {
  if (groups & gLeg) leg(p, d);
  if (groups & gFemur) femur(p, d);
  if (groups & gPatella) patella(p, d);
  if (groups & (gTibia | gFibula)) {
    const Vec3 q = toCalf(p);
    if (groups & gTibia) tibia(q, d);
    if (groups & gFibula) fibula(q, d);
  }
}

uint32_t Anatomy::evaluateNear(const Vec3& p, double nearMm, Distances& d) const {
  uint32_t near = 0;
  leg(p, d);
  if (nearAny(d.legOuter, d.legFat, d.legMuscle, nearMm)) near |= gLeg;
  if (!kFemurBox.farFrom(p, nearMm)) {
    femur(p, d);
    if (nearAny(d.femurOuter, d.femurInner, d.femurCartilage, nearMm)) near |= gFemur;
  }
  if (!kPatellaBox.farFrom(p, nearMm)) {
    patella(p, d);
    if (nearAny(d.patellaOuter, d.patellaInner, 1e9, nearMm)) near |= gPatella;
  }
  const Vec3 q = toCalf(p);
  if (!kTibiaBox.farFrom(q, nearMm)) {
    tibia(q, d);
    if (nearAny(d.tibiaOuter, d.tibiaInner, d.tibiaCartilage, nearMm)) near |= gTibia;
  }
  if (!kFibulaBox.farFrom(q, nearMm)) {
    fibula(q, d);
    if (nearAny(d.fibulaOuter, d.fibulaInner, 1e9, nearMm)) near |= gFibula;
  }
  return near;
}

Classified Anatomy::classify(const Distances& d) {
  if (d.femurOuter < 0) return d.femurInner < 0 ? Classified{kFemurMarrow, tMarrow}
                                                : Classified{kFemurCortex, tCortex};
  if (d.tibiaOuter < 0) return d.tibiaInner < 0 ? Classified{kTibiaMarrow, tMarrow}
                                                : Classified{kTibiaCortex, tCortex};
  if (d.fibulaOuter < 0) return d.fibulaInner < 0 ? Classified{kCancellous, tCancellous}
                                                  : Classified{kFibula, tCortex};
  if (d.patellaOuter < 0) return d.patellaInner < 0 ? Classified{kCancellous, tCancellous}
                                                    : Classified{kPatella, tCortex};
  if (d.femurCartilage < 0 || d.tibiaCartilage < 0) return {kCartilage, tCartilage};
  if (d.legOuter < 0) {
    if (d.legMuscle < 0) return {kMuscle, tMuscle};
    if (d.legFat < 0) return {kFat, tFat};
    return {kSkin, tSkin};
  }
  return {kAir, tAir};
}

}  // namespace vellum::phantom::detail
