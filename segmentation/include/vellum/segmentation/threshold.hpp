#pragma once
// Intensity thresholds: HU intervals and presets, Otsu and multi-Otsu, hysteresis.
#include <string>
#include <vector>

#include "vellum/core/progress.hpp"
#include "vellum/core/enum_table.hpp"
#include "vellum/core/params.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::segmentation {

/// A closed HU interval [lower, upper].
struct HuInterval {
  double lower = -1024;
  double upper = 3071;
  bool contains(double v) const { return v >= lower && v <= upper; }
};

/// Named CT intervals (chosen on the phantom's nominal HU, see docs/segmentation.md):
///   Bone        [ 700, 3071]  cortical bone (~1400 HU): the lower bound is the midpoint
///                             between cortex and what surrounds it (marrow ~20, muscle ~50,
///                             cartilage ~110 HU), so a partial-volume voxel counts as bone
///                             when more than about half of it is cortex.
///   WholeBone   [ 550, 3071]  the same cortex with a lower bound, for whole bones by hole
///                             filling: thin cortex (condyles, fibula, patella) blurred with
///                             marrow stays a closed ring at ~1.4 mm voxels, so
///                             fillHolesPerSlice() recovers cortex + marrow. Over-segments
///                             the cortex itself by up to a voxel.
///   SoftTissue  [-500,  300]  skin, fat, muscle, cartilage, marrow: between air and bone. The
///                             upper bound stays well below cortex so thin cortex still stops
///                             a region or snake; use a seed to keep one body (marrow is
///                             inside the bones).
///   SkinAir     [-500, 3071]  the body against air: its boundary is the skin surface
///   Fat         [-190,  -30]  adipose tissue (the usual clinical window)
///   Lung        [-950, -500]  aerated lung parenchyma
enum class Preset { Bone, SoftTissue, SkinAir, Fat, Lung, WholeBone };

HuInterval presetInterval(Preset p);
/// "bone", "whole-bone", "soft-tissue" (or "soft"), "skin-air" (or "skin"), "fat", "lung"; throws
/// vellum::Error listing the valid names.
const params::EnumTable<Preset>& presets();
inline Preset parsePreset(const std::string& name) { return presets().parse(name); }
inline const char* presetName(Preset p) { return presets().name(p); }
std::vector<Preset> allPresets();  ///< in the order menus list them (whole-bone after bone)

/// Voxels with lower <= HU <= upper (parallel).
Mask threshold(const VolumeI16& ct, const HuInterval& interval);

/// A histogram over [minValue, minValue + bins * binWidth).
struct Histogram {
  double minValue = 0;
  double binWidth = 1;
  std::vector<uint64_t> counts;
  double binCenter(size_t b) const { return minValue + (static_cast<double>(b) + 0.5) * binWidth; }
  /// Lower edge of bin b: the threshold value that separates bins < b from bins >= b.
  double binEdge(size_t b) const { return minValue + static_cast<double>(b) * binWidth; }
};

struct HistogramParams {
  int bins = 256;           ///< number of bins over [lowerHu, upperHu]
  double lowerHu = -1024;   ///< values below are ignored (e.g. -900 to leave air out)
  double upperHu = 3071;    ///< values above are ignored
};

/// Histogram of `ct` (parallel).
Histogram histogram(const VolumeI16& ct, const HistogramParams& params = {});

/// Otsu's threshold: the bin edge maximising the between-class variance of the two classes
/// below / at-or-above it. Throws vellum::Error for an empty histogram.
double otsuThreshold(const Histogram& h);

/// Multi-Otsu: classes-1 increasing thresholds maximising the between-class variance over
/// `classes` classes (dynamic programming, exact over the bins: O(classes * bins²)).
/// classes in [2, 8]; throws vellum::Error otherwise or when the histogram has fewer
/// non-empty bins than classes.
std::vector<double> multiOtsuThresholds(const Histogram& h, int classes);

/// Voxel classes from increasing thresholds: class c (1-based) holds t[c-2] <= HU < t[c-1]
/// (class 1 below t[0], the last class at or above the last threshold). Ids 1..N.
VolumeU16 classify(const VolumeI16& ct, const std::vector<double>& thresholds);

/// Hysteresis thresholding: voxels inside `weak` that are connected (within `weak`) to a
/// voxel inside `strong`. `strong` should lie inside `weak`.
struct HysteresisParams {
  HuInterval strong{1000, 3071};
  HuInterval weak{400, 3071};
  Connectivity connectivity = Connectivity::Vertex26;
};
/// Parameter table of HysteresisParams (the two intervals; connectivity is 6/18/26 and
/// checked by connectivityFromInt). `vellum segment --method hysteresis` and docs use it.
const params::Table<HysteresisParams>& hysteresisParamsTable();
Mask hysteresis(const VolumeI16& ct, const HysteresisParams& params);

}  // namespace vellum::segmentation
