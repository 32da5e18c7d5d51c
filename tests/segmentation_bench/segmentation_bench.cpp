// Times every segmentation method on the knee phantom and prints Dice against its truth.
//   vellum_segmentation_bench [--sizes 128,256] [--only NAME] [--repeat N]
// Output: one Markdown table row per (size, method); paste into docs/benchmarks-segmentation.md.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "vellum/core/parallel.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/core/distance_transform.hpp"
#include "vellum/segmentation/metrics.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/region_growing.hpp"
#include "vellum/segmentation/snake.hpp"
#include "vellum/segmentation/threshold.hpp"

using namespace vellum;
using namespace vellum::segmentation;

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Best-of-N wall time (s) of fn; the last result is kept by fn itself.
double timeIt(int repeat, const std::function<void()>& fn) {
  double best = 1e30;
  for (int r = 0; r < repeat; ++r) {
    const double t0 = now();
    fn();
    best = std::min(best, now() - t0);
  }
  return best;
}

void row(int size, const char* method, double seconds, const std::string& quality) {
  std::printf("| %d³ | %s | %.3f | %s |\n", size, method, seconds, quality.c_str());
  std::fflush(stdout);
}

std::string diceText(double dice) {
  char b[64];
  std::snprintf(b, sizeof b, "Dice %.4f", dice);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{128, 256};
  std::string only;
  int repeat = 3;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--sizes") && a + 1 < argc) {
      sizes.clear();
      for (const char* s = argv[++a]; *s;) {
        sizes.push_back(std::atoi(s));
        while (*s && *s != ',') ++s;
        if (*s == ',') ++s;
      }
    } else if (!std::strcmp(argv[a], "--only") && a + 1 < argc) {
      only = argv[++a];
    } else if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++a]));
    } else {
      std::fprintf(stderr, "usage: %s [--sizes 128,256] [--only METHOD] [--repeat N]\n", argv[0]);
      return 2;
    }
  }
  auto want = [&](const char* m) { return only.empty() || only == m; };
  std::printf("threads: %d\n\n| phantom | method | seconds (best of %d) | result |\n|---|---|---|---|\n",
              workerCount(), repeat);
  for (int size : sizes) {
    phantom::PhantomOptions po;
    po.dims = {size, size, size};
    const phantom::Phantom ph = phantom::makePhantom(po);
    const VolumeI16& ct = ph.ct;
    const Mask boneTruth = maskFromIds(ph.labels.ids(), phantom::isCorticalBone);
    const Mask softTruth = maskFromIds(ph.labels.ids(), phantom::isSoftTissue);
    // A seed in the posterior thigh muscle, well away from bone.
    const Vec3 softSeed{0, 35, 60};
    const Vec3 femurSeed = [&] {  // any femur cortex voxel near the shaft middle
      const auto& g = ct.geometry();
      for (int64_t j = 0; j < g.dims.y; ++j)
        for (int64_t i = 0; i < g.dims.x; ++i) {
          const int64_t k = g.dims.z * 3 / 4;
          if (ph.labels(i, j, k) == phantom::kFemurCortex && ct(i, j, k) > 1000)
            return g.indexToPhysical({double(i), double(j), double(k)});
        }
      return Vec3{};
    }();

    Mask m;
    if (want("threshold")) {
      const double t = timeIt(repeat, [&] { m = threshold(ct, presetInterval(Preset::Bone)); });
      row(size, "threshold (bone preset)", t, diceText(overlap(m, boneTruth).dice) + " vs cortical bone");
    }
    if (want("otsu")) {
      double th = 0;
      const double t = timeIt(repeat, [&] {
        th = otsuThreshold(histogram(ct, {256, -1024, 3071}));
        m = threshold(ct, {th, 3071});
      });
      row(size, "otsu (histogram + threshold)", t, "threshold " + std::to_string(int(th)) + " HU");
    }
    if (want("multi-otsu")) {
      std::vector<double> th;
      const double t = timeIt(repeat, [&] {
        th = multiOtsuThresholds(histogram(ct, {256, -1024, 3071}), 4);
        (void)classify(ct, th);
      });
      std::string s = "thresholds";
      for (double v : th) {
        s += ' ';  // (appending " " + to_string(...) trips a GCC 12 -Wrestrict false positive)
        s += std::to_string(int(v));
      }
      row(size, "multi-otsu, 4 classes (+ classify)", t, s + " HU");
    }
    if (want("hysteresis")) {
      // Weak = the bone preset (cortex midpoint), strong = solid cortex.
      const HysteresisParams hp{{1000, 3071}, presetInterval(Preset::Bone), Connectivity::Vertex26};
      const double t = timeIt(repeat, [&] { m = hysteresis(ct, hp); });
      row(size, "hysteresis (1000 / 700 HU)", t, diceText(overlap(m, boneTruth).dice) + " vs cortical bone");
    }
    if (want("grow")) {
      const double t = timeIt(repeat, [&] { m = connectedThreshold(ct, {femurSeed}, presetInterval(Preset::Bone)); });
      const Mask femurTruth = maskFromIds(ph.labels.ids(), [](uint16_t v) { return v == phantom::kFemurCortex; });
      row(size, "region growing (femur, bone preset)", t, diceText(overlap(m, femurTruth).dice) + " vs femur cortex");
    }
    if (want("confidence")) {
      ConfidenceResult r;
      const double t = timeIt(repeat, [&] { r = confidenceConnected(ct, {softSeed}); });
      const Mask muscle = maskFromIds(ph.labels.ids(), [](uint16_t v) { return v == phantom::kMuscle; });
      row(size, "confidence-connected (muscle seed)", t, diceText(overlap(r.mask, muscle).dice) + " vs muscle");
    }
    const Mask bone = threshold(ct, presetInterval(Preset::Bone));
    if (want("edt")) {
      const double t = timeIt(repeat, [&] { (void)squaredDistanceMm(bone); });
      row(size, "exact EDT (mm)", t, "");
    }
    if (want("morphology")) {
      const double t = timeIt(repeat, [&] { m = close(bone, 3.0); });
      row(size, "closing, 3 mm ball", t, "");
      const double t2 = timeIt(repeat, [&] { m = open(bone, 10.0); });
      row(size, "opening, 10 mm ball", t2, "");
    }
    if (want("components")) {
      Components c;
      const double t = timeIt(repeat, [&] { c = connectedComponents(bone, Connectivity::Vertex26); });
      row(size, "connected components (26)", t, std::to_string(c.count()) + " components");
      const double t2 = timeIt(repeat, [&] { m = removeSmallIslands(bone, 100.0); });
      row(size, "remove islands < 100 mm³", t2, "");
      const double t3 = timeIt(repeat, [&] { m = fillHoles(bone); });
      row(size, "fill holes (3D)", t3, "");
    }
    if (want("metrics")) {
      SegmentMetrics s;
      const double t = timeIt(repeat, [&] { s = compareMasks(bone, boneTruth); });
      char b[96];
      std::snprintf(b, sizeof b, "HD95 %.2f mm", s.hd95Mm);
      row(size, "Dice + HD95 (bone)", t, b);
    }
    for (SpeedType type : {SpeedType::Threshold, SpeedType::Edge}) {
      const bool edge = type == SpeedType::Edge;
      if (!want(edge ? "snake-edge" : "snake")) continue;
      SpeedImage speed;
      const double ts = timeIt(1, [&] { speed = edge ? edgeSpeed(ct) : thresholdSpeed(ct); });
      const SnakeParams sp;  // library defaults (edge: exponent 4, kappa 120, advection 2)
      SnakeResult r;
      const double t = timeIt(1, [&] { r = evolveSnake(speed, {{softSeed, 10.0}}, sp); });
      const auto ov = overlap(r.mask, softTruth);
      char b[200];
      std::snprintf(b, sizeof b, "%s; %d iterations (+%d coarse), %.1f ms/iteration, %s; speed image %.2f s",
                    diceText(ov.dice).c_str(), r.iterations, r.coarseIterations,
                    1000 * r.secondsPerIteration, r.converged ? "converged" : "NOT converged", ts);
      row(size, edge ? "snake, edge speed (soft tissue)" : "snake, threshold speed (soft tissue)", t, b);
    }
  }
  return 0;
}
