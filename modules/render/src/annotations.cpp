#include "vellum/render/annotations.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "map_sampling.hpp"
#include "vellum/core/error.hpp"

namespace vellum::render {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

struct Ink {
  cv::Scalar colour, halo;
};

// White on dark or transparent-over-dark backgrounds, black on light ones; the halo keeps
// text readable where it crosses anatomy.
Ink inkFor(const RgbaImage& image) {
  const uint8_t* c = image.at(0, 0);
  const double luminance = c[3] == 0 ? 255 : 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
  if (luminance > 128) return {cv::Scalar(20, 20, 20, 255), cv::Scalar(255, 255, 255, 255)};
  return {cv::Scalar(240, 240, 240, 255), cv::Scalar(0, 0, 0, 255)};
}

double fontScale(int width, int height) { return std::max(0.35, std::min(width, height) / 900.0); }

// The Hershey scale whose capital letters are `px` pixels high.
double fontScaleForHeight(double px) {
  int baseline = 0;
  return px / cv::getTextSize("H", kFont, 1.0, 1, &baseline).height;
}

double textScale(const AnnotationOptions& o, int width, int height) {
  return o.textHeightPx > 0 ? fontScaleForHeight(o.textHeightPx) : fontScale(width, height);
}
int marginPx(int height) { return std::max(6, height / 40); }
int barThickness(int height) { return std::max(2, height / 200); }

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}
int strokeWidth(double scale) { return std::max(1, int(std::lround(scale * 1.6))); }

void text(cv::Mat& m, const std::string& s, cv::Point at, double scale, const Ink& ink) {
  const int w = strokeWidth(scale);
  cv::putText(m, s, at, kFont, scale, ink.halo, w + 2 * std::max(1, w / 2 + 1), cv::LINE_AA);
  cv::putText(m, s, at, kFont, scale, ink.colour, w, cv::LINE_AA);
}

/// 1, 2 or 5 x 10^k nearest below `mm`.
double roundLength(double mm) {
  const double decade = std::pow(10.0, std::floor(std::log10(mm)));
  for (double f : {5.0, 2.0, 1.0})
    if (f * decade <= mm) return f * decade;
  return decade;
}

std::string formatMm(double mm) {
  char buf[32];
  std::snprintf(buf, sizeof buf, mm >= 1 ? "%.0f mm" : "%.2g mm", mm);
  return buf;
}

// The Hershey scale at which `s` is at most `maxWidth` pixels wide (and at most `scale`).
double fittedScale(const std::string& s, double scale, int maxWidth) {
  int baseline = 0;
  const int w = cv::getTextSize(s, kFont, scale, strokeWidth(scale), &baseline).width;
  return w > maxWidth && w > 0 ? scale * maxWidth / w : scale;
}

// `s` centred horizontally with its baseline at `baselineY`.
void centredText(cv::Mat& m, const std::string& s, int baselineY, double scale, const Ink& ink) {
  int baseline = 0;
  const int w = cv::getTextSize(s, kFont, scale, strokeWidth(scale), &baseline).width;
  text(m, s, {(m.cols - w) / 2, baselineY}, scale, ink);
}

}  // namespace

void drawCaption(RgbaImage& image, const std::string& caption, double textHeightPx) {
  if (caption.empty() || image.width <= 0 || image.height <= 0) return;
  const Ink ink = inkFor(image);
  cv::Mat m(image.height, image.width, CV_8UC4, image.pixels.data());
  const double base = textHeightPx > 0 ? fontScaleForHeight(textHeightPx) : 1.3 * fontScale(image.width, image.height);
  const int margin = marginPx(image.height);
  const double scale = fittedScale(caption, base, image.width - 2 * margin);
  // Above the bottom margin row, where the scale bar and its caption sit.
  int baseline = 0;
  const int h = cv::getTextSize("H", kFont, scale, 1, &baseline).height;
  centredText(m, caption, image.height - 3 * margin - 2 * h, scale, ink);
}

void drawTitleCard(RgbaImage& image, const std::string& title, const std::string& subtitle,
                   std::array<uint8_t, 3> background) {
  for (size_t i = 0; i + 3 < image.pixels.size(); i += 4) {
    image.pixels[i] = background[0], image.pixels[i + 1] = background[1], image.pixels[i + 2] = background[2];
    image.pixels[i + 3] = 255;
  }
  if (image.width <= 0 || image.height <= 0) return;
  const Ink ink = inkFor(image);
  cv::Mat m(image.height, image.width, CV_8UC4, image.pixels.data());
  const int margin = 2 * marginPx(image.height);
  const double scale = fittedScale(title, 2.2 * fontScale(image.width, image.height), image.width - 2 * margin);
  int baseline = 0;
  const int h = cv::getTextSize("H", kFont, scale, 1, &baseline).height;
  const int y = subtitle.empty() ? (image.height + h) / 2 : image.height / 2;
  centredText(m, title, y, scale, ink);
  if (!subtitle.empty()) {
    const double sub = fittedScale(subtitle, scale * 2 / 3, image.width - 2 * margin);
    centredText(m, subtitle, y + 2 * h, sub, ink);
  }
}

std::string displayName(const AnnotationOptions& options, uint16_t id, const std::string& name) {
  const std::string key = lower(name);
  for (const auto& [k, text] : options.displayNames)
    if (lower(k) == key || k == std::to_string(id)) return text;
  return name;
}

std::string anatomicalLetters(const Vec3& d) {
  struct Axis {
    double v;
    char pos, neg;
  };
  std::array<Axis, 3> axes{{{d.x, 'L', 'R'}, {d.y, 'P', 'A'}, {d.z, 'S', 'I'}}};
  std::sort(axes.begin(), axes.end(), [](const Axis& a, const Axis& b) { return std::abs(a.v) > std::abs(b.v); });
  std::string out(1, axes[0].v >= 0 ? axes[0].pos : axes[0].neg);
  if (std::abs(axes[1].v) > 0.38) out += axes[1].v >= 0 ? axes[1].pos : axes[1].neg;  // > ~22 degrees off
  return out;
}

std::vector<StructureAnchor> structureAnchors(const LabelVolume& labels, std::vector<uint16_t> ids,
                                              const Projection& projection, const RgbaImage& rendered,
                                              int64_t minPixels, std::vector<uint16_t>* footprintOut,
                                              AnchorOcclusion occlusion) {
  const int w = projection.width(), h = projection.height();
  if (rendered.width != w || rendered.height != h) throw Error("structure anchors: image and camera sizes differ");
  if (ids.empty())
    for (const Label& l : labels.table()) ids.push_back(l.id);
  std::vector<uint8_t> wanted(65536, 0);
  for (uint16_t id : ids) wanted[id] = 1;

  // Splat every voxel of the wanted structures into a depth buffer: each covers about its
  // projected size, so the footprint has no holes between voxel centres.
  const Geometry& g = labels.geometry();
  const double voxelPx = std::max({g.spacing.x, g.spacing.y, g.spacing.z}) * projection.pixelsPerMm();
  const int half = std::max(0, int(std::ceil(0.5 * voxelPx)));
  std::vector<float> depth(size_t(w) * h, std::numeric_limits<float>::infinity());
  std::vector<uint16_t> seen(size_t(w) * h, 0);
  // InnerFirst: every structure's own footprint (no depth test), then the smallest one wins.
  std::vector<uint16_t> slot(65536, 0);
  for (size_t i = 0; i < ids.size(); ++i) slot[ids[i]] = uint16_t(i);
  std::vector<std::vector<uint8_t>> own(occlusion == AnchorOcclusion::InnerFirst ? ids.size() : 0);
  for (auto& o : own) o.assign(size_t(w) * h, 0);
  const Dims d = g.dims;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const uint16_t id = labels(i, j, k);
        if (!id || !wanted[id]) continue;
        const auto p = projection.toPixel(g.indexToPhysical({double(i), double(j), double(k)}));
        if (!p) continue;
        const int cx = int(std::lround(p->x)), cy = int(std::lround(p->y));
        for (int y = std::max(0, cy - half); y <= std::min(h - 1, cy + half); ++y)
          for (int x = std::max(0, cx - half); x <= std::min(w - 1, cx + half); ++x) {
            const size_t q = size_t(y) * w + x;
            if (!own.empty()) own[slot[id]][q] = 1;
            else if (p->z < depth[q]) depth[q] = float(p->z), seen[q] = id;
          }
      }
  if (!own.empty()) {
    std::vector<int64_t> area(ids.size(), 0);
    for (size_t i = 0; i < ids.size(); ++i)
      for (uint8_t v : own[i]) area[i] += v;
    for (size_t q = 0; q < seen.size(); ++q) {
      int64_t best = std::numeric_limits<int64_t>::max();
      for (size_t i = 0; i < ids.size(); ++i)
        if (own[i][q] && area[i] < best) best = area[i], seen[q] = ids[i];
    }
  }
  for (int y = 0; y < h; ++y)  // only where the picture shows something
    for (int x = 0; x < w; ++x)
      if (rendered.at(x, y)[3] == 0) seen[size_t(y) * w + x] = 0;

  std::vector<StructureAnchor> anchors;
  for (uint16_t id : ids) {
    cv::Mat mask(h, w, CV_8U);
    int64_t count = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) count += (mask.at<uint8_t>(y, x) = seen[size_t(y) * w + x] == id ? 255 : 0) != 0;
    if (count < minPixels) continue;
    // The footprint's innermost pixel: a leader line ending there clearly points at it.
    cv::Mat dist;
    cv::distanceTransform(mask, dist, cv::DIST_L2, 3);
    cv::Point best;
    cv::minMaxLoc(dist, nullptr, nullptr, nullptr, &best);
    const auto label = labels.label(id);
    anchors.push_back({id, label ? label->name : "label " + std::to_string(id), best.x, best.y, count});
  }
  if (footprintOut) *footprintOut = std::move(seen);
  return anchors;
}

std::vector<StructureCentre> structureCentres(const LabelVolume& labels, std::vector<uint16_t> ids) {
  if (ids.empty())
    for (const Label& l : labels.table()) ids.push_back(l.id);
  const Geometry& g = labels.geometry();
  const Dims d = g.dims;
  std::vector<Vec3> sum(65536, Vec3{0, 0, 0});
  std::vector<int64_t> count(65536, 0);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const uint16_t id = labels(i, j, k);
        sum[id] += Vec3{double(i), double(j), double(k)};
        ++count[id];
      }
  // The voxel nearest the centroid (index space; a second pass over the wanted ids only).
  std::vector<double> best(65536, std::numeric_limits<double>::infinity());
  std::vector<Vec3> nearest(65536);
  std::vector<uint8_t> wanted(65536, 0);
  for (uint16_t id : ids) wanted[id] = id != 0 && count[id] > 0;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const uint16_t id = labels(i, j, k);
        if (!wanted[id]) continue;
        const Vec3 v{double(i), double(j), double(k)};
        const Vec3 off = v - sum[id] * (1.0 / double(count[id]));
        const double d2 = dot(off, off);
        if (d2 < best[id]) best[id] = d2, nearest[id] = v;
      }
  std::vector<StructureCentre> out;
  for (uint16_t id : ids)
    if (wanted[id]) out.push_back({id, g.indexToPhysical(nearest[id])});
  return out;
}

std::vector<std::optional<Vec3>> deformedPositions(const BackwardMap& map, const Geometry& source,
                                                   const std::vector<Vec3>& sourceMm) {
  const detail::PreparedMap pm = detail::prepareMap(map, source);
  const Geometry& grid = map.grid;
  const double tolerance = 0.01 * source.minSpacing();
  const double h = detail::PreparedMap::kNormalStepNodes;
  Mat3 mmToNode;  // output mm offsets -> node index offsets
  const Mat3 nodeToMm = grid.direction * Mat3::fromColumns({grid.spacing.x, 0, 0}, {0, grid.spacing.y, 0},
                                                           {0, 0, grid.spacing.z});
  if (!nodeToMm.inverse(mmToNode)) throw Error("backward map: singular node grid geometry");
  // u in mm at output mm x (as the renderer samples it), and du/dx (mm per mm).
  const auto uMm = [&](const Vec3& x) { return source.indexToPhysical(pm.at(grid.physicalToIndex(x))); };
  const auto jacobian = [&](const Vec3& x) {
    const Vec3 q = grid.physicalToIndex(x);
    Vec3 col[3];
    for (int a = 0; a < 3; ++a) {
      Vec3 e{0, 0, 0};
      e[a] = h;
      col[a] = (source.indexToPhysical(pm.interpolated(q + e)) - source.indexToPhysical(pm.interpolated(q - e))) *
               (0.5 / h);
    }
    return Mat3::fromColumns(col[0], col[1], col[2]) * mmToNode;  // du/dq * dq/dx
  };
  std::vector<std::optional<Vec3>> out;
  for (const Vec3& p : sourceMm) {
    Vec3 x = p;
    std::optional<Vec3> found;
    for (int it = 0; it < 30 && !found; ++it) {
      const Vec3 r = uMm(x) - p;
      if (norm(r) <= tolerance) found = x;
      Mat3 jInv;
      if (!jacobian(x).inverse(jInv)) break;
      x = x - jInv * r;
    }
    out.push_back(found);
  }
  return out;
}

void moveAnchorsToCentres(std::vector<StructureAnchor>& anchors, const std::vector<StructureCentre>& drawnMm,
                          const Projection& projection, const std::vector<uint16_t>& footprint) {
  const int w = projection.width(), h = projection.height();
  for (StructureAnchor& a : anchors)
    for (const StructureCentre& c : drawnMm) {
      if (c.id != a.id) continue;
      const auto px = projection.toPixel(c.mm);
      if (!px) continue;
      const int x = int(std::lround(px->x)), y = int(std::lround(px->y));
      if (x < 0 || y < 0 || x >= w || y >= h || footprint[size_t(y) * w + x] != a.id) continue;
      a.x = x;
      a.y = y;
    }
}

ImageInsets annotationInsets(const AnnotationOptions& options, int width, int height,
                             const std::vector<std::string>& labelTexts) {
  // The same measures as annotate() below, plus half a margin of air.
  ImageInsets in;
  const double scale = textScale(options, width, height);
  const int margin = marginPx(height), air = margin / 2;
  int baseline = 0;
  const int textH = cv::getTextSize("Ag", kFont, scale, strokeWidth(scale), &baseline).height;
  const int letterW = cv::getTextSize("RA", kFont, scale, strokeWidth(scale), &baseline).width;
  if (options.orientation) {
    in.left = in.right = margin + letterW + air;
    in.top = in.bottom = margin + textH + air;
  }
  if (options.scaleBar) in.bottom = std::max(in.bottom, margin + barThickness(height) + margin / 2 + textH + air);
  if (options.labels && !labelTexts.empty()) {
    int widest = 0;
    for (const std::string& t : labelTexts)
      widest = std::max(widest, cv::getTextSize(t, kFont, scale, strokeWidth(scale), &baseline).width);
    const int indent = options.orientation ? margin + letterW : 0;
    const int column = margin + indent + widest + margin / 2 + air;
    if (options.labelSide != AnnotationOptions::LabelSide::Right) in.left = std::max(in.left, column);
    if (options.labelSide != AnnotationOptions::LabelSide::Left) in.right = std::max(in.right, column);
  }
  return in;
}

AnnotationLayout annotate(RgbaImage& image, const Projection& projection, const AnnotationOptions& options,
                          const std::vector<StructureAnchor>& anchors) {
  if (image.width != projection.width() || image.height != projection.height())
    throw Error("annotate: image and camera sizes differ");
  AnnotationLayout layout;
  cv::Mat m(image.height, image.width, CV_8UC4, image.pixels.data());
  const Ink ink = inkFor(image);
  const double scale = textScale(options, image.width, image.height);
  const int margin = marginPx(image.height);
  int baseline = 0;
  const int textH = cv::getTextSize("Ag", kFont, scale, strokeWidth(scale), &baseline).height;

  if (options.scaleBar) {
    const double ppm = projection.pixelsPerMm();
    const double mm = options.scaleBarMm > 0 ? options.scaleBarMm : roundLength(0.2 * image.width / ppm);
    const double px = mm * ppm;
    if (px > image.width - 2 * margin) throw Error("scale bar of " + formatMm(mm) + " does not fit the figure");
    const int x0 = margin, y = image.height - margin;
    const int x1 = x0 + int(std::lround(px)) - 1;  // covers pixels x0..x1: px pixels in all
    const int thick = barThickness(image.height);
    cv::rectangle(m, {x0 - 1, y - thick - 1}, {x1 + 1, y + 1}, ink.halo, cv::FILLED);
    cv::rectangle(m, {x0, y - thick}, {x1, y}, ink.colour, cv::FILLED);
    const std::string caption = formatMm(mm) + (projection.perspective() ? " at the centre" : "");
    text(m, caption, {x0, y - thick - margin / 2}, scale, ink);
    layout.scaleBarMm = mm;
    layout.scaleBarPixels = px;
    layout.scaleBarStart = {x0, y};
  }

  if (options.orientation) {
    const std::array<std::string, 4> letters{anatomicalLetters(projection.screenRight()),
                                             anatomicalLetters(-projection.screenRight()),
                                             anatomicalLetters(projection.screenUp()),
                                             anatomicalLetters(-projection.screenUp())};
    layout.orientationLetters = letters;
    const auto size = [&](const std::string& s) { return cv::getTextSize(s, kFont, scale, strokeWidth(scale), &baseline); };
    text(m, letters[0], {image.width - margin - size(letters[0]).width, image.height / 2 + textH / 2}, scale, ink);
    text(m, letters[1], {margin, image.height / 2 + textH / 2}, scale, ink);
    text(m, letters[2], {image.width / 2 - size(letters[2]).width / 2, margin + textH}, scale, ink);
    text(m, letters[3], {image.width / 2 - size(letters[3]).width / 2, image.height - margin}, scale, ink);
  }

  if (options.labels && !anchors.empty()) {
    // Two columns in the side margins; each label as near its anchor's height as the others
    // allow (sorted, then pushed apart, then pulled back inside the figure).
    const int rowH = textH + baseline + textH / 2;
    const int top = margin + 2 * textH, bottom = image.height - margin - 3 * textH;
    for (int side = 0; side < 2; ++side) {
      std::vector<const StructureAnchor*> column;
      using Side = AnnotationOptions::LabelSide;
      for (const auto& a : anchors) {
        const bool left = options.labelSide == Side::Nearest ? a.x < image.width / 2 : options.labelSide == Side::Left;
        if (left == (side == 0)) column.push_back(&a);
      }
      std::sort(column.begin(), column.end(), [](auto* a, auto* b) { return a->y < b->y; });
      std::vector<int> ys;
      for (const auto* a : column) ys.push_back(std::clamp(a->y, top, bottom));
      for (size_t i = 1; i < ys.size(); ++i) ys[i] = std::max(ys[i], ys[i - 1] + rowH);
      if (!ys.empty() && ys.back() > bottom) {
        ys.back() = bottom;
        for (size_t i = ys.size() - 1; i-- > 0;) ys[i] = std::min(ys[i], ys[i + 1] - rowH);
      }
      for (size_t i = 0; i < column.size(); ++i) {
        const auto& a = *column[i];
        const std::string name = displayName(options, a.id, a.name);
        const cv::Size sz = cv::getTextSize(name, kFont, scale, strokeWidth(scale), &baseline);
        // Beside the orientation letter of that edge, not on it.
        const int indent = options.orientation ? margin + cv::getTextSize("RA", kFont, scale, strokeWidth(scale), &baseline).width : 0;
        const int x0 = side == 0 ? margin + indent : image.width - margin - indent - sz.width;
        const int yBase = ys[i] + sz.height / 2;
        const AnnotationLayout::Box box{x0, yBase - sz.height, x0 + sz.width - 1, yBase + baseline};
        const int lx = side == 0 ? box.x1 + margin / 2 : box.x0 - margin / 2;
        const int ly = ys[i];
        cv::line(m, {lx, ly}, {a.x, a.y}, ink.halo, strokeWidth(scale) + 2, cv::LINE_AA);
        cv::line(m, {lx, ly}, {a.x, a.y}, ink.colour, strokeWidth(scale), cv::LINE_AA);
        cv::circle(m, {a.x, a.y}, strokeWidth(scale) + 1, ink.colour, cv::FILLED, cv::LINE_AA);
        text(m, name, {x0, yBase}, scale, ink);
        layout.labelBoxes.push_back(box);
        layout.labelTexts.push_back(name);
        layout.leaderLines.push_back({lx, ly, a.x, a.y});
      }
    }
  }
  return layout;
}

}  // namespace vellum::render
