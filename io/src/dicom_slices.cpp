// Ordering the slices of one DICOM series in space and building the regular output grid:
// sort along the slice normal (never by file name or InstanceNumber), measure the spacing,
// detect duplicates, gaps, uneven spacing and gantry tilt, and resample when needed.
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "dicom_internal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::io::detail::dicom {

namespace {

constexpr double kDuplicateTolMm = 0.01;   // slices closer than this along the normal coincide
constexpr double kOrientationTol = 1e-3;   // per-component IOP difference tolerated in a series
constexpr double kSpacingRelTol = 1e-3;    // relative PixelSpacing difference tolerated
constexpr double kPi = 3.14159265358979323846;

std::string vecText(const Vec3& v) { return num(v.x, 4) + "\\" + num(v.y, 4) + "\\" + num(v.z, 4); }

/// Fills missing attributes of a lone frame with defaults (with warnings) and checks values.
void checkFrame(Frame& f, bool single, std::vector<std::string>& warnings) {
  if (!f.rowCosine || !f.colCosine) {
    if (!single) throw FileError(f.file, "no ImageOrientationPatient: cannot order the slices");
    f.rowCosine = Vec3{1, 0, 0};
    f.colCosine = Vec3{0, 1, 0};
    warnings.push_back("no ImageOrientationPatient: identity orientation assumed");
  }
  if (!f.position) {
    if (!single) throw FileError(f.file, "no ImagePositionPatient: cannot order the slices");
    f.position = Vec3{0, 0, 0};
    warnings.push_back("no ImagePositionPatient: origin set to (0,0,0)");
  }
  if (!f.rowSpacing || !f.colSpacing) {
    f.rowSpacing = f.colSpacing = 1.0;
    warnings.push_back("no PixelSpacing: 1 mm assumed");
  }
  if (!(*f.rowSpacing > 0) || !(*f.colSpacing > 0) || !std::isfinite(*f.rowSpacing) ||
      !std::isfinite(*f.colSpacing))
    throw FileError(f.file, "invalid PixelSpacing " + num(*f.rowSpacing, 6) + "\\" +
                                num(*f.colSpacing, 6) + " (must be positive)");
  if (!std::isfinite(f.slope) || !std::isfinite(f.intercept) || f.slope == 0)
    throw FileError(f.file, "invalid RescaleSlope/Intercept " + num(f.slope, 6) + "/" +
                                num(f.intercept, 6));
  const double nr = norm(*f.rowCosine), nc = norm(*f.colCosine);
  if (!(nr > 0.5) || !(nc > 0.5) || !isFinite(*f.rowCosine) || !isFinite(*f.colCosine) ||
      !isFinite(*f.position))
    throw FileError(f.file, "invalid ImageOrientationPatient/ImagePositionPatient");
  f.rowCosine = *f.rowCosine / nr;
  f.colCosine = *f.colCosine / nc;
  if (std::abs(dot(*f.rowCosine, *f.colCosine)) > 1e-2)
    throw FileError(f.file, "ImageOrientationPatient row and column directions are not "
                            "perpendicular (cosine " + num(dot(*f.rowCosine, *f.colCosine), 4) + ")");
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Every frame must share the first one's orientation and pixel spacing.
void checkSharedOrientation(const std::vector<Frame>& frames) {
  const Frame& ref = frames.front();
  for (const Frame& f : frames) {
    const Vec3 dr = *f.rowCosine - *ref.rowCosine, dc = *f.colCosine - *ref.colCosine;
    const double diff = std::max({std::abs(dr.x), std::abs(dr.y), std::abs(dr.z), std::abs(dc.x),
                                  std::abs(dc.y), std::abs(dc.z)});
    if (diff > kOrientationTol)
      throw FileError(f.file, "mixed orientations in one series: ImageOrientationPatient " +
                                  vecText(*f.rowCosine) + "\\" + vecText(*f.colCosine) + " but " +
                                  ref.file.filename().string() + " has " + vecText(*ref.rowCosine) +
                                  "\\" + vecText(*ref.colCosine));
    if (std::abs(*f.rowSpacing - *ref.rowSpacing) > kSpacingRelTol * *ref.rowSpacing ||
        std::abs(*f.colSpacing - *ref.colSpacing) > kSpacingRelTol * *ref.colSpacing)
      throw FileError(f.file, "mixed pixel spacing in one series: " + num(*f.rowSpacing, 4) + "\\" +
                                  num(*f.colSpacing, 4) + " mm but " +
                                  ref.file.filename().string() + " has " +
                                  num(*ref.rowSpacing, 4) + "\\" + num(*ref.colSpacing, 4) + " mm");
  }
}

/// Frames sorted along the normal; coincident positions grouped as duplicates of one slice.
void groupSlices(const std::vector<Frame>& frames, const Vec3& normal, SlicePlan& plan) {
  // Sort along the normal; ties keep a deterministic order (then grouped as duplicates).
  std::vector<double> along(frames.size());
  std::vector<size_t> order(frames.size());
  for (size_t i = 0; i < frames.size(); ++i) along[i] = dot(*frames[i].position, normal);
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (along[a] != along[b]) return along[a] < along[b];
    if (frames[a].instanceNumber != frames[b].instanceNumber)
      return frames[a].instanceNumber < frames[b].instanceNumber;
    if (frames[a].file != frames[b].file) return frames[a].file < frames[b].file;
    return frames[a].frameIndex < frames[b].frameIndex;
  });

  // Group coincident positions.
  for (size_t oi = 0; oi < order.size(); ++oi) {
    const Frame& f = frames[order[oi]];
    if (!plan.slices.empty() && along[order[oi]] - dot(*plan.slices.back().position, normal) <
                                    kDuplicateTolMm) {
      const Frame& kept = plan.slices.back();
      const Vec3 delta = *f.position - *kept.position;
      if (norm(delta) > kDuplicateTolMm)
        throw FileError(f.file, "conflicting slices: same position along the normal as " +
                                    kept.file.filename().string() + " but shifted in-plane by " +
                                    num(norm(delta), 3) + " mm");
      plan.duplicates.back().push_back(f);
      continue;
    }
    plan.slices.push_back(f);
    plan.duplicates.emplace_back();
  }
}

/// Each slice's offset along the normal and in-plane shift (pixels) from the first; a gantry
/// tilt (origins moving in-plane along the stack) asks for resampling with shear correction.
void measureOffsets(const Vec3& row, const Vec3& col, const Vec3& normal, double sx, double sy, SlicePlan& plan) {
  const size_t n = plan.slices.size();
  const Vec3 origin = *plan.slices.front().position;
  const double d0 = dot(origin, normal);
  double maxShiftMm = 0;
  for (const Frame& s : plan.slices) {
    const Vec3 delta = *s.position - origin;
    plan.offsets.push_back(dot(*s.position, normal) - d0);
    const Vec3 shiftMm{dot(delta, row), dot(delta, col), 0};
    plan.inPlaneShift.push_back({shiftMm.x / sx, shiftMm.y / sy, 0});
    maxShiftMm = std::max(maxShiftMm, norm(shiftMm));
  }

  // Gantry tilt: slice origins move in-plane along the stack. Resample (shear correction).
  const double shiftTolMm = std::max(0.01, 0.02 * std::min(sx, sy));
  if (n > 1 && maxShiftMm > shiftTolMm) {
    // Least-squares shear (in-plane mm per mm along the normal) through slice 0.
    double sdd = 0, sdx = 0, sdy = 0;
    for (size_t k = 0; k < n; ++k) {
      sdd += plan.offsets[k] * plan.offsets[k];
      sdx += plan.offsets[k] * plan.inPlaneShift[k].x * sx;
      sdy += plan.offsets[k] * plan.inPlaneShift[k].y * sy;
    }
    const double shear = sdd > 0 ? std::hypot(sdx, sdy) / sdd : 0;
    const double angle = std::atan(shear) * 180.0 / kPi;
    plan.warnings.push_back("slice origins shift in-plane along the stack by up to " +
                            num(maxShiftMm, 2) + " mm (gantry tilt about " + num(angle, 1) +
                            " degrees): resampled onto an orthogonal grid (shear corrected); "
                            "voxels outside the acquired slices are background");
    plan.resample = true;
  }
}

/// The output slice spacing and count: uniform stacks keep theirs; uneven ones are resampled
/// to the smallest regular gap (or the median, when a gap is suspiciously small).
double sliceSpacing(SlicePlan& plan, int64_t& count) {
  const size_t n = plan.slices.size();
  double spacing = 1.0;
  count = static_cast<int64_t>(n);
  if (n == 1) {
    const Frame& s = plan.slices.front();
    spacing = s.spacingBetweenSlices > 0 ? s.spacingBetweenSlices
              : s.sliceThickness > 0     ? s.sliceThickness
                                         : 1.0;
  } else {
    const double length = plan.offsets.back();
    const double uniform = length / static_cast<double>(n - 1);
    double maxDev = 0;
    std::vector<double> gaps;
    for (size_t k = 0; k < n; ++k) {
      maxDev = std::max(maxDev, std::abs(plan.offsets[k] - static_cast<double>(k) * uniform));
      if (k > 0) gaps.push_back(plan.offsets[k] - plan.offsets[k - 1]);
    }
    spacing = uniform;
    if (maxDev > std::max(1e-3, 0.01 * uniform)) {
      const double minGap = *std::min_element(gaps.begin(), gaps.end());
      const double maxGap = *std::max_element(gaps.begin(), gaps.end());
      const double med = median(gaps);
      const double target = minGap >= 0.5 * med ? minGap : med;
      count = static_cast<int64_t>(std::llround(length / target)) + 1;
      spacing = length / static_cast<double>(count - 1);
      const auto wide = std::count_if(gaps.begin(), gaps.end(),
                                      [&](double g) { return g > 1.5 * target; });
      std::string why = "uneven slice spacing: gaps between slices range " + num(minGap, 3) +
                        ".." + num(maxGap, 3) + " mm";
      if (wide > 0) {
        why += " (" + std::to_string(wide) + " gap" + (wide > 1 ? "s" : "") +
               " wider than 1.5x " + num(target, 3) + " mm: missing slices?";
        // Name where (the first few): the slice files on either side of each gap.
        int named = 0;
        for (size_t k = 1; k < n && named < 3; ++k)
          if (gaps[k - 1] > 1.5 * target) {
            why += std::string(named++ ? ";" : "") + " between " + plan.slices[k - 1].file.filename().string() +
                   " and " + plan.slices[k].file.filename().string() + " at " + num(plan.offsets[k - 1], 3) +
                   ".." + num(plan.offsets[k], 3) + " mm, interpolated from them";
          }
        if (wide > named) why += "; ...";
        why += ")";
      }
      plan.warnings.push_back(why + "; resampled " + std::to_string(n) + " slices to " +
                              std::to_string(count) + " slices " + num(spacing, 3) +
                              " mm apart by linear interpolation along the slice normal");
      plan.resample = true;
    }
  }
  if (!(spacing > 0) || !std::isfinite(spacing))
    throw FileError(plan.slices.front().file, "invalid slice spacing " + num(spacing, 6));
  return spacing;
}

}  // namespace

SlicePlan planSlices(std::vector<Frame> frames, int64_t rows, int64_t columns) {
  if (frames.empty()) throw Error("DICOM series has no images");
  SlicePlan plan;
  const bool single = frames.size() == 1;
  for (Frame& f : frames) checkFrame(f, single, plan.warnings);
  checkSharedOrientation(frames);
  const Frame& ref = frames.front();
  const Vec3 row = *ref.rowCosine, col = *ref.colCosine;
  const Vec3 normal = normalized(cross(row, col));
  const double sx = *ref.colSpacing, sy = *ref.rowSpacing;  // PixelSpacing is [row, column]
  groupSlices(frames, normal, plan);
  measureOffsets(row, col, normal, sx, sy, plan);
  int64_t count = 0;
  const double spacing = sliceSpacing(plan, count);
  plan.geometry.dims = {columns, rows, count};
  plan.geometry.spacing = {sx, sy, spacing};
  plan.geometry.origin = *plan.slices.front().position;
  plan.geometry.direction = Mat3::fromColumns(row, col, normal);
  return plan;
}

namespace {

/// Bilinear sample of one slice at continuous pixel (u, v); background outside (matching
/// Volume::sampleLinear: neighbours outside the slice take the background value).
double sampleSlice(const int16_t* s, int64_t nx, int64_t ny, double u, double v, double bg) {
  const double fu = std::floor(u), fv = std::floor(v);
  const auto i0 = static_cast<int64_t>(fu), j0 = static_cast<int64_t>(fv);
  const double tu = u - fu, tv = v - fv;
  auto at = [&](int64_t i, int64_t j) {
    return (i >= 0 && j >= 0 && i < nx && j < ny) ? static_cast<double>(s[j * nx + i]) : bg;
  };
  const double a = at(i0, j0) + tu * (at(i0 + 1, j0) - at(i0, j0));
  const double b = at(i0, j0 + 1) + tu * (at(i0 + 1, j0 + 1) - at(i0, j0 + 1));
  return a + tv * (b - a);
}

int16_t toI16(double v) {
  return static_cast<int16_t>(std::clamp(std::round(v), -32768.0, 32767.0));
}

}  // namespace

void resampleStack(const SlicePlan& plan, const std::vector<int16_t>& stack, VolumeI16& out,
                   double background, Progress* progress) {
  const Dims d = plan.geometry.dims;
  const int64_t nx = d.x, ny = d.y, plane = nx * ny;
  const auto n = static_cast<int64_t>(plan.slices.size());
  const double dz = plan.geometry.spacing.z;
  const double eps = 1e-4;  // mm: an output slice this close to an input slice copies it
  if (progress) progress->begin("resampling DICOM slices", static_cast<uint64_t>(d.z));
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      const double z = static_cast<double>(k) * dz;
      // Bracketing input slices a <= z < b.
      const auto it = std::upper_bound(plan.offsets.begin(), plan.offsets.end(), z + eps);
      int64_t a = std::clamp<int64_t>(static_cast<int64_t>(it - plan.offsets.begin()) - 1, 0, n - 1);
      double t = 0;
      if (a + 1 < n && std::abs(z - plan.offsets[static_cast<size_t>(a)]) > eps)
        t = (z - plan.offsets[static_cast<size_t>(a)]) /
            (plan.offsets[static_cast<size_t>(a + 1)] - plan.offsets[static_cast<size_t>(a)]);
      const int64_t b = std::min(a + 1, n - 1);
      const int16_t* sa = stack.data() + a * plane;
      const int16_t* sb = stack.data() + b * plane;
      const Vec3 sha = plan.inPlaneShift[static_cast<size_t>(a)];
      const Vec3 shb = plan.inPlaneShift[static_cast<size_t>(b)];
      const bool shifted = norm(sha) > 1e-6 || norm(shb) > 1e-6;
      int16_t* dst = out.data() + k * plane;
      for (int64_t j = 0; j < ny; ++j) {
        for (int64_t i = 0; i < nx; ++i) {
          double va, vb;
          if (shifted) {
            va = sampleSlice(sa, nx, ny, static_cast<double>(i) - sha.x,
                             static_cast<double>(j) - sha.y, background);
            vb = t > 0 ? sampleSlice(sb, nx, ny, static_cast<double>(i) - shb.x,
                                     static_cast<double>(j) - shb.y, background)
                       : va;
          } else {
            va = sa[j * nx + i];
            vb = sb[j * nx + i];
          }
          dst[j * nx + i] = t > 0 ? toI16(va + t * (vb - va)) : toI16(va);
        }
      }
      if (progress) progress->advance();
    }
  });
  if (progress) progress->end();
}

namespace {

/// Normalised cross-correlation of slice `a` moved by (dx, dy) pixels against `b` (b(i, j) with
/// a(i - dx, j - dy)) over a lattice of every `step`-th pixel where both exist; b may be a
/// float image (the neighbours' mean). -1 when there is nothing to compare or no contrast.
template <class B>
double correlation(const int16_t* a, const B* b, int64_t nx, int64_t ny, int64_t dx, int64_t dy, int64_t step) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  int64_t n = 0;
  for (int64_t j = std::max<int64_t>(0, dy); j < std::min(ny, ny + dy); j += step)
    for (int64_t i = std::max<int64_t>(0, dx); i < std::min(nx, nx + dx); i += step) {
      const double x = a[(j - dy) * nx + (i - dx)], y = b[j * nx + i];
      sa += x; sb += y; saa += x * x; sbb += y * y; sab += x * y;
      ++n;
    }
  if (n < 16) return -1;
  const double va = saa - sa * sa / double(n), vb = sbb - sb * sb / double(n);
  if (va <= 1e-9 || vb <= 1e-9) return -1;
  return (sab - sa * sb / double(n)) / std::sqrt(va * vb);
}

}  // namespace

int64_t repairMisregisteredSlices(const SlicePlan& plan, int16_t* stack, int64_t nx, int64_t ny,
                                  std::vector<std::string>& warnings) {
  const auto n = static_cast<int64_t>(plan.slices.size());
  if (n < 3 || nx < 8 || ny < 8) return 0;
  const int64_t plane = nx * ny;
  // About 128 x 128 samples per slice whatever its size: a shift of a whole slice shows at that scale.
  const int64_t step = std::max<int64_t>(1, std::min(nx, ny) / 128);
  auto slice = [&](int64_t k) { return stack + k * plane; };
  // Each interior slice against its two neighbours, and the neighbours against each other.
  std::vector<std::array<double, 3>> c(static_cast<size_t>(n), {1, 1, 1});
  parallelFor(n - 2, [&](int64_t t0, int64_t t1) {
    for (int64_t k = t0 + 1; k < t1 + 1; ++k)
      c[static_cast<size_t>(k)] = {correlation(slice(k), slice(k - 1), nx, ny, 0, 0, step),
                                   correlation(slice(k), slice(k + 1), nx, ny, 0, 0, step),
                                   correlation(slice(k - 1), slice(k + 1), nx, ny, 0, 0, step)};
  });
  int64_t repaired = 0;
  std::vector<float> mean(static_cast<size_t>(plane));
  for (int64_t k = 1; k + 1 < n; ++k) {
    const auto [prev, next, across] = c[static_cast<size_t>(k)];
    // The neighbours agree with each other, the slice with neither: a drop of at least 0.1 and
    // three times the neighbours' own distance from 1 (an ordinary slice correlates better with
    // its neighbours than they do with each other two spacings apart).
    const double best = std::max(prev, next);
    if (!(across > 0.5 && best < across - 0.1 && 1 - best > 3 * (1 - across))) continue;
    // Does an in-plane shift explain it? Search +-1/16 of the slice on the lattice, then refine.
    const int64_t prevOff = (k - 1) * plane, nextOff = (k + 1) * plane;
    for (int64_t p = 0; p < plane; ++p) mean[static_cast<size_t>(p)] = 0.5f * (float(stack[prevOff + p]) + float(stack[nextOff + p]));
    const int64_t reach = std::max<int64_t>(2, std::max(nx, ny) / 16);
    double bestC = -2;
    int64_t bx = 0, by = 0;
    for (int64_t dy = -reach; dy <= reach; dy += step)
      for (int64_t dx = -reach; dx <= reach; dx += step)
        if (const double r = correlation(slice(k), mean.data(), nx, ny, dx, dy, step); r > bestC) { bestC = r; bx = dx; by = dy; }
    const int64_t cx = bx, cy = by;
    for (int64_t dy = cy - step; dy <= cy + step; ++dy)
      for (int64_t dx = cx - step; dx <= cx + step; ++dx)
        if (const double r = correlation(slice(k), mean.data(), nx, ny, dx, dy, step); r > bestC) { bestC = r; bx = dx; by = dy; }
    if ((bx == 0 && by == 0) || bestC < across - 0.05) continue;  // not a shift: leave it (anatomy, artefact)
    const double o0 = plan.offsets[static_cast<size_t>(k - 1)], o1 = plan.offsets[static_cast<size_t>(k)],
                 o2 = plan.offsets[static_cast<size_t>(k + 1)];
    const double t = o2 > o0 ? (o1 - o0) / (o2 - o0) : 0.5;
    int16_t* dst = slice(k);
    for (int64_t p = 0; p < plane; ++p) {
      const double v = double(stack[prevOff + p]) + t * (double(stack[nextOff + p]) - double(stack[prevOff + p]));
      dst[p] = static_cast<int16_t>(std::clamp(std::round(v), -32768.0, 32767.0));
    }
    ++repaired;
    warnings.push_back("slice " + std::to_string(k + 1) + " of " + std::to_string(n) + " (" +
                       plan.slices[static_cast<size_t>(k)].file.filename().string() + ", " + num(o1, 3) +
                       " mm) is mis-registered: shifted by (" + std::to_string(-bx) + ", " + std::to_string(-by) +
                       ") pixels against both neighbours (correlation " + num(prev, 2) + " / " + num(next, 2) +
                       " with them, " + num(across, 2) + " between them, " + num(bestC, 2) +
                       " shifted back); replaced by interpolating its neighbours (--no-slice-repair keeps it)");
  }
  return repaired;
}

}  // namespace vellum::io::detail::dicom
