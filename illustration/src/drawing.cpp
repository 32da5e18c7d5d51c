// OpenCV side of the curve analogy: C0 from a drawing, and the before/after plate (PNG codecs
// through io::codecs, loaded on first use).
#include <opencv2/imgcodecs.hpp>  // flag constants only
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <fstream>

#include "vellum/core/error.hpp"
#include "vellum/illustration/curve_analogy.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/image_codecs.hpp"

namespace vellum::illustration {

namespace {
/// The outer contour of `mask` enclosing the largest area (empty when none has any area).
std::vector<cv::Point> largestOutline(const cv::Mat& mask, double& area) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  size_t best = contours.size();
  area = 0;
  for (size_t i = 0; i < contours.size(); ++i) {
    const double a = cv::contourArea(contours[i]);
    if (a > area) area = a, best = i;
  }
  return best == contours.size() ? std::vector<cv::Point>{} : std::move(contours[best]);
}
}  // namespace

Polyline2 loadDrawingOutline(const std::filesystem::path& path, int& width, int& height,
                             int darkThreshold) {
  cv::Mat grey;
  std::string error;
  if (!io::codecs::imread(path, cv::IMREAD_GRAYSCALE, grey, error) || grey.empty())
    throw FileError(path, "cannot read the drawing (PNG or JPG expected)" + (error.empty() ? "" : ": " + error));
  width = grey.cols;
  height = grey.rows;
  cv::Mat dark;
  cv::threshold(grey, dark, darkThreshold, 255, cv::THRESH_BINARY_INV);
  // Close small gaps in hand-drawn strokes so the outline is one closed region.
  cv::morphologyEx(dark, dark, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
  double area = 0;
  const std::vector<cv::Point> outline = largestOutline(dark, area);
  if (outline.empty() || area < 16)
    throw FileError(path, "no dark outline found (strokes darker than grey " + std::to_string(darkThreshold) + ")");
  Polyline2 c;
  for (const auto& p : outline) c.push_back({double(p.x), double(p.y)});
  return c;
}

Polyline2 projectedOutline(const TriMesh& mesh, const render::Projection& proj, int supersample) {
  const int ss = std::max(1, supersample);
  cv::Mat mask(proj.height() * ss, proj.width() * ss, CV_8UC1, cv::Scalar(0));
  // Pixel centres at integers: pixel x covers [x - 0.5, x + 0.5); fillPoly's fixed point
  // (4 fraction bits) keeps sub-pixel vertex positions.
  std::vector<cv::Point> px(mesh.vertices.size());
  for (size_t v = 0; v < px.size(); ++v) {
    const auto p = proj.toPixel(Vec3{mesh.vertices[v][0], mesh.vertices[v][1], mesh.vertices[v][2]});
    if (!p) throw Error("outline: a vertex is behind the camera");
    px[v] = {cvRound(((p->x + 0.5) * ss - 0.5) * 16), cvRound(((p->y + 0.5) * ss - 0.5) * 16)};
  }
  for (const auto& f : mesh.faces) {
    const cv::Point tri[3] = {px[f[0]], px[f[1]], px[f[2]]};
    cv::fillConvexPoly(mask, tri, 3, cv::Scalar(255), cv::LINE_8, 4);
  }
  double area = 0;
  const std::vector<cv::Point> outline = largestOutline(mask, area);
  if (outline.empty()) throw Error("outline: the mesh covers no pixel of the view");
  Polyline2 c;
  for (const auto& p : outline) c.push_back({(p.x + 0.5) / ss - 0.5, (p.y + 0.5) / ss - 0.5});
  return c;
}

namespace {
void writePng(const std::filesystem::path& path, const cv::Mat& img) {
  io::writeAtomically(path, [&](const std::filesystem::path& tmp) {
    std::vector<uchar> buf;
    std::string error;
    if (!io::codecs::imencode(".png", img, buf, error)) throw FileError(path, "PNG encoding failed" + (error.empty() ? "" : ": " + error));
    std::ofstream os(tmp, std::ios::binary);
    os.write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
    if (!os) throw FileError(path, "write failed (disk full?)");
  });
}
}  // namespace

void writeCurveDrawing(const std::filesystem::path& path, int width, int height,
                       const Polyline2& curve, int strokePx) {
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<cv::Point> pts;
  for (const auto& p : curve) pts.emplace_back(cvRound(p.x * 16), cvRound(p.y * 16));
  cv::polylines(img, std::vector<std::vector<cv::Point>>{pts}, true, cv::Scalar(30, 30, 30),
                std::max(1, strokePx), cv::LINE_AA, 4);
  writePng(path, img);
}

void writeCurvePlate(const std::filesystem::path& path, int width, int height,
                     const Polyline2& before, const Polyline2& drawing, const Polyline2& after) {
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  auto draw = [&](const Polyline2& c, const cv::Scalar& colour, int thickness) {
    std::vector<cv::Point> pts;
    for (const auto& p : c) pts.emplace_back(cvRound(p.x * 16), cvRound(p.y * 16));  // 4 fraction bits
    cv::polylines(img, std::vector<std::vector<cv::Point>>{pts}, true, colour, thickness, cv::LINE_AA, 4);
  };
  draw(before, cv::Scalar(150, 150, 150), 2);
  draw(drawing, cv::Scalar(40, 40, 220), 1);
  draw(after, cv::Scalar(200, 90, 20), 2);
  cv::putText(img, "grey: before   red: drawing (aligned)   blue: after", cv::Point(8, 18),
              cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  writePng(path, img);
}

}  // namespace vellum::illustration
