#pragma once
// Comparing two results (`vellum compare`, the checks of `vellum qa`): two label maps (overlap
// and surface distances per id, segmentation/metrics), two images (pixel differences, PSNR,
// SSIM, a heat map) or two grey volumes (geometry, value differences), each judged against one
// set of tolerances.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
#include "vellum/core/image.hpp"
#include "vellum/core/params.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/app/run_report.hpp"  // vellumVersion(): what reports and baselines record
#include "vellum/io/volume_io.hpp"

namespace vellum::app {

enum class CompareKind { Auto, Labels, Image, Volume };
/// "auto", "labels", "image", "volume"; parse errors name the flag, --kind.
const params::EnumTable<CompareKind>& compareKinds();
inline const char* compareKindName(CompareKind kind) { return compareKinds().name(kind); }
inline CompareKind parseCompareKind(const std::string& name) { return compareKinds().parse(name); }

/// What still counts as "the same". One table: the flags of `vellum compare` and the
/// "tolerances" object of a check in a QA manifest.
struct CompareTolerances {
  double minDice = 1.0;                 ///< labels: every id's Dice at least this
  std::optional<double> maxHd95Mm;      ///< labels: every id's HD95 at most this
  std::optional<double> maxAssdMm;      ///< labels: every id's mean surface distance at most this
  double tolerance = 0;                 ///< images: |difference| per channel (0..255); volumes: per voxel (HU for CT)
  double maxDifferingPercent = 0;       ///< images / volumes: share of pixels / voxels allowed beyond `tolerance`
  std::optional<double> minPsnrDb;      ///< images: PSNR at least this
  std::optional<double> minSsim;        ///< images: SSIM at least this
  double percentile = 99;               ///< images: the difference percentile reported
};
const params::Table<CompareTolerances>& compareTolerancesTable();

/// Pixel differences of two images of one size. A pixel's difference is the largest
/// |a - b| over its four channels (alpha included); PSNR and SSIM are over RGB luminance.
struct ImageDiff {
  double maxDifference = 0;        ///< 0..255
  double meanDifference = 0;       ///< mean over pixels
  double percentileDifference = 0; ///< tolerances.percentile (nearest rank)
  int64_t differingPixels = 0;     ///< difference > tolerances.tolerance
  double differingPercent = 0;
  double psnrDb = 0;               ///< +infinity when the RGB planes are identical
  double ssim = 1;                 ///< mean SSIM (Wang et al. 2004: 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03)
  RgbaImage heatmap;               ///< the differences in colour over the dimmed first image
};
/// Throws vellum::Error when the sizes differ.
ImageDiff diffImages(const RgbaImage& a, const RgbaImage& b, const CompareTolerances& tolerances);

/// Mean SSIM of two same-size images' luminance (0.299 R + 0.587 G + 0.114 B), reflected borders.
double meanSsim(const RgbaImage& a, const RgbaImage& b);

struct CompareRequest {
  std::filesystem::path a, b;      ///< a: the result; b: the baseline or reference
  CompareKind kind = CompareKind::Auto;
  CompareTolerances tolerances;
  std::vector<uint16_t> ids;       ///< labels: only these ids (default: every id in either map)
  /// labels: compare the union of these ids in A with the union of `bIds` in B (one row, id 0),
  /// e.g. a segment against the several truth ids it covers. `bIds` defaults to `aIds`.
  std::vector<uint16_t> aIds, bIds;
  io::LoadOptions load;
};

struct CompareResult {
  CompareKind kind = CompareKind::Auto;  ///< what was compared (never Auto)
  bool pass = false;
  std::vector<std::string> failures;     ///< one line per tolerance exceeded
  nlohmann::json report;                 ///< the whole comparison (docs/qa.md: schema)
  /// For reports: A, B and their differences as pictures (images: the images and the heat map;
  /// label maps and volumes: the axial slice with the most disagreement).
  RgbaImage pictureA, pictureB, heatmap;
};

/// Loads A and B (every format io reads; images through OpenCV), decides the kind (Auto: an
/// image by its extension, a label map when both hold unsigned integer voxels, else a grey
/// volume) and compares. Differences are results (pass = false); unreadable input throws.
CompareResult compareFiles(const CompareRequest& request);

/// Human-readable lines of a result (what `vellum compare` prints).
std::string compareSummary(const CompareResult& result);

}  // namespace vellum::app
