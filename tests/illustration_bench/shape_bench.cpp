// Shape pipeline stages on the knee phantom, 4 segments (body, muscle, femur, tibia):
//   vellum_shape_bench --benchmark_filter=/128     (or /256)
// Each run is the whole pipeline; the counters are each stage's wall time in ms (mean over
// the iterations). CPU time is listed by Google Benchmark for the main thread only.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "vellum/illustration/shape.hpp"
#include "vellum/phantom/phantom.hpp"

namespace ill = vellum::illustration;

namespace {
const vellum::phantom::Phantom& phantomOf(int64_t n) {
  static std::map<int64_t, std::unique_ptr<vellum::phantom::Phantom>> cache;
  auto& p = cache[n];
  if (!p) {
    vellum::phantom::PhantomOptions o;
    o.dims = {n, n, n};
    p = std::make_unique<vellum::phantom::Phantom>(vellum::phantom::makePhantom(o));
  }
  return *p;
}

void BM_ShapePipeline(benchmark::State& state) {
  const auto& ph = phantomOf(state.range(0));
  std::vector<ill::Segment> segs;
  for (const char* s : {"body=1,2,3,4,5,6,7,8,9,10,11", "muscle=3", "femur=4,5", "tibia=6,7"})
    segs.push_back(ill::parseSegmentSpec(s, ph.labels));
  ill::StageTimes sum;
  int runs = 0;
  for (auto _ : state) {
    const auto r = ill::runShapePipeline(ph.labels, segs, {}, {}, {});
    benchmark::DoNotOptimize(r.distance.data());
    sum.denoiseMs += r.times.denoiseMs;
    sum.meshMs += r.times.meshMs;
    sum.processMs += r.times.processMs;
    sum.distancesMs += r.times.distancesMs;
    sum.segmentationMs += r.times.segmentationMs;
    ++runs;
  }
  state.counters["denoise_ms"] = sum.denoiseMs / runs;
  state.counters["mesh_ms"] = sum.meshMs / runs;
  state.counters["process_ms"] = sum.processMs / runs;
  state.counters["distances_ms"] = sum.distancesMs / runs;
  state.counters["segmentation_ms"] = sum.segmentationMs / runs;
}
}  // namespace

BENCHMARK(BM_ShapePipeline)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

BENCHMARK_MAIN();
