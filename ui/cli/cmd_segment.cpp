// `vellum segment IN --out LABELS.nrrd`: thresholds, Otsu, hysteresis, region growing,
// confidence-connected growing and 3D snakes, with morphology/island post-processing, adding
// into an existing label map, and quality metrics against a truth label map.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/segmentation/label_map.hpp"
#include "vellum/segmentation/metrics.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/region_growing.hpp"
#include "vellum/segmentation/snake.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::cli {
namespace seg = vellum::segmentation;
namespace {

struct SegmentArgs {
  std::string input, out, into, labelName, color, truth, report, overlap = "overwrite";
  std::vector<std::string> seeds;  ///< "x,y,z" (mm), parsed into request.seedsMm
  app::SegmentRequest request;      ///< method, settings and post-processing: the flags write here
  int labelId = 0;
  std::vector<uint16_t> truthIds;
  bool force = false;
  InputOptions in;
};

std::vector<double> parseNumbers(const std::string& text, size_t n, const char* what) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw Error(std::string(what) + ": '" + text + "' is not " + std::to_string(n) + " comma-separated numbers");
    }
  }
  if (v.size() != n) throw Error(std::string(what) + ": '" + text + "' needs " + std::to_string(n) + " numbers");
  return v;
}

nlohmann::json metricsJson(const seg::SegmentMetrics& m) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"id", m.id}, {"dice", m.dice}, {"jaccard", m.jaccard}, {"voxels", m.voxels},
          {"truth_voxels", m.truthVoxels}, {"volume_mm3", m.volumeMm3}, {"truth_volume_mm3", m.truthVolumeMm3},
          {"volume_difference_mm3", m.volumeDifferenceMm3}, {"volume_difference_percent", m.volumeDifferencePercent},
          {"hd95_mm", num(m.hd95Mm)}, {"hausdorff_mm", num(m.hausdorffMm)},
          {"mean_surface_distance_mm", num(m.meanSurfaceDistanceMm)}};
}

/// Adds the segmentation to `labels` as label `id` (or, for k-means classes, ids id..id+k-1);
/// returns the ids written and reports the single segment's counts.
std::vector<uint16_t> addToLabels(const SegmentArgs& a, const app::SegmentRequest& request,
                                  const app::SegmentOutcome& outcome, uint16_t id, LabelVolume& labels,
                                  nlohmann::json& report) {
  const seg::OverlapRule rule = seg::parseOverlapRule(a.overlap);
  std::array<uint8_t, 3> rgb = defaultLabelColor(id);
  if (!a.color.empty()) {
    const auto c = parseNumbers(a.color, 3, "--color");
    for (int i = 0; i < 3; ++i) {
      if (c[i] < 0 || c[i] > 255) throw Error("--color: components must be in 0..255");
      rgb[i] = static_cast<uint8_t>(c[i]);
    }
  }
  std::vector<uint16_t> written;
  if (outcome.classes) {
    for (int c = 1; c <= request.classes; ++c) {
      const uint16_t cid = static_cast<uint16_t>(id + c - 1);
      const seg::Mask m = seg::maskFromIds(*outcome.classes, [c](uint16_t v) { return v == c; });
      seg::addSegment(labels, m, {cid, (a.labelName.empty() ? "class " : a.labelName + " ") + std::to_string(c), defaultLabelColor(cid)}, rule);
      written.push_back(cid);
    }
  } else {
    const seg::AddResult r = seg::addSegment(labels, outcome.mask, {id, a.labelName.empty() ? request.method : a.labelName, rgb}, rule);
    report["segment"] = {{"id", id}, {"voxels", r.written}, {"skipped_by_overlap_rule", r.skipped},
                         {"cleared", r.cleared}, {"volume_mm3", seg::maskVolumeMm3(outcome.mask)}};
    written.push_back(id);
  }
  return written;
}

/// --truth: Dice, Jaccard, HD95 and volume difference of the written labels (or of the segment
/// against the union of --truth-ids), printed and returned for the report.
nlohmann::json truthMetrics(const SegmentArgs& a, const LabelVolume& labels, const seg::Mask& mask, bool classes,
                            uint16_t id, const std::vector<uint16_t>& written) {
  const LabelVolume truth = a.in.loadLabelsOnInputGrid(a.truth);
  nlohmann::json metrics = nlohmann::json::array();
  if (!a.truthIds.empty() && !classes) {
    // The new segment against the union of the given truth ids.
    const auto& ids = a.truthIds;
    const seg::Mask t = seg::maskFromIds(truth.ids(), [&](uint16_t v) {
      return std::find(ids.begin(), ids.end(), v) != ids.end();
    });
    seg::SegmentMetrics m = seg::compareMasks(mask, t);
    m.id = id;
    metrics.push_back(metricsJson(m));
    std::printf("segment %u vs truth ids:", id);
    for (uint16_t v : ids) std::printf(" %u", v);
    std::printf("  Dice %.4f  Jaccard %.4f  HD95 %.2f mm  volume %+.2f%%\n", m.dice, m.jaccard, m.hd95Mm, m.volumeDifferencePercent);
  } else {
    for (const auto& m : seg::compareLabels(labels.ids(), truth.ids(), written)) {
      metrics.push_back(metricsJson(m));
      std::printf("label %u  Dice %.4f  Jaccard %.4f  HD95 %.2f mm  volume %+.2f%%\n", m.id, m.dice, m.jaccard, m.hd95Mm, m.volumeDifferencePercent);
    }
  }
  return metrics;
}

void runSegment(const SegmentArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  OutputPlan()
      .input(a.input)
      .input(a.into, "the --into label map")
      .input(a.truth, "the --truth label map")
      .output(a.out, "--out")
      .json(a.report, "--report")
      .force(a.force)
      .check();
  const io::LoadedVolume lv = loadWithProgress(a.input, a.in);
  const VolumeI16 ct = toInt16(lv.volume);
  app::SegmentRequest request = a.request;
  for (const auto& s : a.seeds) {
    const auto v = parseNumbers(s, 3, "--seed");
    request.seedsMm.push_back({v[0], v[1], v[2]});
  }
  nlohmann::json report;
  report["input"] = a.input;
  report["method"] = request.method;
  report["dims"] = {ct.dims().x, ct.dims().y, ct.dims().z};
  report["spacing_mm"] = toJson(ct.geometry().spacing);
  report["load_seconds"] = secondsSince(t0);

  const auto t1 = std::chrono::steady_clock::now();
  app::SegmentOutcome outcome;
  {
    ProgressBar bar;
    outcome = app::runSegmentation(ct, request, bar.progress());
    bar.finish();
  }
  report.update(outcome.info);
  const seg::Mask& mask = outcome.mask;
  const std::optional<VolumeU16>& classes = outcome.classes;
  report["segment_seconds"] = secondsSince(t1);

  LabelVolume labels = a.into.empty() ? LabelVolume(ct.geometry()) : a.in.loadLabelsOnInputGrid(a.into);
  const uint16_t id = a.labelId > 0 ? static_cast<uint16_t>(a.labelId) : labels.nextFreeId();
  const std::vector<uint16_t> written = addToLabels(a, request, outcome, id, labels, report);
  // The truth comparison runs before anything is written: a truth map that cannot be read
  // leaves no output behind.
  if (!a.truth.empty()) {
    report["truth"] = a.truth;
    report["metrics"] = truthMetrics(a, labels, mask, classes.has_value(), id, written);
  }
  RunOutputs outputs;
  ensureParentFolder(a.out);
  io::SaveOptions so;
  so.force = a.force;
  io::saveLabels(labels, a.out, so);
  outputs.wrote(a.out);
  report["seconds"] = secondsSince(t0);
  if (!a.report.empty()) writeJsonFile(report, a.report);
  outputs.commit();
  std::cout << a.out << ": segment";
  for (uint16_t w : written) std::cout << " " << w;
  std::cout << " (" << request.method << ")";
  if (!classes) std::cout << ", " << seg::countVoxels(mask) << " voxels, " << seg::maskVolumeMm3(mask) / 1000.0 << " cm³";
  std::cout << "\n";
}

}  // namespace

void addSegmentCommand(CLI::App& app) {
  auto a = std::make_shared<SegmentArgs>();
  auto* cmd = app.add_subcommand("segment", "Segment a CT volume into a label map (thresholds, Otsu, region growing, 3D snakes)");
  cmd->add_option("input", a->input, "input volume (file or DICOM folder)")->required();
  cmd->add_option("--out,-o", a->out, "output label map (.nrrd keeps the label table)")->required();
  // Method, its settings and post-processing: flags generated from the request's table.
  addFlags(*cmd, a->request, app::segmentRequestTable());
  cmd->add_option("--seed", a->seeds, "seed point x,y,z in mm (repeatable; snake: bubble centres)");
  cmd->add_option("--into", a->into, "add the segment into this existing label map (written to --out)");
  cmd->add_option("--label-id", a->labelId, "segment id (default: the lowest free id)");
  cmd->add_option("--label-name", a->labelName, "segment name (default: the method)");
  cmd->add_option("--color", a->color, "segment colour R,G,B (0..255)");
  cmd->add_option("--overlap", a->overlap, "where segments overlap: overwrite | keep-existing | replace")->capture_default_str();
  cmd->add_option("--truth", a->truth, "truth label map: report Dice, Jaccard, volume difference, HD95");
  cmd->add_option("--truth-ids", a->truthIds, "compare against the union of these truth ids (default: the same id)")->delimiter(',');
  cmd->add_option("--report", a->report, "write parameters, timings, iterations and metrics as JSON");
  a->in.addTo(*cmd);
  addForceFlag(*cmd, a->force);
  cmd->footer(
      "Examples:\n"
      "  vellum segment knee.nrrd --out bone.nrrd --preset whole-bone --fill-holes-slices --min-island 100\n"
      "  vellum segment knee.nrrd --out soft.nrrd --method snake --seed 0,35,60 --radius 10 \\\n"
      "      --truth knee-labels.nrrd --truth-ids 1,2,3,10 --report soft.json");
  cmd->callback([a] { runSegment(*a); });
}

namespace {

/// One slice through `centreMm`, resampled to square pixels in mm (physical aspect, whatever
/// the spacing): grey CT (window -200..400 HU, trilinear), segments tinted at 35% with a
/// full-colour outline so their borders can be checked. `right`/`down` are the physical
/// directions of the image's +x and +y (unit vectors along patient axes).
RgbaImage slicePanel(const VolumeI16& ct, const LabelVolume& labels, const Vec3& centreMm, const Vec3& right,
                     const Vec3& down, double mmPerPx) {
  const Geometry& g = ct.geometry();
  // Physical extent of the grid along the two axes (identity-like directions: the phantom's).
  const Vec3 lo = g.indexToPhysical({0, 0, 0}), hi = g.indexToPhysical({double(g.dims.x - 1), double(g.dims.y - 1), double(g.dims.z - 1)});
  const double r0 = std::min(dot(lo, right), dot(hi, right)), r1 = std::max(dot(lo, right), dot(hi, right));
  const double d0 = std::min(dot(lo, down), dot(hi, down)), d1 = std::max(dot(lo, down), dot(hi, down));
  const int w = std::max(1, static_cast<int>(std::lround((r1 - r0) / mmPerPx)));
  const int heightPx = std::max(1, static_cast<int>(std::lround((d1 - d0) / mmPerPx)));
  // The image's top-left corner: the grid's smallest extent along right and down, in the
  // plane through the centre.
  const Vec3 base = centreMm + right * (r0 - dot(centreMm, right)) + down * (d0 - dot(centreMm, down));
  std::vector<uint16_t> ids(static_cast<size_t>(w) * heightPx);
  RgbaImage img(w, heightPx);
  for (int y = 0; y < heightPx; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec3 p = base + right * ((x + 0.5) * mmPerPx) + down * ((y + 0.5) * mmPerPx);
      const Vec3 ijk = g.physicalToIndex(p);
      ids[static_cast<size_t>(y) * w + x] = static_cast<uint16_t>(labels.ids().sampleNearest(ijk));
      const double v = std::clamp((ct.sampleLinear(ijk) + 200.0) / 600.0, 0.0, 1.0) * 255.0;
      uint8_t* px = img.at(x, y);
      px[0] = px[1] = px[2] = static_cast<uint8_t>(v);
      px[3] = 255;
    }
  for (int y = 0; y < heightPx; ++y)
    for (int x = 0; x < w; ++x) {
      const uint16_t id = ids[static_cast<size_t>(y) * w + x];
      if (!id) continue;
      bool edge = false;
      for (const auto& [dx, dy] : {std::pair{-1, 0}, std::pair{1, 0}, std::pair{0, -1}, std::pair{0, 1}}) {
        const int xx = x + dx, yy = y + dy;
        edge = edge || xx < 0 || yy < 0 || xx >= w || yy >= heightPx || ids[static_cast<size_t>(yy) * w + xx] != id;
      }
      const auto c = labels.label(id) ? labels.label(id)->rgb : defaultLabelColor(id);
      uint8_t* px = img.at(x, y);
      const double a = edge ? 1.0 : 0.35;
      for (int t = 0; t < 3; ++t) px[t] = static_cast<uint8_t>((1 - a) * px[t] + a * c[t]);
    }
  return img;
}

/// Panels side by side on black, with a gap.
RgbaImage sideBySide(const std::vector<RgbaImage>& panels, int gap) {
  int w = gap * static_cast<int>(panels.size() - 1), h = 0;
  for (const auto& p : panels) { w += p.width; h = std::max(h, p.height); }
  RgbaImage out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out.at(x, y)[3] = 255;
  int x0 = 0;
  for (const auto& p : panels) {
    for (int y = 0; y < p.height; ++y)
      for (int x = 0; x < p.width; ++x) std::copy(p.at(x, y), p.at(x, y) + 4, out.at(x0 + x, y));
    x0 += p.width + gap;
  }
  return out;
}

}  // namespace

void demoSegmentation(const DemoContext& ctx) {
  const auto t0 = std::chrono::steady_clock::now();
  const VolumeI16 ct = toInt16(io::loadVolume(ctx.phantomCt).volume);
  const LabelVolume truth = io::loadLabels(ctx.phantomLabels);
  LabelVolume labels(ct.geometry());
  // Whole bones: the whole-bone preset keeps thin cortex closed, fill the marrow slice by
  // slice (all three orientations, so coarse grids still close), drop specks.
  seg::Mask bone = seg::threshold(ct, seg::presetInterval(seg::Preset::WholeBone));
  bone = seg::removeSmallIslands(seg::fillHolesAllSlices(bone), 100.0);
  seg::addSegment(labels, bone, {1, "bone", {235, 190, 40}});
  // Soft tissue: a snake from a bubble in the posterior thigh muscle.
  const Vec3 seed{0, 35, 60};
  ProgressBar bar;
  const seg::SpeedImage speed = seg::thresholdSpeed(ct, {}, bar.progress());
  const seg::SnakeResult snake = seg::evolveSnake(speed, {{seed, 10.0}}, {}, bar.progress());
  bar.finish();
  seg::addSegment(labels, snake.mask, {2, "soft tissue", {200, 70, 60}}, seg::OverlapRule::KeepExisting);
  io::saveLabels(labels, ctx.outDir / "segmentation.nrrd");

  const auto boneM = seg::compareMasks(bone, seg::maskFromIds(truth.ids(), phantom::isBone));
  const auto softM = seg::compareMasks(snake.mask, seg::maskFromIds(truth.ids(), phantom::isSoftTissue));
  // Figure: axial through the seed (anterior up, patient's right on the left), coronal and
  // sagittal through the knee (0,0,0) (head up; sagittal anterior on the left), at the
  // physical aspect ratio and one scale for all panels (the longest extent 480 px).
  const Vec3 knee{0, 0, 0};
  const Geometry& g = ct.geometry();
  const double mmPerPx = std::max({g.spacing.x * double(g.dims.x - 1), g.spacing.y * double(g.dims.y - 1),
                                   g.spacing.z * double(g.dims.z - 1)}) / 480.0;
  const RgbaImage fig = sideBySide({slicePanel(ct, labels, seed, {1, 0, 0}, {0, 1, 0}, mmPerPx),
                                    slicePanel(ct, labels, knee, {1, 0, 0}, {0, 0, -1}, mmPerPx),
                                    slicePanel(ct, labels, knee, {0, 1, 0}, {0, 0, -1}, mmPerPx)},
                                   8);
  io::saveImage(fig, ctx.outDir / "segmentation.png");

  nlohmann::json j;
  j["bone"] = {{"method", "threshold whole-bone preset + hole fill in x/y/z slices + islands < 100 mm3"}, {"truth", "isBone"},
               {"dice", boneM.dice}, {"hd95_mm", boneM.hd95Mm}};
  j["soft_tissue"] = {{"method", "snake, threshold speed, bubble 10 mm at (0,35,60) mm"}, {"truth", "isSoftTissue"},
                      {"dice", softM.dice}, {"hd95_mm", softM.hd95Mm}, {"iterations", snake.iterations},
                      {"coarse_iterations", snake.coarseIterations}, {"seconds", snake.seconds}};
  j["seconds"] = secondsSince(t0);
  writeJsonFile(j, ctx.outDir / "segmentation.json");
  std::printf("segmentation: bone Dice %.4f (HD95 %.2f mm), soft tissue snake Dice %.4f (HD95 %.2f mm, %.2f s) -> segmentation.nrrd, segmentation.png\n",
              boneM.dice, boneM.hd95Mm, softM.dice, softM.hd95Mm, snake.seconds);
}

}  // namespace vellum::cli
