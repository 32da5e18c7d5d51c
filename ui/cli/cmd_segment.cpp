// `vellum segment IN --out LABELS.nrrd`: thresholds, Otsu, hysteresis, region growing,
// confidence-connected growing and 3D snakes, with morphology/island post-processing, adding
// into an existing label map, and quality metrics against a truth label map.
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

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

/// The flags: the app request's fields, and the texts parsed into it (seeds, colour).
struct SegmentArgs {
  app::SegmentRequest request;
  std::vector<std::string> seeds;  ///< "x,y,z" (mm)
  std::vector<std::string> splitSeeds;  ///< "x,y,z" (mm), one object each
  std::vector<ColourArg> colour;   ///< --colour R,G,B (0..1) or the old --color (0..255)
  InputOptions in;
};

/// How the segment joins the label map, described once (docs/parameters.md).
const params::Table<app::SegmentRequest>& segmentLabelTable() {
  using R = app::SegmentRequest;
  static const params::Table<R> t{
      params::integer<R>("label_id", &R::labelId, {"Label id", "segment id; 0: the lowest free id", "", 0, 65535}),
      params::text<R>("label_name", &R::labelName, {"Label name", "segment name; empty: the method's", ""}),
      params::text<R>("overlap", &R::overlap, {"Overlap", "where segments overlap", ""},
                      {"overwrite", "keep-existing", "replace"}),
  };
  return t;
}

/// The seeds and the truth ids, described once (docs/parameters.md).
const ListTable<SegmentArgs>& segmentListTable() {
  using A = SegmentArgs;
  static const ListTable<A> t{
      repeated<A>("seed", &A::seeds, "X,Y,Z", {"Seed", "seed point (repeatable; snake: bubble centres)", "mm"}),
      repeated<A>("split_seed", &A::splitSeeds, "X,Y,Z",
                  {"Split seed", "with --split: one object per seed (repeatable; pieces without a seed are dropped)",
                   "mm"}),
      commaList<A>("truth_ids", params::nested(&A::request, &app::SegmentRequest::truthIds), "ID,ID..",
                   {"Truth ids", "compare against the union of these truth ids (default: the same id)", ""}),
  };
  return t;
}

/// The result on stdout: the segment, then each truth comparison.
void printSegmentResult(const app::SegmentRequest& r, const app::SegmentResult& result) {
  const nlohmann::json& j = result.report;
  std::cout << r.output.string() << ": segment";
  for (uint16_t w : result.written) std::cout << " " << w;
  std::cout << " (" << r.settings.method << ")";
  if (j.contains("segment"))
    std::cout << ", " << j["segment"]["voxels"].get<int64_t>() << " voxels, "
              << j["segment"]["volume_mm3"].get<double>() / 1000.0 << " cm³";
  std::cout << "\n";
  if (j.contains("segment") && j["segment"].contains("objects")) {
    for (const auto& o : j["segment"]["objects"])
      std::printf("  id %u: %.2f cm³\n", o["id"].get<unsigned>(), o["volume_mm3"].get<double>() / 1000.0);
    if (j.contains("split")) {
      const nlohmann::json& sp = j["split"];
      std::printf("  dropped %.2f cm³ (pieces below --split-min-volume)\n", sp["dropped_mm3"].get<double>() / 1000.0);
      if (sp.value("joint_contrast_hu", 0.0) > 0)
        std::printf("  joint cut: %lld joint-space voxels, %d neighbours merged across necks\n",
                    static_cast<long long>(sp["joint_voxels"].get<int64_t>()), sp["joint_merges"].get<int>());
      if (sp.value("open_joints", false)) std::printf("  opened %.2f cm³ of joint space\n", sp["opened_mm3"].get<double>() / 1000.0);
      if (sp.value("fill", false)) std::printf("  filled %.2f cm³ of cavities\n", sp["filled_mm3"].get<double>() / 1000.0);
      if (sp.value("thin_mm", 0.0) > 0)
        std::printf("  removed %.2f cm³ of thin tubes (a wire, a cord) before the split\n",
                    sp["thin_removed_mm3"].get<double>() / 1000.0);
    }
  }
  if (!j.contains("metrics")) return;
  for (const auto& m : j["metrics"]) {
    if (m.contains("truth_ids")) {
      std::printf("segment %u vs truth ids:", m["id"].get<unsigned>());
      for (const auto& v : m["truth_ids"]) std::printf(" %u", v.get<unsigned>());
    } else {
      std::printf("label %u", m["id"].get<unsigned>());
    }
    const double hd95 = m["hd95_mm"].is_null() ? NAN : m["hd95_mm"].get<double>();
    std::printf("  Dice %.4f  Jaccard %.4f  HD95 %.2f mm  volume %+.2f%%\n", m["dice"].get<double>(),
                m["jaccard"].get<double>(), hd95, m["volume_difference_percent"].get<double>());
  }
  std::fflush(stdout);
}

void runSegment(SegmentArgs& a) {
  app::SegmentRequest& r = a.request;
  for (const auto& s : a.seeds) {
    const auto v = parseNumberList(s, 3, "--seed");
    r.settings.seedsMm.push_back({v[0], v[1], v[2]});
  }
  for (const auto& s : a.splitSeeds) {
    const auto v = parseNumberList(s, 3, "--split-seed");
    r.settings.post.splitParams.seedsMm.push_back({v[0], v[1], v[2]});
  }
  if (!a.splitSeeds.empty() && !r.settings.post.split) throw Error("--split-seed needs --split");
  if (!a.colour.empty()) r.colour = colourBytes(a.colour.back());
  setVolumeInput(r, a.in);
  printSegmentResult(r, runPipeline(r, app::runSegment));
}

}  // namespace

std::string segmentLabelFlagsMarkdown() {
  const SegmentArgs defaults;  // default-initialised, not S{}: see shapeFlagsMarkdown
  return params::markdown(segmentLabelTable(), defaults.request) + listMarkdownRows(segmentListTable(), defaults);
}

void addSegmentCommand(CLI::App& app) {
  auto a = std::make_shared<SegmentArgs>();
  auto* cmd = app.add_subcommand("segment", "Segment a CT volume into a label map (thresholds, Otsu, region growing, 3D snakes)");
  app::SegmentRequest& r = a->request;
  addInput(*cmd, "input", r.input, "input volume (file or DICOM folder)")->required();
  addOutput(*cmd, "--out,-o", r.output, "output label map (.nrrd keeps the label table)")->required();
  // Method, its settings and post-processing: flags generated from the request's table.
  addFlags(*cmd, r.settings, app::segmentSettingsTable());
  addLists(*cmd, *a, segmentListTable());  // --seed, --split-seed, --truth-ids
  addInput(*cmd, "--into", r.into, "add the segment into this existing label map (written to --out)");
  addFlags(*cmd, r, segmentLabelTable());
  addColourOption(*cmd, a->colour, "R,G,B", "segment colour");
  addInput(*cmd, "--truth", r.truth, "truth label map: report Dice, Jaccard, volume difference, HD95");
  addOutput(*cmd, "--report", r.report, "write parameters, timings, iterations and metrics as JSON");
  a->in.addTo(*cmd);
  addForceFlag(*cmd, r.force);
  cmd->footer(
      "Examples:\n"
      "  vellum segment knee.nrrd --out bone.nrrd --preset whole-bone --fill-holes-slices --min-island 100\n"
      "  vellum segment feet/ --out bones.nrrd --preset whole-bone --fill-holes-slices --split --label-name bone\n"
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
