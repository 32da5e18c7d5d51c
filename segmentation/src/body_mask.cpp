#include "vellum/segmentation/body_mask.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

#include "vellum/segmentation/components.hpp"
#include "vellum/core/distance_transform.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::segmentation {

const params::Table<BodyMaskParams>& bodyMaskParamsTable() {
  using B = BodyMaskParams;
  static const params::Table<B> table{
      params::real<B>("air_threshold", &B::airThresholdHu,
                      {"Air threshold", "the body is everything above it", "HU", -1000, 0}),
      params::real<B>("opening_radius", &B::openingRadiusMm,
                      {"Opening radius", "contacts thinner than about twice this are cut (table pads, rods)", "mm",
                       0, 30}),
      params::real<B>("min_part_volume", &B::minPartMl,
                      {"Smallest body part",
                       "every separate part at least this large (and thick) is kept: two legs, two feet, arms "
                       "beside a chest; smaller pieces go",
                       "mL", 0, 1e6}),
      params::real<B>("min_part_thickness", &B::minPartThicknessMm,
                      {"Thinnest body part",
                       "a part must be at least this thick somewhere (largest ball inside it): table tops and "
                       "pads are thinner than a foot or a wrist",
                       "mm", 0, 500}),
  };
  return table;
}

namespace {

struct Parts {
  Mask mask;
  std::vector<double> keptMl;  ///< largest first
  int left = 0;                ///< components not kept
  bool largestBelowMinimum = false;
};

/// The components `c` of `m` that `isPart(label)` accepts; the largest alone when it accepts none.
Parts keepParts(const Mask& m, const Components& c, const std::function<bool(uint32_t)>& isPart) {
  std::vector<uint8_t> keep(c.sizes.size(), 0);
  Parts out;
  for (uint32_t l = 1; l < keep.size(); ++l) keep[l] = isPart(l);
  if (c.count() > 0 && std::find(keep.begin(), keep.end(), 1) == keep.end()) {
    keep[c.largest()] = 1;
    out.largestBelowMinimum = true;
  }
  const double voxelMl = voxelVolumeMm3(m.geometry()) / 1000;
  for (uint32_t l = 1; l < keep.size(); ++l)
    if (keep[l]) out.keptMl.push_back(double(c.sizes[l]) * voxelMl);
    else ++out.left;
  std::sort(out.keptMl.rbegin(), out.keptMl.rend());
  out.mask = selectComponents(m.geometry(), c, keep);
  return out;
}

/// Body parts of `m`: components at least minPartMl large and minPartThicknessMm thick.
Parts bodyParts(const Mask& m, const BodyMaskParams& p, Progress& progress) {
  // Thickness: twice the deepest voxel's distance to the outside (the largest inner ball).
  const VolumeF32 depth2 = squaredDistanceMm(maskNot(m), progress);
  const Components c = connectedComponents(m);
  std::vector<float> deepest2(c.sizes.size(), 0.f);
  for (size_t i = 0; i < c.labels.size(); ++i)
    if (const uint32_t l = c.labels[i]) deepest2[l] = std::max(deepest2[l], depth2.data()[i]);
  const double voxelMl = voxelVolumeMm3(m.geometry()) / 1000;
  return keepParts(m, c, [&](uint32_t l) {
    return double(c.sizes[l]) * voxelMl >= p.minPartMl && 2 * std::sqrt(double(deepest2[l])) >= p.minPartThicknessMm;
  });
}

}  // namespace

Mask bodyMask(const VolumeI16& ct, const BodyMaskParams& params, Progress& progress, BodyMaskReport* report) {
  params::validate(bodyMaskParamsTable(), params);
  const Mask aboveAir = threshold(ct, {params.airThresholdHu, 32767});
  const double r = params.openingRadiusMm;
  Parts core;
  Mask body;
  if (r == 0) {
    core = bodyParts(aboveAir, params, progress);
    body = std::move(core.mask);
  } else {
    // Enclosed air filled first, so that a thin shell around air (a skull of a head phantom,
    // a thin chest wall around lungs) is solid when the opening cuts the thin contacts; the
    // opening's body parts (each leg, each foot) are the body's core.
    const Mask opened = open(fillHolesPerSlice(aboveAir), r, progress);
    core = bodyParts(opened, params, progress);
    const Mask others = maskAnd(opened, maskNot(core.mask));
    // Grow the core back by r inside the thresholded voxels, but only where it is nearer than
    // any other opened part (else the growth would climb back onto the table next to it).
    const VolumeF32 toCore = squaredDistanceMm(core.mask, progress);
    const VolumeF32 toOthers = squaredDistanceMm(others, progress);
    body = makeMask(ct.geometry());
    const float r2 = float(r * r);
    for (size_t i = 0; i < body.size(); ++i)
      body.data()[i] = aboveAir.data()[i] && toCore.data()[i] <= r2 && toCore.data()[i] <= toOthers.data()[i];
  }
  // Crumbs the growth left apart from the parts (a pad's last millimetres) go too.
  const double voxelMl = voxelVolumeMm3(ct.geometry()) / 1000;
  const Mask filled = fillHolesAllSlices(body);
  const Components pieces = connectedComponents(filled);
  Parts kept = keepParts(filled, pieces, [&](uint32_t l) { return double(pieces.sizes[l]) * voxelMl >= params.minPartMl; });
  if (report) {
    *report = {};
    report->keptPartsMl = kept.keptMl;
    int64_t removed = 0;
    for (size_t i = 0; i < kept.mask.size(); ++i) removed += aboveAir.data()[i] && !kept.mask.data()[i];
    report->removedMl = double(removed) * voxelMl;
    report->removedParts = core.left + kept.left;
    report->keptLargestBelowMinimum = core.largestBelowMinimum;
  }
  return std::move(kept.mask);
}

VolumeI16 removeTable(const VolumeI16& ct, const BodyMaskParams& params, Progress& progress,
                      BodyMaskReport* report) {
  const Mask body = bodyMask(ct, params, progress, report);
  VolumeI16 out = ct;
  const auto air = static_cast<int16_t>(ct.background());
  int16_t* v = out.data();
  const uint8_t* m = body.data();
  for (size_t i = 0; i < out.size(); ++i)
    if (!m[i]) v[i] = air;
  return out;
}

}  // namespace vellum::segmentation
