#include "vellum/segmentation/body_mask.hpp"

#include "vellum/segmentation/components.hpp"
#include "vellum/core/distance_transform.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::segmentation {

const params::Table<BodyMaskParams>& bodyMaskParamsTable() {
  using B = BodyMaskParams;
  static const params::Table<B> table{
      params::real<B>("air_threshold", [](auto& p) -> auto& { return p.airThresholdHu; },
                      {"Air threshold", "the body is everything above it", "HU", -1000, 0}),
      params::real<B>("opening_radius", [](auto& p) -> auto& { return p.openingRadiusMm; },
                      {"Opening radius", "contacts thinner than about twice this are cut (table pads, rods)", "mm",
                       0, 30}),
  };
  return table;
}

Mask bodyMask(const VolumeI16& ct, const BodyMaskParams& params, Progress& progress) {
  params::validate(bodyMaskParamsTable(), params);
  const Mask aboveAir = threshold(ct, {params.airThresholdHu, 32767});
  const double r = params.openingRadiusMm;
  if (r == 0) return fillHolesAllSlices(keepLargestComponent(aboveAir));
  // Enclosed air filled first, so that a thin shell around air (a skull of a head phantom,
  // a thin chest wall around lungs) is solid when the opening cuts the thin contacts; the
  // opening's largest component is the body's core.
  const Mask opened = open(fillHolesPerSlice(aboveAir), r, progress);
  const Mask core = keepLargestComponent(opened);
  const Mask others = maskAnd(opened, maskNot(core));
  // Grow the core back by r inside the thresholded voxels, but only where it is nearer than
  // any other opened part (else the growth would climb back onto the table next to it).
  const VolumeF32 toCore = squaredDistanceMm(core, progress);
  const VolumeF32 toOthers = squaredDistanceMm(others, progress);
  Mask body = makeMask(ct.geometry());
  const float r2 = float(r * r);
  for (size_t i = 0; i < body.size(); ++i)
    body.data()[i] = aboveAir.data()[i] && toCore.data()[i] <= r2 && toCore.data()[i] <= toOthers.data()[i];
  return fillHolesAllSlices(keepLargestComponent(body));
}

VolumeI16 removeTable(const VolumeI16& ct, const BodyMaskParams& params, Progress& progress) {
  const Mask body = bodyMask(ct, params, progress);
  VolumeI16 out = ct;
  const auto air = static_cast<int16_t>(ct.background());
  int16_t* v = out.data();
  const uint8_t* m = body.data();
  for (size_t i = 0; i < out.size(); ++i)
    if (!m[i]) v[i] = air;
  return out;
}

}  // namespace vellum::segmentation
