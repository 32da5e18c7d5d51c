// The shape pipeline: stages run one after the other (so each has a wall-clock time), each
// stage in parallel over the segments (TBB); OpenVDB's tools are threaded inside too.
// Progress and cancellation are checked between stages on the calling thread only: an
// exception thrown inside a TBB task cancels the nested OpenVDB algorithms of the other
// segments half-way (TBB returns from them early), and OpenVDB then works on torn grids.
#include <sys/resource.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "shape_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::illustration {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
/// VELLUM_SHAPE_PROFILE: the process's CPU seconds (all threads) since the previous call, by
/// stage: on a loaded machine the wall-clock stage times mostly measure the other processes.
void cpuLap(const char* stage) {
  static const bool profile = std::getenv("VELLUM_SHAPE_PROFILE") != nullptr;
  if (!profile) return;
  static double last = 0;
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const double now = double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  std::fprintf(stderr, "  cpu %-12s %7.2f s\n", stage, now - last);
  last = now;
}
template <class F>
void forEachSegment(size_t n, F f) {
  tbb::parallel_for(size_t(0), n, [&](size_t i) { f(i); }, tbb::simple_partitioner());
}
}  // namespace

VolumeF32 denoiseMask(const VolumeU8& mask, const DenoiseOptions& options) {
  const auto box = detail::maskFromVolume(mask, 4);
  auto ls = detail::denoiseLevelSet(box, options.iterations, options.marginVoxels);
  return detail::levelSetToDense(*ls, mask.geometry());
}

std::vector<SegmentShape> buildShapes(const LabelVolume& labels,
                                      const std::vector<Segment>& segments,
                                      const ShapeOptions& options, StageTimes& times,
                                      Progress& progress) {
  const size_t n = segments.size();
  const Geometry& g = labels.geometry();
  const double minSpacing = g.minSpacing();
  std::vector<detail::MaskBox> masks(n);
  std::vector<detail::LevelSetPtr> sets(n);
  std::vector<SegmentShape> shapes(n);
  for (size_t i = 0; i < n; ++i) shapes[i].segment = segments[i];

  progress.begin("denoise", n);
  cpuLap("before");
  auto t0 = Clock::now();
  forEachSegment(n, [&](size_t i) {
    masks[i] = detail::extractMask(labels.ids(), segments[i].ids, 4);
    if (masks[i].count == 0) return;
    sets[i] = detail::denoiseLevelSet(masks[i], options.denoise.iterations, options.denoise.marginVoxels);
  });
  times.denoiseMs = msSince(t0);
  cpuLap("denoise");
  progress.advance(n);  // throws Cancelled here, on this thread, never inside a TBB task
  for (size_t i = 0; i < n; ++i)
    if (masks[i].count == 0) throw Error("--segment " + segments[i].name + ": no voxel has its label ids");
  progress.end();

  progress.begin("mesh", n);
  t0 = Clock::now();
  forEachSegment(n, [&](size_t i) {
    shapes[i].mesh = detail::extractIndexMesh(*sets[i], options.adaptivity);
    detail::indexToPhysical(shapes[i].mesh, g);
    sets[i].reset();
  });
  times.meshMs = msSince(t0);
  cpuLap("mesh");
  progress.advance(n);
  progress.end();

  progress.begin("process", n);
  t0 = Clock::now();
  static const bool profile = std::getenv("VELLUM_SHAPE_PROFILE") != nullptr;
  forEachSegment(n, [&](size_t i) {
    MeshChecks stats;
    auto tp = Clock::now();
    const size_t facesIn = shapes[i].mesh.faces.size();
    TriMesh m = detail::smoothAndDecimate(shapes[i].mesh, options.smoothingIterations,
                                          options.targetFaces, 0.5 * minSpacing);
    const double decMs = msSince(tp);
    tp = Clock::now();
    m = detail::repairMesh(m, stats);
    const double repMs = msSince(tp);
    tp = Clock::now();
    MeshChecks c = checkMesh(m);
    if (profile)
      std::fprintf(stderr, "  process %-10s %zu -> %zu faces: smooth+decimate %.0f ms, repair %.0f ms, check %.0f ms\n",
                   segments[i].name.c_str(), facesIn, m.faces.size(), decMs, repMs, msSince(tp));
    // The soup round trip can leave a few intersections CGAL's repair did not see (faces
    // meeting at duplicated, coincident vertices): one more repair pass on the result.
    for (int pass = 0; pass < 2 && (c.selfIntersections > 0 || !c.closed || !c.manifold); ++pass) {
      MeshChecks again;
      m = detail::repairMesh(m, again);
      stats.holesFilled += again.holesFilled;
      stats.degenerateRemoved += again.degenerateRemoved;
      stats.selfIntersectionsRepaired = stats.selfIntersectionsRepaired || again.selfIntersectionsRepaired;
      c = checkMesh(m);
    }
    c.holesFilled = stats.holesFilled;
    c.degenerateRemoved = stats.degenerateRemoved;
    c.selfIntersectionsRepaired = stats.selfIntersectionsRepaired;
    c.voxelVolumeMm3 = double(masks[i].count) * g.spacing.x * g.spacing.y * g.spacing.z;
    c.maxBoundaryDistanceMm = detail::maxDistanceToBinaryBoundary(m, masks[i], g);
    shapes[i].mesh = std::move(m);
    shapes[i].checks = c;
  });
  times.processMs = msSince(t0);
  cpuLap("process");
  progress.advance(n);
  progress.end();
  return shapes;
}

ShapeResult runShapePipeline(const LabelVolume& labels, const std::vector<Segment>& segments,
                             const std::vector<Shell>& shells, const std::vector<Grow>& grows,
                             const ShapeOptions& options, Progress& progress) {
  if (segments.empty()) throw Error("no segments: give at least one --segment NAME=ID[,ID..]");
  for (size_t i = 0; i < segments.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (segments[i].name == segments[j].name)
        throw Error("--segment: name '" + segments[i].name + "' is used twice");
  auto indexOf = [&](const std::string& name, const char* flag) {
    for (size_t i = 0; i < segments.size(); ++i)
      if (segments[i].name == name) return i;
    throw Error(std::string(flag) + ": unknown segment '" + name + "'");
  };
  std::vector<double> extra(segments.size(), 0.0), offset(segments.size(), 0.0);
  for (const auto& s : shells) {
    const size_t i = indexOf(s.segment, "--shell");
    if (!(s.thicknessMm > 0) || !std::isfinite(s.thicknessMm))
      throw Error("--shell " + s.segment + ": thickness must be a positive number of mm");
    extra[i] = std::max(extra[i], s.thicknessMm);
  }
  for (const auto& gr : grows) {
    const size_t i = indexOf(gr.segment, "--grow");
    if (!std::isfinite(gr.offsetMm)) throw Error("--grow " + gr.segment + ": offset must be a number of mm");
    offset[i] += gr.offsetMm;
  }
  for (size_t i = 0; i < segments.size(); ++i)
    extra[i] = std::max(extra[i] + std::max(0.0, -offset[i]), std::abs(offset[i]));

  ShapeResult r;
  r.shapes = buildShapes(labels, segments, options, r.times, progress);

  // Distances, one segment at a time (each is parallel inside): its float distance is folded
  // into the union, the labels and its int16 field, then dropped, so that only one float
  // volume per segment is ever alive (memory at 512x512x350: ~370 MB a float volume).
  const size_t n = segments.size();
  progress.begin("distances", n);
  DistanceOptions dopt;
  dopt.bandMm = options.exactBandMm;
  detail::RepresentationBuilder builder(labels.geometry(), segments, shells);
  r.fields.resize(n);
  VolumeF32 dist;  // one buffer for every segment, then the far field's scratch
  for (size_t i = 0; i < n; ++i) {
    auto t0 = Clock::now();
    detail::signedDistanceInto(r.shapes[i].mesh, labels.geometry(), dopt, extra[i], dist);
    r.times.distancesMs += msSince(t0);
    cpuLap("distance");
    t0 = Clock::now();
    if (offset[i] != 0) {
      const float o = static_cast<float>(offset[i]);
      float* v = dist.data();
      parallelFor(static_cast<int64_t>(dist.size()), [&](int64_t b, int64_t e) {
        for (int64_t x = b; x < e; ++x) v[x] -= o;
      }, 1 << 16);
      // Values beyond the exact band were clamped at +-background: the exact band shrinks.
      dist.setBackground(dist.background() - std::abs(offset[i]));
    }
    builder.add(i, dist);
    r.fields[i] = detail::segmentField(i, dist, segments, shells, n);
    r.times.segmentationMs += msSince(t0);
    cpuLap("fold+field");
    progress.advance();
  }
  progress.end();
  progress.begin("segmentation", 1);
  auto t0 = Clock::now();
  builder.finish(r.distance, r.segmentation, &dist.voxels());
  r.times.segmentationMs += msSince(t0);
  cpuLap("far field");
  progress.advance();
  progress.end();
  return r;
}

const params::Table<ShapeOptions>& shapeOptionsTable() {
  using S = ShapeOptions;
  static const params::Table<S> table{
      params::integer<S>("denoise_iterations", params::nested(&S::denoise, &DenoiseOptions::iterations),
                         {"Denoising steps", "constrained mean-curvature steps of the level-set denoising", "", 0, 1000}),
      params::real<S>("denoise_margin", params::nested(&S::denoise, &DenoiseOptions::marginVoxels),
                      {"Constraint margin", "phi <= -m inside, >= +m outside at voxel centres (keeps thin sheets)",
                       "voxels", 0, 0.5}),
      params::integer<S>("target_faces", &S::targetFaces,
                         {"Face budget", "per-segment face budget of the decimation; 0 = no decimation", "", 0, 10000000}),
      params::integer<S>("smoothing_iterations", &S::smoothingIterations,
                         {"Smoothing passes", "OpenMesh tangential smoothing passes", "", 0, 100}),
      params::real<S>("adaptivity", &S::adaptivity,
                      {"Meshing adaptivity", "OpenVDB volumeToMesh adaptivity; 0 = uniform", "", 0, 1}),
      params::real<S>("band", &S::exactBandMm,
                      {"Exact band", "half-width of the band of exact distances; 0 = 3 voxels of the smallest spacing, at least 2 of the largest", "mm", 0, 1000}),
  };
  return table;
}

}  // namespace vellum::illustration
