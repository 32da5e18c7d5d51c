// Deformation benchmarks on the knee phantom with the demo's 16 control points (strongest bend).
// Wall-clock times (the engine is parallel): UseRealTime. Counters: PSNR against s = 1.
#include <benchmark/benchmark.h>

#include <vtkImageData.h>
#include <vtkImageReslice.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkThinPlateSplineTransform.h>

#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>

#include "vellum/core/heap_reuse.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/deformation/twist_map.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

const phantom::Phantom& kneePhantom(int n) {
  static std::map<int, phantom::Phantom> cache;
  auto it = cache.find(n);
  if (it == cache.end()) {
    phantom::PhantomOptions o;
    o.dims = {n, n, n};
    it = cache.emplace(n, phantom::makePhantom(o)).first;
  }
  return it->second;
}
const VolumeI16& knee(int n) { return kneePhantom(n).ct; }

// The demo's strongest keyframe: 20 degrees of flexion about the phantom's knee axis.
ControlPoints bendPoints(const Geometry& g) {
  return kneeBendTrack(g, 20.0, 2.0, phantom::flexionAxisPointMm()).keyframes[1].points;
}

// Full synthesis: control volume at s, then the full-resolution deformed volume. Third
// argument: 0 trilinear, 1 Gaussian upsampling of the coordinates.
void BM_Synthesis(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), s = static_cast<int>(state.range(1));
  const Upsampling up = state.range(2) ? Upsampling::Gaussian : Upsampling::Trilinear;
  const AnyVolume vol = knee(n);
  const auto pts = bendPoints(knee(n).geometry());
  DeformParams p;
  p.controlScale = s;
  Deformer d(vol, p);
  d.setPoints(pts);
  AnyVolume out;
  double mapMs = 0;
  for (auto _ : state) {
    d.update();
    mapMs += d.timings().mapMs;
    out = synthesize(vol, d.controlVolume(), up);
    benchmark::DoNotOptimize(out);
  }
  state.counters["map_ms"] = mapMs / static_cast<double>(state.iterations());
  if (s > 1) {
    DeformParams ref = p;
    ref.controlScale = 1;
    state.counters["psnr_db"] = psnr(synthesize(vol, computeControlVolume(vol, pts, ref)), out);
  }
  state.counters["threads"] = workerCount();
}

// Synthesis with rigid bones (ids 4..9, 11): MLS map, rigidity blend, then synthesis with the
// voxel snap. Counters: blend_ms, and the voxel-level bone RMS residual of the result's map.
void BM_SynthesisRigid(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), s = static_cast<int>(state.range(1));
  const AnyVolume vol = knee(n);
  const auto pts = bendPoints(knee(n).geometry());
  const RigidBodies bodies = RigidBodies::fromLabels(kneePhantom(n).labels, {4, 5, 6, 7, 8, 9, 11});
  DeformParams p;
  p.controlScale = s;
  Deformer d(vol, p);
  d.setPoints(pts);
  ControlVolume cv = d.update();
  applyRigidity(cv, bodies);  // builds the cached distance fields (once per grid)
  AnyVolume out;
  double blendMs = 0;
  for (auto _ : state) {
    cv = d.update();
    const auto t0 = std::chrono::steady_clock::now();
    applyRigidity(cv, bodies);
    blendMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    out = synthesize(vol, cv);
    benchmark::DoNotOptimize(out);
  }
  state.counters["blend_ms"] = blendMs / static_cast<double>(state.iterations());
  state.counters["bone_rms_voxels_mm"] = measureRigidityVoxels(cv, knee(n).geometry(), bodies).boneRmsResidualMm;
  state.counters["threads"] = workerCount();
}

// The rigid-bone blend alone (what the studio adds to every map update), s = 4 as the studio.
void BM_RigidBlend(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), s = static_cast<int>(state.range(1));
  const RigidBodies bodies = RigidBodies::fromLabels(kneePhantom(n).labels, {4, 5, 6, 7, 8, 9, 11});
  DeformParams p;
  p.controlScale = s;
  Deformer d(AnyVolume(knee(n)), p);
  d.setPoints(bendPoints(knee(n).geometry()));
  const ControlVolume solved = d.update();
  ControlVolume cv = solved;
  applyRigidity(cv, bodies);  // builds the cached distance fields (once per grid)
  for (auto _ : state) {
    state.PauseTiming();
    cv = solved;
    state.ResumeTiming();
    applyRigidity(cv, bodies);
    benchmark::DoNotOptimize(cv);
  }
  state.counters["threads"] = workerCount();
}

// Density-aware control-volume update (K = 3) after a target drag. With the cache the rho
// fields exist already (built before timing); without it, rays are cast every iteration.
void BM_DensityUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), s = static_cast<int>(state.range(1));
  const bool cache = state.range(2) != 0;
  const AnyVolume vol = knee(n);
  auto pts = bendPoints(knee(n).geometry());
  DeformParams p;
  p.controlScale = s;
  p.density.enabled = true;
  p.density.iterations = 3;
  p.density.rhoCache = cache;
  Deformer d(vol, p);
  d.setPoints(pts);
  d.update();
  state.counters["rho_cache_build_ms"] = d.timings().rhoCacheMs;
  int flip = 0;
  for (auto _ : state) {
    pts[5].target.x += (flip++ % 2) ? -1.0 : 1.0;  // drag a target
    d.setPoints(pts);
    d.update();
    if (d.timings().rhoFieldsRebuilt != 0) state.SkipWithError("rho fields rebuilt on a target drag");
  }
}

// VTK: thin-plate spline through the same landmarks (output -> input, like our backward map)
// and vtkImageReslice with linear interpolation over the same grid.
void BM_VtkThinPlateSpline(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const VolumeI16& v = knee(n);
  const Geometry& g = v.geometry();
  vtkNew<vtkImageData> img;
  img->SetDimensions(int(g.dims.x), int(g.dims.y), int(g.dims.z));
  img->SetSpacing(g.spacing.x, g.spacing.y, g.spacing.z);
  img->SetOrigin(g.origin.x, g.origin.y, g.origin.z);
  img->AllocateScalars(VTK_SHORT, 1);
  std::memcpy(img->GetScalarPointer(), v.data(), v.size() * sizeof(int16_t));
  vtkNew<vtkPoints> from, to;
  for (const auto& p : bendPoints(g)) {
    from->InsertNextPoint(p.target.x, p.target.y, p.target.z);
    to->InsertNextPoint(p.source.x, p.source.y, p.source.z);
  }
  vtkNew<vtkThinPlateSplineTransform> tps;
  tps->SetSourceLandmarks(from);
  tps->SetTargetLandmarks(to);
  tps->SetBasisToR();
  for (auto _ : state) {
    vtkNew<vtkImageReslice> reslice;
    reslice->SetInputData(img);
    reslice->SetResliceTransform(tps);
    reslice->SetInterpolationModeToLinear();
    reslice->SetBackgroundLevel(-1000);
    reslice->SetOutputSpacing(g.spacing.x, g.spacing.y, g.spacing.z);
    reslice->SetOutputOrigin(g.origin.x, g.origin.y, g.origin.z);
    reslice->SetOutputExtent(0, int(g.dims.x) - 1, 0, int(g.dims.y) - 1, 0, int(g.dims.z) - 1);
    reslice->Update();
    benchmark::DoNotOptimize(reslice->GetOutput()->GetScalarPointer());
  }
}

// The file stages of `vellum deform` (issue 11): loading the int16 phantom from a MetaImage
// (.mha) and saving a volume as gzip NRRD (the CLI's default). Files live in /dev/shm when it
// exists, so the page cache, not the disk, is what the load reads from.
std::filesystem::path benchFile(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
  return dir / ("vellum-bench-" + std::to_string(::getpid()) + "-" + name);
}

void BM_LoadMha(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto path = benchFile("load.mha");
  io::saveVolume(knee(n), path);
  for (auto _ : state) {
    io::LoadedVolume lv = io::loadVolume(path);
    benchmark::DoNotOptimize(lv.volume);
  }
  std::filesystem::remove(path);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(knee(n).size() * 2));
}

void BM_SaveGzipNrrd(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto path = benchFile("save.nrrd");
  for (auto _ : state) io::saveVolume(knee(n), path);
  state.counters["compressed_mb"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::filesystem::remove(path);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(knee(n).size() * 2));
}

// One movie frame's twist map (`vellum pose --movie`): the knee phantom at 256 x 256 x 175,
// the node grid of the 512 x 512 x 350 knee at the movie's scale 2; femur and patella still,
// tibia and fibula turned by the first argument's degrees about the flexion axis; the second:
// TwistParams::cellCheck (1, as in movie frames).
// Run: vellum_deformation_bench --benchmark_filter=TwistMap --benchmark_min_time=5
void BM_TwistMap(benchmark::State& state) {
  phantom::PhantomOptions o;
  o.dims = {256, 256, 175};
  static const phantom::Phantom ph = phantom::makePhantom(o);
  Pose pose;
  Joint knee;
  knee.name = "knee";
  knee.parent = {4, 5};
  knee.child = {6, 7};
  knee.axisA = {-10, 0, 24.5};
  knee.axisB = {10, 0, 24.5};
  pose.joints.push_back(knee);
  linkJoints(pose);
  const RigidBodies bodies = RigidBodies::fromLabelGroups(ph.labels, {{4, 5}, {6, 7}}, 3);
  const double angle = static_cast<double>(state.range(0));
  TwistParams params;
  params.cellCheck = state.range(1) != 0;  // as TwistFrames sets it at scale > 1
  const ReuseFreedMemory reuse;  // as a movie's frames do (heap_reuse.hpp): no fresh pages per map
  TwistMap m;
  for (auto _ : state) m = twistMap(pose, {angle}, bodies, ph.labels.geometry(), params);
  const TwistJointStats& s = m.joints.at(0);
  state.counters["rounds"] = s.rounds;
  state.counters["joined"] = static_cast<double>(s.joinedVoxels);
  state.counters["relaxed"] = static_cast<double>(s.relaxedVoxels);
  state.counters["softened"] = static_cast<double>(s.softenedVoxels);
}

}  // namespace

BENCHMARK(BM_LoadMha)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SaveGzipNrrd)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Synthesis)->ArgsProduct({{128, 256}, {1, 2, 4}, {0}})
    ->ArgsProduct({{128, 256}, {2, 4}, {1}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RigidBlend)->Args({256, 4})->Args({256, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SynthesisRigid)->Args({128, 2})->Args({256, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DensityUpdate)->Args({128, 4, 1})->Args({256, 4, 1})->Args({256, 2, 1})
    ->Args({128, 4, 0})->Args({256, 4, 0})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_VtkThinPlateSpline)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_TwistMap)->ArgsProduct({{10, 20}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
