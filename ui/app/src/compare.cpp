// `vellum compare` and the QA checks: label maps through segmentation/metrics (Dice, HD95 and
// ASSD on the one exact distance transform, in mm), images through OpenCV, volumes voxel by voxel.
#include "vellum/app/compare.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "vellum/core/error.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/segmentation/mask.hpp"
#include "vellum/segmentation/metrics.hpp"

namespace vellum::app {
namespace fs = std::filesystem;
namespace seg = vellum::segmentation;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// JSON has no infinity: an infinite distance (one side empty) or PSNR (identical) is null.
nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

std::string fmt(double v, int precision = 4) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

bool isImagePath(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" || e == ".tiff" || e == ".bmp" || e == ".webp";
}

cv::Mat luminance(const RgbaImage& im) {
  const cv::Mat rgba(im.height, im.width, CV_8UC4, const_cast<uint8_t*>(im.pixels.data()));
  cv::Mat grey, out;
  cv::cvtColor(rgba, grey, cv::COLOR_RGBA2GRAY);  // 0.299 R + 0.587 G + 0.114 B
  grey.convertTo(out, CV_64F);
  return out;
}

/// Colours `t` in [0, 1] with OpenCV's perceptually ordered "inferno" map.
std::array<uint8_t, 3> inferno(double t) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
    cv::Mat c;
    cv::applyColorMap(ramp, c, cv::COLORMAP_INFERNO);
    return c;
  }();
  const int i = std::clamp(static_cast<int>(std::lround(t * 255.0)), 0, 255);
  const cv::Vec3b bgr = lut.at<cv::Vec3b>(0, i);
  return {bgr[2], bgr[1], bgr[0]};
}

void put(RgbaImage& im, int x, int y, std::array<uint8_t, 3> c) {
  uint8_t* p = im.at(x, y);
  p[0] = c[0];
  p[1] = c[1];
  p[2] = c[2];
  p[3] = 255;
}

nlohmann::json describeVolume(const fs::path& path, const io::LoadedVolume& lv) {
  const Geometry& g = geometryOf(lv.volume);
  nlohmann::json j{{"path", path.string()},
                   {"format", lv.format},
                   {"type", voxelTypeName(voxelTypeOf(lv.volume))},
                   {"dims", {g.dims.x, g.dims.y, g.dims.z}},
                   {"spacing_mm", {g.spacing.x, g.spacing.y, g.spacing.z}},
                   {"origin_mm", {g.origin.x, g.origin.y, g.origin.z}}};
  if (!lv.seriesUid.empty()) j["series_uid"] = lv.seriesUid;
  if (!lv.warnings.empty()) j["warnings"] = lv.warnings;
  return j;
}

bool unsignedIntegers(const AnyVolume& v) {
  const VoxelType t = voxelTypeOf(v);
  return t == VoxelType::UInt8 || t == VoxelType::UInt16;
}

/// Geometry problems that make two grids incomparable voxel by voxel ("" when they match).
std::string geometryDifference(const Geometry& a, const Geometry& b) {
  if (!(a.dims == b.dims)) return "grids differ: " + a.dims.str() + " vs " + b.dims.str();
  if (!a.approxEqual(b, 1e-4)) return "grids differ in spacing, origin or direction";
  return {};
}

// ---- label maps ------------------------------------------------------------------------

nlohmann::json metricsJson(const seg::SegmentMetrics& m) {
  return {{"id", m.id},
          {"dice", m.dice},
          {"jaccard", m.jaccard},
          {"hd95_mm", num(m.hd95Mm)},
          {"assd_mm", num(m.meanSurfaceDistanceMm)},
          {"hausdorff_mm", num(m.hausdorffMm)},
          {"voxels_a", m.voxels},
          {"voxels_b", m.truthVoxels},
          {"volume_a_mm3", m.volumeMm3},
          {"volume_b_mm3", m.truthVolumeMm3},
          {"volume_difference_mm3", m.volumeDifferenceMm3},
          {"volume_difference_percent", m.volumeDifferencePercent}};
}

/// The axial slices of A and B with the most voxels whose ids differ (the middle one when
/// none do), coloured by the label colours, and where they differ: red A only, blue B only,
/// magenta different ids, grey agreement.
void labelPictures(const VolumeU16& a, const VolumeU16& b, CompareResult& r) {
  const Dims d = a.dims();
  std::vector<int64_t> perSlice(static_cast<size_t>(d.z), 0);
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) perSlice[static_cast<size_t>(k)] += a(i, j, k) != b(i, j, k);
  });
  const auto best = std::max_element(perSlice.begin(), perSlice.end());
  const int64_t k = *best > 0 ? best - perSlice.begin() : d.z / 2;
  const int w = static_cast<int>(d.x), h = static_cast<int>(d.y);
  r.pictureA = RgbaImage(w, h);
  r.pictureB = RgbaImage(w, h);
  r.heatmap = RgbaImage(w, h);
  auto colour = [](uint16_t id) { return id ? defaultLabelColor(id) : std::array<uint8_t, 3>{0, 0, 0}; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint16_t va = a(x, y, k), vb = b(x, y, k);
      put(r.pictureA, x, y, colour(va));
      put(r.pictureB, x, y, colour(vb));
      std::array<uint8_t, 3> c{0, 0, 0};
      if (va == vb) c = va ? std::array<uint8_t, 3>{90, 90, 90} : c;
      else if (!vb) c = {230, 40, 40};
      else if (!va) c = {40, 90, 240};
      else c = {220, 40, 220};
      put(r.heatmap, x, y, c);
    }
  r.report["picture_slice"] = k;
}

void compareLabelMaps(const VolumeU16& a, const VolumeU16& b, const CompareRequest& q, CompareResult& r) {
  const CompareTolerances& t = q.tolerances;
  std::vector<seg::SegmentMetrics> rows;
  if (!q.aIds.empty() || !q.bIds.empty()) {
    const std::vector<uint16_t> ai = q.aIds.empty() ? q.bIds : q.aIds, bi = q.bIds.empty() ? ai : q.bIds;
    auto in = [](const std::vector<uint16_t>& ids) {
      return [&ids](uint16_t v) { return v != 0 && std::find(ids.begin(), ids.end(), v) != ids.end(); };
    };
    const seg::Mask ma = seg::maskFromIds(a, in(ai)), mb = seg::maskFromIds(b, in(bi));
    seg::SegmentMetrics m = seg::compareMasks(ma, mb);
    m.id = 0;
    rows.push_back(m);
    r.report["a_ids"] = ai;
    r.report["b_ids"] = bi;
    // The pictures show the two masks compared (as label 1), not the whole maps.
    labelPictures(convertVolume<uint16_t>(AnyVolume(ma)), convertVolume<uint16_t>(AnyVolume(mb)), r);
  } else {
    rows = seg::compareLabels(a, b, q.ids);
    labelPictures(a, b, r);
  }
  nlohmann::json list = nlohmann::json::array();
  for (const auto& m : rows) {
    list.push_back(metricsJson(m));
    const std::string who = m.id ? "label " + std::to_string(m.id) : std::string("the id groups");
    if (m.dice < t.minDice) r.failures.push_back(who + ": Dice " + fmt(m.dice, 6) + " < " + fmt(t.minDice, 6));
    if (t.maxHd95Mm && !(m.hd95Mm <= *t.maxHd95Mm))
      r.failures.push_back(who + ": HD95 " + fmt(m.hd95Mm) + " mm > " + fmt(*t.maxHd95Mm) + " mm");
    if (t.maxAssdMm && !(m.meanSurfaceDistanceMm <= *t.maxAssdMm))
      r.failures.push_back(who + ": ASSD " + fmt(m.meanSurfaceDistanceMm) + " mm > " + fmt(*t.maxAssdMm) + " mm");
  }
  r.report["labels"] = list;
}

// ---- grey volumes ----------------------------------------------------------------------

struct VoxelDiff {
  double max = 0, sum = 0;
  int64_t differing = 0;
  size_t argmax = 0;
};

template <class A, class B>
VoxelDiff diffVoxels(const Volume<A>& a, const Volume<B>& b, double tolerance) {
  const A* pa = a.data();
  const B* pb = b.data();
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, a.size(), 1 << 16), VoxelDiff{},
      [&](const tbb::blocked_range<size_t>& range, VoxelDiff acc) {
        for (size_t i = range.begin(); i < range.end(); ++i) {
          const double d = std::abs(static_cast<double>(pa[i]) - static_cast<double>(pb[i]));
          acc.sum += d;
          acc.differing += d > tolerance;
          if (d > acc.max) {
            acc.max = d;
            acc.argmax = i;
          }
        }
        return acc;
      },
      [](VoxelDiff x, const VoxelDiff& y) {
        x.sum += y.sum;
        x.differing += y.differing;
        if (y.max > x.max || (y.max == x.max && y.argmax < x.argmax)) {
          x.max = y.max;
          x.argmax = y.argmax;
        }
        return x;
      });
}

/// The axial slice through the largest difference: A and B in grey (CT: window -1000..1000 HU;
/// otherwise A's value range), |A-B| in "inferno" on a square-root scale up to the slice's
/// largest difference (so that small differences beside one large one still show) over A dimmed.
void volumePictures(const AnyVolume& av, const AnyVolume& bv, int64_t k, CompareResult& r) {
  const bool ct = voxelTypeOf(av) == VoxelType::Int16;
  const auto [lo, hi] = ct ? std::pair<double, double>{-1000.0, 1000.0}
                           : std::visit([](const auto& v) { return v.valueRange(); }, av);
  const double span = hi > lo ? hi - lo : 1.0;
  const Dims d = geometryOf(av).dims;
  // Only this slice is read (a copy of whole volumes as float would double the memory).
  auto at = [k](const AnyVolume& v) {
    return [&v, k](int x, int y) { return std::visit([&](const auto& w) { return double(w(x, y, k)); }, v); };
  };
  const auto a = at(av), b = at(bv);
  const int w = static_cast<int>(d.x), h = static_cast<int>(d.y);
  r.pictureA = RgbaImage(w, h);
  r.pictureB = RgbaImage(w, h);
  r.heatmap = RgbaImage(w, h);
  double sliceMax = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) sliceMax = std::max(sliceMax, std::abs(a(x, y) - b(x, y)));
  auto grey = [&](double v) {
    const auto g = static_cast<uint8_t>(std::clamp((v - lo) / span * 255.0, 0.0, 255.0));
    return std::array<uint8_t, 3>{g, g, g};
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      put(r.pictureA, x, y, grey(a(x, y)));
      put(r.pictureB, x, y, grey(b(x, y)));
      const double diff = std::abs(a(x, y) - b(x, y));
      // Unchanged voxels as A's grey at a third of its brightness (as the image heat map).
      const auto g = static_cast<uint8_t>(grey(a(x, y))[0] / 3);
      put(r.heatmap, x, y, diff > 0 ? inferno(0.25 + 0.75 * std::sqrt(diff / sliceMax)) : std::array<uint8_t, 3>{g, g, g});
    }
  r.report["picture_slice"] = k;
}

void compareGreyVolumes(const AnyVolume& a, const AnyVolume& b, const CompareRequest& q, CompareResult& r) {
  const Geometry &ga = geometryOf(a), &gb = geometryOf(b);
  nlohmann::json v{{"dims_equal", ga.dims == gb.dims}, {"geometry_equal", ga.approxEqual(gb, 1e-4)},
                   {"types_equal", voxelTypeOf(a) == voxelTypeOf(b)}};
  if (!(ga.dims == gb.dims)) {
    r.failures.push_back(geometryDifference(ga, gb));
    r.report["volume"] = v;
    return;
  }
  if (!v["geometry_equal"].get<bool>()) r.failures.push_back(geometryDifference(ga, gb));
  const CompareTolerances& t = q.tolerances;
  const VoxelDiff d = std::visit([&](const auto& x, const auto& y) { return diffVoxels(x, y, t.tolerance); }, a, b);
  const double n = static_cast<double>(ga.dims.voxelCount());
  const int64_t i = static_cast<int64_t>(d.argmax % static_cast<size_t>(ga.dims.x));
  const int64_t j = static_cast<int64_t>(d.argmax / static_cast<size_t>(ga.dims.x) % static_cast<size_t>(ga.dims.y));
  const int64_t k = static_cast<int64_t>(d.argmax / static_cast<size_t>(ga.dims.x * ga.dims.y));
  const Vec3 at = ga.indexToPhysical({double(i), double(j), double(k)});
  v["max_abs_difference"] = d.max;
  v["mean_abs_difference"] = n > 0 ? d.sum / n : 0.0;
  v["differing_voxels"] = d.differing;
  v["differing_percent"] = n > 0 ? 100.0 * static_cast<double>(d.differing) / n : 0.0;
  v["max_at_index"] = {i, j, k};
  v["max_at_mm"] = {at.x, at.y, at.z};
  v["unit"] = voxelTypeOf(a) == VoxelType::Int16 ? "HU" : "";
  r.report["volume"] = v;
  const double pct = v["differing_percent"].get<double>();
  if (pct > t.maxDifferingPercent)
    r.failures.push_back(std::to_string(d.differing) + " voxels (" + fmt(pct) + "%) differ by more than " +
                         fmt(t.tolerance) + " (largest " + fmt(d.max) + ")");
  volumePictures(a, b, k, r);
}

}  // namespace

const params::EnumTable<CompareKind>& compareKinds() {
  static const params::EnumTable<CompareKind> t{"--kind", {"auto", "labels", "image", "volume"}};
  return t;
}

const params::Table<CompareTolerances>& compareTolerancesTable() {
  using T = CompareTolerances;
  using params::real;
  static const params::Table<T> t{
      real<T>("min_dice", &T::minDice,
              {"Minimum Dice", "labels: every id's Dice must be at least this", "", 0, 1}),
      real<T>("max_hd95", &T::maxHd95Mm,
              {"Maximum HD95", "labels: every id's 95th-percentile surface distance must be at most this (unset: not checked)", "mm", 0, 1e6}),
      real<T>("max_assd", &T::maxAssdMm,
              {"Maximum ASSD", "labels: every id's average symmetric surface distance must be at most this (unset: not checked)", "mm", 0, 1e6}),
      real<T>("tolerance", &T::tolerance,
              {"Tolerance", "images: difference allowed per channel (0..255); volumes: per voxel, in the volume's unit (HU for CT)", "", 0, 1e9}),
      real<T>("max_differing_percent", &T::maxDifferingPercent,
              {"Differing share", "images / volumes: share of pixels / voxels allowed to differ by more than the tolerance", "%", 0, 100}),
      real<T>("min_psnr", &T::minPsnrDb,
              {"Minimum PSNR", "images: peak signal-to-noise ratio of the RGB planes at least this (unset: not checked)", "dB", 0, 1000}),
      real<T>("min_ssim", &T::minSsim,
              {"Minimum SSIM", "images: mean structural similarity of the luminance at least this (unset: not checked)", "", -1, 1}),
      real<T>("percentile", &T::percentile,
              {"Percentile", "images: the percentile of the pixel differences reported", "%", 0, 100}),
  };
  return t;
}

double meanSsim(const RgbaImage& a, const RgbaImage& b) {
  if (a.width != b.width || a.height != b.height) throw Error("SSIM: image sizes differ");
  const cv::Mat x = luminance(a), y = luminance(b);
  const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
  auto blur = [](const cv::Mat& m) {
    cv::Mat out;
    cv::GaussianBlur(m, out, cv::Size(11, 11), 1.5, 1.5, cv::BORDER_REFLECT);
    return out;
  };
  const cv::Mat mx = blur(x), my = blur(y);
  const cv::Mat mx2 = mx.mul(mx), my2 = my.mul(my), mxy = mx.mul(my);
  const cv::Mat sx2 = blur(x.mul(x)) - mx2, sy2 = blur(y.mul(y)) - my2, sxy = blur(x.mul(y)) - mxy;
  cv::Mat num = (2 * mxy + c1).mul(2 * sxy + c2), den = (mx2 + my2 + c1).mul(sx2 + sy2 + c2), map;
  cv::divide(num, den, map);
  return cv::mean(map)[0];
}

ImageDiff diffImages(const RgbaImage& a, const RgbaImage& b, const CompareTolerances& t) {
  if (a.width != b.width || a.height != b.height)
    throw Error("image sizes differ: " + std::to_string(a.width) + "x" + std::to_string(a.height) + " vs " +
                std::to_string(b.width) + "x" + std::to_string(b.height));
  ImageDiff r;
  const size_t n = static_cast<size_t>(a.width) * static_cast<size_t>(a.height);
  std::array<int64_t, 256> histogram{};  // of per-pixel differences: exact percentiles, 0..255
  std::vector<uint8_t> diff(n);
  double squares = 0;
  for (size_t p = 0; p < n; ++p) {
    const uint8_t* pa = a.pixels.data() + 4 * p;
    const uint8_t* pb = b.pixels.data() + 4 * p;
    int d = 0;
    for (int c = 0; c < 4; ++c) {
      const int e = std::abs(int(pa[c]) - int(pb[c]));
      d = std::max(d, e);
      if (c < 3) squares += double(e) * e;
    }
    diff[p] = static_cast<uint8_t>(d);
    ++histogram[static_cast<size_t>(d)];
  }
  double sum = 0;
  for (int v = 0; v < 256; ++v) {
    sum += double(v) * double(histogram[static_cast<size_t>(v)]);
    if (histogram[static_cast<size_t>(v)]) r.maxDifference = v;
    if (v > t.tolerance) r.differingPixels += histogram[static_cast<size_t>(v)];
  }
  r.meanDifference = n ? sum / double(n) : 0.0;
  r.differingPercent = n ? 100.0 * double(r.differingPixels) / double(n) : 0.0;
  // Nearest rank: the smallest difference with at least `percentile`% of pixels at or below it.
  const auto rank = static_cast<int64_t>(std::ceil(t.percentile / 100.0 * double(n)));
  int64_t seen = 0;
  for (int v = 0; v < 256; ++v) {
    seen += histogram[static_cast<size_t>(v)];
    if (seen >= std::max<int64_t>(rank, 1)) {
      r.percentileDifference = v;
      break;
    }
  }
  const double mse = n ? squares / (3.0 * double(n)) : 0.0;
  r.psnrDb = mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : kInf;
  r.ssim = meanSsim(a, b);
  // Heat map: unchanged pixels as the first image's grey at a third of its brightness, changed
  // ones in "inferno" scaled to the largest difference (never darker than a quarter, so that a
  // one-level difference still shows).
  r.heatmap = RgbaImage(a.width, a.height);
  for (size_t p = 0; p < n; ++p) {
    const int x = static_cast<int>(p % static_cast<size_t>(a.width)), y = static_cast<int>(p / static_cast<size_t>(a.width));
    const uint8_t* pa = a.pixels.data() + 4 * p;
    if (diff[p] == 0) {
      const auto g = static_cast<uint8_t>((0.299 * pa[0] + 0.587 * pa[1] + 0.114 * pa[2]) / 3.0);
      put(r.heatmap, x, y, {g, g, g});
    } else {
      put(r.heatmap, x, y, inferno(0.25 + 0.75 * diff[p] / r.maxDifference));
    }
  }
  return r;
}

CompareResult compareFiles(const CompareRequest& q) {
  CompareResult r;
  r.kind = q.kind;
  const bool imageA = isImagePath(q.a), imageB = isImagePath(q.b);
  if (r.kind == CompareKind::Auto && (imageA || imageB)) r.kind = CompareKind::Image;
  r.report = {{"tool", "vellum compare"},
              {"vellum_version", vellumVersion()},
              {"tolerances", params::toJson(compareTolerancesTable(), q.tolerances)}};
  if (r.kind == CompareKind::Image) {
    const RgbaImage a = io::loadImage(q.a), b = io::loadImage(q.b);
    r.report["a"] = {{"path", q.a.string()}, {"width", a.width}, {"height", a.height}};
    r.report["b"] = {{"path", q.b.string()}, {"width", b.width}, {"height", b.height}};
    if (a.width != b.width || a.height != b.height) {
      r.failures.push_back("image sizes differ: " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                           " vs " + std::to_string(b.width) + "x" + std::to_string(b.height));
    } else {
      const CompareTolerances& t = q.tolerances;
      ImageDiff d = diffImages(a, b, t);
      r.report["image"] = {{"max_difference", d.maxDifference},
                           {"mean_difference", d.meanDifference},
                           {"percentile", t.percentile},
                           {"percentile_difference", d.percentileDifference},
                           {"differing_pixels", d.differingPixels},
                           {"differing_percent", d.differingPercent},
                           {"psnr_db", num(d.psnrDb)},
                           {"ssim", d.ssim}};
      if (d.differingPercent > t.maxDifferingPercent)
        r.failures.push_back(std::to_string(d.differingPixels) + " pixels (" + fmt(d.differingPercent) +
                             "%) differ by more than " + fmt(t.tolerance) + " (largest " + fmt(d.maxDifference) + ")");
      if (t.minPsnrDb && d.psnrDb < *t.minPsnrDb)
        r.failures.push_back("PSNR " + fmt(d.psnrDb) + " dB < " + fmt(*t.minPsnrDb) + " dB");
      if (t.minSsim && d.ssim < *t.minSsim) r.failures.push_back("SSIM " + fmt(d.ssim, 6) + " < " + fmt(*t.minSsim, 6));
      r.pictureA = a;
      r.pictureB = b;
      r.heatmap = std::move(d.heatmap);
    }
  } else {
    if (imageA || imageB) throw Error("--kind " + std::string(compareKindName(r.kind)) + ": " +
                                      (imageA ? q.a : q.b).string() + " is an image");
    const io::LoadedVolume a = io::loadVolume(q.a, q.load), b = io::loadVolume(q.b, q.load);
    r.report["a"] = describeVolume(q.a, a);
    r.report["b"] = describeVolume(q.b, b);
    if (r.kind == CompareKind::Auto)
      r.kind = unsignedIntegers(a.volume) && unsignedIntegers(b.volume) ? CompareKind::Labels : CompareKind::Volume;
    if (r.kind == CompareKind::Labels) {
      const Geometry &ga = geometryOf(a.volume), &gb = geometryOf(b.volume);
      if (const std::string why = geometryDifference(ga, gb); !why.empty())
        r.failures.push_back(why);
      else if (q.load.region.downsample > 1)  // label maps downsample by the most frequent id, not the mean
        compareLabelMaps(io::loadLabels(q.a, q.load).ids(), io::loadLabels(q.b, q.load).ids(), q, r);
      else
        compareLabelMaps(convertVolume<uint16_t>(a.volume), convertVolume<uint16_t>(b.volume), q, r);
    } else {
      compareGreyVolumes(a.volume, b.volume, q, r);
    }
  }
  r.pass = r.failures.empty();
  r.report["kind"] = compareKindName(r.kind);
  r.report["pass"] = r.pass;
  r.report["failures"] = r.failures;
  return r;
}

std::string compareSummary(const CompareResult& r) {
  std::ostringstream s;
  const nlohmann::json& j = r.report;
  s << compareKindName(r.kind) << ": " << j["a"]["path"].get<std::string>() << " vs "
    << j["b"]["path"].get<std::string>() << "\n";
  auto value = [](const nlohmann::json& v, int precision = 4) {
    return v.is_null() ? std::string("inf") : fmt(v.get<double>(), precision);
  };
  if (j.contains("labels"))
    for (const auto& m : j["labels"])
      s << "  " << (m["id"].get<int>() ? "label " + std::to_string(m["id"].get<int>()) : std::string("ids"))
        << "  Dice " << value(m["dice"], 6) << "  Jaccard " << value(m["jaccard"], 6) << "  HD95 "
        << value(m["hd95_mm"]) << " mm  ASSD " << value(m["assd_mm"]) << " mm  volume "
        << fmt(m["volume_difference_mm3"].get<double>()) << " mm3 (" << fmt(m["volume_difference_percent"].get<double>())
        << "%)\n";
  if (j.contains("image")) {
    const auto& m = j["image"];
    s << "  max " << value(m["max_difference"]) << "  mean " << value(m["mean_difference"]) << "  p"
      << value(m["percentile"]) << " " << value(m["percentile_difference"]) << "  differing "
      << m["differing_pixels"].get<int64_t>() << " px (" << value(m["differing_percent"]) << "%)  PSNR "
      << value(m["psnr_db"]) << " dB  SSIM " << value(m["ssim"], 6) << "\n";
  }
  if (j.contains("volume") && j["volume"].contains("max_abs_difference")) {
    const auto& m = j["volume"];
    s << "  geometry " << (m["geometry_equal"].get<bool>() ? "equal" : "differs") << "  max |diff| "
      << value(m["max_abs_difference"]) << "  mean |diff| " << value(m["mean_abs_difference"], 6) << "  differing "
      << m["differing_voxels"].get<int64_t>() << " voxels\n";
  }
  s << (r.pass ? "PASS" : "FAIL");
  for (const auto& f : r.failures) s << "\n  " << f;
  s << "\n";
  return s.str();
}

}  // namespace vellum::app
