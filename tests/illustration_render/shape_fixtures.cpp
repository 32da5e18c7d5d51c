#include "shape_fixtures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vellum/core/parallel.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::test {

double sphereSdf(const Vec3& p, const Vec3& c, double r) { return norm(p - c) - r; }

double boxSdf(const Vec3& p, const Vec3& c, const Vec3& h) {
  const Vec3 q{std::abs(p.x - c.x) - h.x, std::abs(p.y - c.y) - h.y, std::abs(p.z - c.z) - h.z};
  const Vec3 outside{std::max(q.x, 0.0), std::max(q.y, 0.0), std::max(q.z, 0.0)};
  return norm(outside) + std::min(std::max({q.x, q.y, q.z}), 0.0);
}

illustration::ShapeScene makeScene(int n, const std::vector<AnalyticSegment>& segments, double spacing) {
  Geometry g;
  g.dims = {n, n, n};
  g.spacing = {spacing, spacing, spacing};
  const double half = (n - 1) * 0.5 * spacing;
  g.origin = {-half, -half, -half};
  illustration::ShapeScene s;
  s.distance = VolumeF32(g, 0.f, 1e3);
  VolumeU16 ids(g, 0);
  std::vector<VolumeF32> own(segments.size(), VolumeF32(g, 0.f, 1e3));
  parallelFor(n, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < n; ++j)
        for (int64_t i = 0; i < n; ++i) {
          const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
          double d = std::numeric_limits<double>::infinity();
          uint16_t label = 0;
          for (size_t si = 0; si < segments.size(); ++si) {
            const double v = segments[si].sdf(p);
            own[si](i, j, k) = float(v);
            if (v < 0 && label == 0) label = uint16_t(si + 1);
            d = std::min(d, v);
          }
          s.distance(i, j, k) = float(d);
          ids(i, j, k) = label;
        }
  });
  std::vector<Label> table;
  for (size_t si = 0; si < segments.size(); ++si)
    table.push_back({uint16_t(si + 1), segments[si].name, defaultLabelColor(uint16_t(si + 1))});
  s.segments = LabelVolume(std::move(ids), table);
  for (size_t si = 0; si < segments.size(); ++si) {
    illustration::SegmentField f;
    f.id = uint16_t(si + 1);
    f.name = segments[si].name;
    f.distance = illustration::quantiseField(own[si]);
    s.fields.push_back(std::move(f));
  }
  return s;
}

illustration::ShapeScene nestedScene(int n) {
  const double rb = 0.18 * n, rm = 0.30 * n, rs = 0.36 * n;
  const Vec3 c{0, 0, 0};
  return makeScene(n, {{"bone", [=](const Vec3& p) { return sphereSdf(p, c, rb); }},
                       {"muscle", [=](const Vec3& p) { return std::max(rb - norm(p), sphereSdf(p, c, rm)); }},
                       {"skin", [=](const Vec3& p) { return std::max(rm - norm(p), sphereSdf(p, c, rs)); }}});
}

const illustration::ShapeScene& nestedScene48() {
  static const illustration::ShapeScene s = nestedScene(48);
  return s;
}

illustration::ShapeScene twoSpheres(int n) {
  const double r = 0.22 * n, off = 0.25 * n;
  return makeScene(n, {{"bone", [=](const Vec3& p) { return sphereSdf(p, {-off, 0, 0}, r); }},
                       {"muscle", [=](const Vec3& p) { return sphereSdf(p, {off, 0, 0}, r); }}});
}

illustration::Style twoRowStyle() {
  illustration::Style st;
  illustration::SegmentStyle bone, muscle;
  bone.match = "bone";
  bone.colour = {0.9f, 0.85f, 0.7f};
  bone.opacity = 0.8f;
  muscle.match = "muscle";
  muscle.colour = {0.8f, 0.2f, 0.15f};
  muscle.opacity = 0.8f;
  st.segments = {bone, muscle};
  return st;
}

void writeShapeFolder(const illustration::ShapeScene& scene, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  io::saveVolume(scene.distance, dir / "distance.nrrd");
  io::saveLabels(scene.segments, dir / "segments.nrrd");
  illustration::saveSegmentFields(scene.fields, dir);
}

}  // namespace vellum::test
