#pragma once
// Density-aware MLS weights ([HVD 1.3] in docs/references.md): w_i = rho(u, x_i) / |v - y_i|^n with
//   rho(a, b) = (1 / phi(a, b)) * integral_a^b I(t) dt   (mm, straight segment, SOURCE volume)
// I is the normalised density: the window [windowLowHu, windowHighHu] mapped to [0,1] and
// raised to at least phiMin (so empty space behaves like a homogeneous medium of density
// phiMin, and rho equals the segment length in any homogeneous region).
#include <memory>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::deformation {

enum class PhiRule {
  Min,   ///< min of I along the segment (paper, default)
  Mean,  ///< mean of I over the whole volume (the segment mean would cancel rho to its length)
  None,  ///< phi = 1: rho is the plain accumulated density
};
enum class RayMode {
  Linear,  ///< fixed step (linearStepVoxels) on the full-resolution density
  Conic,   ///< step grows with distance from the evaluated point; reads the matching mip level
};
enum class MipReduction { Mean, Max };

const params::EnumTable<PhiRule>& phiRules();            ///< "min", "mean", "none"
const params::EnumTable<RayMode>& rayModes();            ///< "linear", "conic"
const params::EnumTable<MipReduction>& mipReductions();  ///< "mean", "max"
inline const char* phiRuleName(PhiRule r) { return phiRules().name(r); }
inline PhiRule parsePhiRule(const std::string& name) { return phiRules().parse(name); }
inline const char* rayModeName(RayMode r) { return rayModes().name(r); }
inline RayMode parseRayMode(const std::string& name) { return rayModes().parse(name); }
inline MipReduction parseMipReduction(const std::string& name) { return mipReductions().parse(name); }

struct DensityParams {
  bool enabled = false;
  PhiRule phi = PhiRule::Min;
  double phiMin = 0.05;          ///< floor of I and of phi (range: densityParamsTable())
  double windowLowHu = -1000;    ///< I = 0 here ...
  double windowHighHu = 2000;    ///< ... and 1 here
  int iterations = 3;            ///< fixed-point iterations K (paper: 2..3)
  double toleranceMm = 0;        ///< > 0: stop early once no node moved more than this
  RayMode rays = RayMode::Conic;  ///< conic: ~log(length) samples per ray instead of ~length
  double linearStepVoxels = 1.0; ///< linear rays: step in voxels of the smallest spacing
  double coneSlope = 0.15;       ///< conic rays: step and footprint = slope * distance (voxels)
  MipReduction reduction = MipReduction::Mean;
  bool rhoCache = true;          ///< false: cast rays to u_k for every node and iteration
  /// Divide rho by the segment length (mm): the weight keeps the power n and only the
  /// density contrast along the segment (>= 1 with phi = min) modulates it. false = the
  /// paper's rho, which in homogeneous tissue grows like the distance (effective power n - 1,
  /// so the map spreads more): on the knee phantom that bent bone MORE than plain MLS, see
  /// docs/deformation.md; hence the default true.
  bool lengthNormalisedRho = true;
};

/// The normalised density I of a source volume and its 3D mip pyramid (level 0 = full
/// resolution, each level halves every axis). Immutable once built; shared by threads.
class DensityVolume {
 public:
  DensityVolume(const AnyVolume& source, const DensityParams& params);

  const Geometry& geometry() const { return levels_[0].geometry(); }
  int levelCount() const { return static_cast<int>(levels_.size()); }
  const VolumeF32& level(int l) const { return levels_[static_cast<size_t>(l)]; }
  double globalMean() const { return globalMean_; }

  /// rho(a, b) in mm for a, b in SOURCE index coordinates (full resolution).
  double rho(const Vec3& aIdx, const Vec3& bIdx) const;

 private:
  DensityParams params_;
  std::vector<VolumeF32> levels_;
  double globalMean_ = 1;
  Mat3 indexToMm_;  ///< direction * diag(spacing): index-space vector -> mm vector
  struct ConeStep {
    double s, h, mid;  ///< start, length and midpoint of the step (mm from the apex)
    int level;         ///< mip level read at the midpoint
  };
  std::vector<ConeStep> coneSteps_;
};

}  // namespace vellum::deformation
