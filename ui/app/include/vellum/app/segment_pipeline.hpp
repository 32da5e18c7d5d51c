#pragma once
// Segmentation as a request: the method (threshold, Otsu, multi-Otsu, hysteresis, region
// growing, confidence-connected growing, 3D snake), its settings, and the post-processing
// (morphology, holes, islands, largest component). `vellum segment` fills a request from its
// flags; the studio's snake tool fills one from a click. Both run runSegmentation, so a
// setting means the same in both, and the report (`info`) is the same JSON.
#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/params.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/core/volume.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/segmentation/mask.hpp"
#include "vellum/segmentation/snake.hpp"
#include "vellum/segmentation/split.hpp"

namespace vellum::app {

struct SegmentPostProcessing {
  double closeMm = 0, openMm = 0;  ///< morphological closing / opening (ball radius, mm); 0 = off
  bool fillHoles = false;          ///< 3D hole filling
  bool fillHolesSlices = false;    ///< 2D hole filling in every slice along x, y and z
  double minIslandMm3 = 0;         ///< drop components smaller than this; 0 = off
  bool keepLargest = false;        ///< keep the largest component (with seeds: those holding a seed)
  /// Last: split the mask into separate objects (bones), each written under its own id.
  bool split = false;
  segmentation::SplitParams splitParams;  ///< neck, minimum volume, seeds (`--split-seed`)
};

/// Every field but the seeds is described once in segmentSettingsTable() (`vellum segment`'s
/// flags, the studio's segmentation settings, docs/parameters.md).
struct SegmentSettings {
  /// threshold | otsu | multi-otsu | hysteresis | grow | confidence | snake
  std::string method = "threshold";
  std::string preset;                         ///< HU preset; empty = the method's default
  std::optional<double> lower, upper;         ///< HU, override the preset's bounds
  std::optional<double> strong;               ///< hysteresis: lower bound of the strong interval
  int classes = 3;                            ///< multi-otsu
  std::vector<Vec3> seedsMm;                  ///< grow, confidence, snake
  /// snake: start from this region (on the input's grid) instead of bubbles at the seeds: a
  /// snake continued on a larger box (the studio). Not a flag.
  std::shared_ptr<const segmentation::Mask> snakeStart;
  double bubbleRadiusMm = 5;                  ///< snake: seed bubble radius
  std::optional<int> iterations;              ///< confidence / snake; unset = the method's default
  std::string speed = "threshold";            ///< snake: threshold | edge
  double curvature = 0.2, propagation = 1.0;  ///< snake weights
  std::optional<double> advection;            ///< snake; unset: the speed's default (0 threshold, 2 edge)
  double sigma = 1.0, kappa = 120, exponent = 4;  ///< snake edge speed
  double multiplier = 2.5;                    ///< confidence
  SegmentPostProcessing post;
};

const params::Table<SegmentSettings>& segmentSettingsTable();

struct SegmentationResult {
  segmentation::Mask mask;             ///< empty for multi-otsu
  std::optional<VolumeU16> classes;    ///< multi-otsu: class per voxel (0 .. classes-1)
  std::optional<VolumeU16> objects;    ///< with post.split: object per voxel (0, 1 .. n, largest first)
  nlohmann::json info = nlohmann::json::object();  ///< what ran: intervals, iterations, post-processing
};

/// Runs `request` on `ct`. Throws vellum::Error for a bad request (unknown method, missing
/// seeds, upper < lower), vellum::Cancelled through `progress`. `observe` sees a snake evolve.
SegmentationResult runSegmentation(const VolumeI16& ct, const SegmentSettings& request,
                               Progress& progress = Progress::none(),
                               const segmentation::SnakeObserver& observe = {});

/// `vellum segment` as a request: load the CT, segment it, add the segment to a label map,
/// compare with a truth label map, write the map and the report.
struct SegmentRequest {
  std::filesystem::path input;   ///< CT volume file or DICOM folder
  std::filesystem::path output;  ///< the label map (.nrrd keeps the label table)
  std::filesystem::path into;    ///< add the segment into this label map; empty: a new map
  std::filesystem::path truth;   ///< truth label map for Dice, Jaccard, HD95; empty: none
  std::vector<uint16_t> truthIds;  ///< compare with the union of these truth ids (empty: same ids)
  std::filesystem::path report;    ///< report JSON; empty: not written (still returned)
  SegmentSettings settings;
  uint16_t labelId = 0;                         ///< 0: the lowest free id
  std::string labelName;                        ///< empty: the method's name
  std::optional<std::array<uint8_t, 3>> colour;  ///< empty: the id's default colour
  std::string overlap = "overwrite";            ///< overwrite | keep-existing | replace
  io::LoadOptions load;  ///< series, raw layout, region (the label maps get the same region)
  bool force = false;    ///< a DICOM output may replace a Vellum folder of another kind
  std::string commandLine;  ///< for the report (run_report.hpp); empty from the studio
};

struct SegmentResult {
  std::vector<uint16_t> written;      ///< the label ids written
  nlohmann::json report;              ///< what `report` holds: method, counts, timings, metrics
  std::vector<std::string> warnings;  ///< the load's warnings
};

/// Runs the request under the output policy (nothing is written when the truth comparison or
/// the report fails). Throws vellum::Error / FileError, vellum::Cancelled through `progress`.
SegmentResult runSegment(const SegmentRequest& request, Progress& progress = Progress::none());

}  // namespace vellum::app
