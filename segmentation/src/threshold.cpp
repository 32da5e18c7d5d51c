#include "vellum/segmentation/threshold.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "neighbors.hpp"

namespace vellum::segmentation {

HuInterval presetInterval(Preset p) {
  switch (p) {
    case Preset::Bone: return {700, 3071};
    case Preset::WholeBone: return {550, 3071};
    case Preset::SoftTissue: return {-500, 300};
    case Preset::SkinAir: return {-500, 3071};
    case Preset::Fat: return {-190, -30};
    case Preset::Lung: return {-950, -500};
  }
  return {};
}

const params::EnumTable<Preset>& presets() {
  static const params::EnumTable<Preset> t{
      "preset", {"bone", "soft-tissue", "skin-air", "fat", "lung", "whole-bone"},
      {{"soft", Preset::SoftTissue}, {"skin", Preset::SkinAir}}};
  return t;
}

std::vector<Preset> allPresets() {
  return {Preset::Bone, Preset::WholeBone, Preset::SoftTissue, Preset::SkinAir, Preset::Fat, Preset::Lung};
}


Mask threshold(const VolumeI16& ct, const HuInterval& interval) {
  Mask out(ct.geometry(), 0, 0.0);
  const int16_t* src = ct.data();
  uint8_t* dst = out.data();
  // Integer bounds make the inner loop branch-free and exact for int16 data.
  const double lo = std::ceil(interval.lower), hi = std::floor(interval.upper);
  const int lower = static_cast<int>(std::clamp(lo, -40000.0, 40000.0));
  const int upper = static_cast<int>(std::clamp(hi, -40000.0, 40000.0));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ct.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i)
                        dst[i] = static_cast<uint8_t>(src[i] >= lower && src[i] <= upper);
                    });
  return out;
}

Histogram histogram(const VolumeI16& ct, const HistogramParams& p) {
  if (p.bins < 2 || p.bins > (1 << 20)) throw Error("histogram: bins must be in [2, 1048576]");
  if (!(p.upperHu > p.lowerHu)) throw Error("histogram: upper HU must exceed lower HU");
  Histogram h;
  h.minValue = p.lowerHu;
  h.binWidth = (p.upperHu - p.lowerHu) / p.bins;
  const size_t bins = static_cast<size_t>(p.bins);
  const int16_t* src = ct.data();
  h.counts = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, ct.size(), 1 << 18), std::vector<uint64_t>(bins, 0),
      [&](const tbb::blocked_range<size_t>& r, std::vector<uint64_t> acc) {
        for (size_t i = r.begin(); i < r.end(); ++i) {
          const double v = src[i];
          if (v < p.lowerHu || v > p.upperHu) continue;
          const auto b = static_cast<size_t>((v - p.lowerHu) / h.binWidth);
          ++acc[std::min(b, bins - 1)];
        }
        return acc;
      },
      [](std::vector<uint64_t> a, const std::vector<uint64_t>& b) {
        for (size_t i = 0; i < a.size(); ++i) a[i] += b[i];
        return a;
      });
  return h;
}

std::vector<double> multiOtsuThresholds(const Histogram& h, int classes) {
  if (classes < 2 || classes > 8) throw Error("multi-Otsu: classes must be in [2, 8]");
  const size_t L = h.counts.size();
  const auto nonEmpty = std::count_if(h.counts.begin(), h.counts.end(), [](uint64_t c) { return c > 0; });
  if (nonEmpty < classes)
    throw Error("multi-Otsu: the histogram has " + std::to_string(nonEmpty) +
                " non-empty bins, fewer than the " + std::to_string(classes) + " classes asked for");
  // Prefix sums of weight and first moment; a class over bins [a, b) contributes
  // (S_b - S_a)² / (W_b - W_a) to the between-class variance (up to constants).
  std::vector<double> W(L + 1, 0), S(L + 1, 0);
  for (size_t b = 0; b < L; ++b) {
    W[b + 1] = W[b] + static_cast<double>(h.counts[b]);
    S[b + 1] = S[b] + static_cast<double>(h.counts[b]) * h.binCenter(b);
  }
  const double ninf = -std::numeric_limits<double>::infinity();
  auto cost = [&](size_t a, size_t b) {
    const double w = W[b] - W[a];
    if (w <= 0) return ninf;  // every class must hold voxels
    const double s = S[b] - S[a];
    return s * s / w;
  };
  const size_t C = static_cast<size_t>(classes);
  // best[c][b]: best score of splitting bins [0, b) into c+1 classes; arg = start of the last.
  std::vector<std::vector<double>> best(C, std::vector<double>(L + 1, ninf));
  std::vector<std::vector<size_t>> arg(C, std::vector<size_t>(L + 1, 0));
  for (size_t b = 1; b <= L; ++b) best[0][b] = cost(0, b);
  for (size_t c = 1; c < C; ++c)
    for (size_t b = c + 1; b <= L; ++b)
      for (size_t a = c; a < b; ++a) {
        if (best[c - 1][a] == ninf) continue;
        const double v = best[c - 1][a] + cost(a, b);
        if (v > best[c][b]) { best[c][b] = v; arg[c][b] = a; }
      }
  std::vector<double> t(C - 1);
  size_t b = L;
  for (size_t c = C - 1; c >= 1; --c) {
    const size_t a = arg[c][b];
    t[c - 1] = h.binEdge(a);
    b = a;
  }
  return t;
}

double otsuThreshold(const Histogram& h) { return multiOtsuThresholds(h, 2).front(); }

VolumeU16 classify(const VolumeI16& ct, const std::vector<double>& thresholds) {
  if (!std::is_sorted(thresholds.begin(), thresholds.end()))
    throw Error("classify: thresholds must be increasing");
  VolumeU16 out(ct.geometry(), 0, 0.0);
  const int16_t* src = ct.data();
  uint16_t* dst = out.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ct.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) {
                        const double v = src[i];
                        uint16_t c = 1;
                        for (double t : thresholds) c += v >= t;
                        dst[i] = c;
                      }
                    });
  return out;
}

Mask hysteresis(const VolumeI16& ct, const HysteresisParams& p) {
  Mask out(ct.geometry(), 0, 0.0);
  const int16_t* src = ct.data();
  std::vector<int64_t> starts;
  for (size_t i = 0; i < ct.size(); ++i)
    if (p.strong.contains(src[i]) && p.weak.contains(src[i])) starts.push_back(static_cast<int64_t>(i));
  detail::floodFill(ct.dims(), starts, p.connectivity,
                    [&](int64_t q) { return p.weak.contains(src[q]); }, out.data());
  return out;
}

const params::Table<HysteresisParams>& hysteresisParamsTable() {
  using H = HysteresisParams;
  static const params::Table<H> table{
      params::real<H>("strong_lower", params::nested(&H::strong, &HuInterval::lower),
                      {"Strong threshold", "voxels at or above it seed the mask", "HU", -1024, 3071}),
      params::real<H>("strong_upper", params::nested(&H::strong, &HuInterval::upper),
                      {"Strong upper", "upper end of the seeding interval", "HU", -1024, 3071}),
      params::real<H>("weak_lower", params::nested(&H::weak, &HuInterval::lower),
                      {"Weak threshold", "voxels at or above it join when connected to a seed", "HU", -1024, 3071}),
      params::real<H>("weak_upper", params::nested(&H::weak, &HuInterval::upper),
                      {"Weak upper", "upper end of the joining interval", "HU", -1024, 3071}),
  };
  return table;
}

}  // namespace vellum::segmentation
