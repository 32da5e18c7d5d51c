// Shape pipeline: Whitaker band constraint, mesh checks, signed distance accuracy, shells, grow.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <random>

#include "test_data.hpp"
#include "test_meshes.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/phantom/phantom.hpp"

namespace ill = vellum::illustration;
using namespace vellum;

namespace {

Geometry cube(int64_t n, double spacing = 1.0) {
  Geometry g;
  g.dims = {n, n, n};
  g.spacing = {spacing, spacing, spacing};
  const double c = -0.5 * (n - 1) * spacing;
  g.origin = {c, c, c};
  return g;
}

/// Binary sphere of `radius` mm centred at the origin (voxel centres inside).
VolumeU8 sphereMask(const Geometry& g, double radius) {
  VolumeU8 m(g, 0);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        m(i, j, k) = norm(g.indexToPhysical(Vec3{double(i), double(j), double(k)})) < radius;
  return m;
}

LabelVolume labelsOf(const VolumeU8& mask, uint16_t id, const std::string& name) {
  VolumeU16 ids(mask.geometry(), 0);
  for (size_t n = 0; n < mask.size(); ++n) ids.data()[n] = mask.data()[n] ? id : 0;
  return LabelVolume(std::move(ids), {{id, name, {200, 100, 50}}});
}

using test::icosphere;

void expectCleanMesh(const ill::SegmentShape& s) {
  SCOPED_TRACE(s.segment.name);
  EXPECT_GT(s.mesh.faces.size(), 100u);
  EXPECT_TRUE(s.checks.closed);
  EXPECT_TRUE(s.checks.manifold);
  EXPECT_TRUE(s.checks.outward);
  EXPECT_EQ(s.checks.selfIntersections, 0);
  EXPECT_GT(s.checks.volumeMm3, 0);
  // Independent re-check of the exported mesh.
  const auto c = ill::checkMesh(s.mesh);
  EXPECT_TRUE(c.closed && c.manifold && c.outward);
  EXPECT_EQ(c.selfIntersections, 0);
}

}  // namespace

TEST(ShapeDenoise, ZeroLevelSetStaysWithinHalfVoxelBand) {
  // A noisy thresholded sphere with holes: a hard case for the constraint.
  const Geometry g = cube(40);
  VolumeU8 m = sphereMask(g, 13.0);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> pick(0, 39);
  for (int n = 0; n < 400; ++n) {  // salt-and-pepper flips
    const int i = pick(rng), j = pick(rng), k = pick(rng);
    m(i, j, k) = !m(i, j, k);
  }
  const ill::DenoiseOptions opt{20};
  const VolumeF32 phi = ill::denoiseMask(m, opt);
  int64_t violations = 0, changed = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const float p = phi(i, j, k);
        if (m(i, j, k) ? p > -opt.marginVoxels + 1e-4 : p < opt.marginVoxels - 1e-4) ++violations;
        if (std::abs(p) < 0.45f) ++changed;  // centres the zero level set came close to
      }
  EXPECT_EQ(violations, 0);
  // Along every grid edge between an inside and an outside centre phi changes sign, so the
  // zero crossing lies between the two centres: within half a voxel of their shared face.
  int64_t edges = 0, crossings = 0;
  for (int64_t k = 0; k + 1 < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        if (m(i, j, k) != m(i, j, k + 1)) {
          ++edges;
          crossings += (phi(i, j, k) < 0) != (phi(i, j, k + 1) < 0);
        }
  EXPECT_EQ(crossings, edges);
  EXPECT_GT(changed, 0);  // the flow did move the surface within the band
}

TEST(ShapeDenoise, SmoothsTheStaircase) {
  // Face normals of a sphere's mesh point radially; the binary staircase's do not. After the
  // constrained flow the (area-weighted) mean angle to the radial direction drops.
  const Geometry g = cube(40);
  const LabelVolume labels = labelsOf(sphereMask(g, 12.3), 1, "ball");
  auto meanAngle = [&](int iterations) {
    ill::ShapeOptions opt;
    opt.denoise.iterations = iterations;
    opt.targetFaces = 0;
    opt.smoothingIterations = 0;
    opt.adaptivity = 0;
    ill::StageTimes t;
    const auto shapes = ill::buildShapes(labels, {ill::parseSegmentSpec("1", labels)}, opt, t);
    double sum = 0, area = 0;
    for (const auto& f : shapes[0].mesh.faces) {
      Vec3 p[3];
      for (int c = 0; c < 3; ++c) {
        const auto& v = shapes[0].mesh.vertices[f[c]];
        p[c] = Vec3{v[0], v[1], v[2]};
      }
      const Vec3 n = cross(p[1] - p[0], p[2] - p[0]);
      const double a = norm(n);
      if (a <= 0) continue;
      const Vec3 centre = (p[0] + p[1] + p[2]) * (1.0 / 3);
      sum += a * std::acos(std::clamp(dot(n, normalized(centre)) / a, -1.0, 1.0));
      area += a;
    }
    return sum / area * 180 / M_PI;
  };
  const double staircase = meanAngle(0), smooth = meanAngle(5);
  EXPECT_LT(smooth, 0.75 * staircase) << staircase << " -> " << smooth << " degrees";
}

TEST(ShapeMesh, NoisySphereWithHolesIsClean) {
  const Geometry g = cube(48, 0.8);
  VolumeU8 m = sphereMask(g, 15.0);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> pick(0, 47);
  for (int n = 0; n < 600; ++n) {
    const int i = pick(rng), j = pick(rng), k = pick(rng);
    m(i, j, k) = !m(i, j, k);
  }
  // Punch tunnels through the sphere (holes in the segment).
  for (int k = 0; k < 48; ++k)
    for (int d = -1; d <= 1; ++d) {
      m(24 + d, 24, k) = 0;
      m(10, 24 + d, k) = 0;
    }
  const LabelVolume labels = labelsOf(m, 5, "ball");
  ill::ShapeOptions opt;
  opt.targetFaces = 3000;
  ill::StageTimes t;
  const auto shapes = ill::buildShapes(labels, {ill::parseSegmentSpec("5", labels)}, opt, t);
  ASSERT_EQ(shapes.size(), 1u);
  EXPECT_EQ(shapes[0].segment.name, "ball");
  expectCleanMesh(shapes[0]);
  // Salt noise outside the sphere stays (the constraint keeps every voxel's side), as tiny
  // closed blobs: the decimation's constraints stop above the 3000-face budget.
  EXPECT_NEAR(shapes[0].checks.volumeMm3 / shapes[0].checks.voxelVolumeMm3, 1.0, 0.08);
  EXPECT_LT(shapes[0].checks.maxBoundaryDistanceMm, 1.0 * 0.8);
}

// --target-faces is a budget the meshes keep: a box with a tunnel and a ball on it (sharp
// edges: the feature-guarded decimation alone stops far above a small budget) comes out at
// most 2 % over it, still clean, and still within two voxels of the binary boundary.
TEST(ShapeMesh, TargetFacesBoundsTheFaceCount) {
  const Geometry g = cube(40, 1.0);
  VolumeU8 m(g, 0);
  for (int64_t k = 0; k < 40; ++k)
    for (int64_t j = 0; j < 40; ++j)
      for (int64_t i = 0; i < 40; ++i) {
        const bool box = i >= 6 && i < 30 && j >= 8 && j < 32 && k >= 8 && k < 28;
        const bool tunnel = i >= 14 && i < 20 && j >= 16 && j < 22;
        const double dx = i - 30.0, dy = j - 20.0, dz = k - 18.0;
        m(i, j, k) = (box && !tunnel) || dx * dx + dy * dy + dz * dz < 49.0;
      }
  const LabelVolume labels = labelsOf(m, 1, "part");
  for (const int64_t target : {500, 800}) {
    SCOPED_TRACE(target);
    ill::ShapeOptions opt;
    opt.targetFaces = target;
    ill::StageTimes t;
    const auto shapes = ill::buildShapes(labels, {ill::parseSegmentSpec("1", labels)}, opt, t);
    ASSERT_EQ(shapes.size(), 1u);
    expectCleanMesh(shapes[0]);
    EXPECT_LE(double(shapes[0].mesh.faces.size()), 1.02 * double(target));
    EXPECT_GE(double(shapes[0].mesh.faces.size()), 0.8 * double(target));
    EXPECT_NEAR(shapes[0].checks.volumeMm3 / shapes[0].checks.voxelVolumeMm3, 1.0, 0.05);
    EXPECT_LT(shapes[0].checks.maxBoundaryDistanceMm, 2.0);
  }
}

TEST(ShapeMesh, PhantomSegmentsAreClean) {
  phantom::PhantomOptions po;
  po.dims = {56, 56, 56};
  const auto ph = phantom::makePhantom(po);
  std::vector<ill::Segment> segs;
  // Every label on its own (names from the label table) and the usual unions.
  for (const char* s : {"1", "2", "3", "4", "5", "6", "7", "8", "9", "10", "11",
                        "body=1,2,3,4,5,6,7,8,9,10,11", "femur=4,5", "tibia=6,7", "fibula=8,11",
                        "patella=9,11"})
    segs.push_back(ill::parseSegmentSpec(s, ph.labels));
  ill::ShapeOptions opt;
  opt.targetFaces = 5000;
  ill::StageTimes t;
  const auto shapes = ill::buildShapes(ph.labels, segs, opt, t);
  ASSERT_EQ(shapes.size(), segs.size());
  const double voxel = ph.labels.geometry().spacing.x;
  for (const auto& s : shapes) {
    expectCleanMesh(s);
    SCOPED_TRACE(s.segment.name);
    EXPECT_LT(s.checks.maxBoundaryDistanceMm, 1.5 * voxel * 1.25);
  }
}

TEST(ShapeDistance, SphereMeshMatchesAnalyticDistance) {
  const double h = 1.0, r = 11.0;
  const Geometry g = cube(36, h);
  const auto mesh = icosphere(r, 5);
  const auto d = ill::signedDistances({mesh}, g, {4.0});
  ASSERT_EQ(d.size(), 1u);
  int64_t wrongSign = 0, near = 0;
  double maxErr = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const double a = norm(g.indexToPhysical(Vec3{double(i), double(j), double(k)})) - r;
        const double v = d[0](i, j, k);
        if (std::abs(a) > 0.02 && (a < 0) != (v < 0)) ++wrongSign;
        if (std::abs(a) <= 2 * h) {
          ++near;
          maxErr = std::max(maxErr, std::abs(v - a));
        }
      }
  EXPECT_EQ(wrongSign, 0);
  EXPECT_GT(near, 1000);
  EXPECT_LE(maxErr, 0.05 * h);
}

TEST(ShapeDistance, FarFieldOfTheUnionIsWithinAVoxel) {
  const double h = 1.0, r = 8.0;
  const Geometry g = cube(48, h);
  auto d = ill::signedDistances({icosphere(r, 5)}, g, {});  // exact band: 3 voxels
  ill::Segment s{"ball", {1}, {255, 0, 0}};
  VolumeF32 u;
  LabelVolume seg;
  ill::buildRepresentation(d, {s}, {}, u, seg);
  double maxFar = 0, maxNear = 0, maxDist = 0;
  int64_t wrongSign = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const double a = norm(g.indexToPhysical(Vec3{double(i), double(j), double(k)})) - r;
        const double v = u(i, j, k);
        if (std::abs(a) > 0.02 && (a < 0) != (v < 0)) ++wrongSign;
        if (std::abs(a) <= 2 * h) maxNear = std::max(maxNear, std::abs(v - a));
        else maxFar = std::max(maxFar, std::abs(v - a));
        maxDist = std::max(maxDist, std::abs(v));
        EXPECT_EQ(seg(i, j, k), a < -0.05 ? 1 : (a > 0.05 ? 0 : seg(i, j, k)));
      }
  EXPECT_EQ(wrongSign, 0);
  EXPECT_LE(maxNear, 0.05 * h);
  EXPECT_LE(maxFar, 1.0 * h);   // far field: distance to the band + the band's width
  EXPECT_GT(maxDist, 20.0);     // not clamped: the grid's corners are ~33 mm away
}

TEST(ShapeDistance, AnisotropicGridSignsAndAccuracy) {
  Geometry g = cube(32, 1.0);
  g.spacing = {0.9, 0.9, 1.3};
  g.origin = {-0.45 * 31, -0.45 * 31, -0.65 * 31};
  const double r = 10.0;
  const auto d = ill::signedDistances({icosphere(r, 5)}, g, {4.0});
  int64_t wrongSign = 0;
  double maxErr = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const double a = norm(g.indexToPhysical(Vec3{double(i), double(j), double(k)})) - r;
        const double v = d[0](i, j, k);
        if (std::abs(a) > 0.05 && (a < 0) != (v < 0)) ++wrongSign;
        if (std::abs(a) <= 2 * 0.9) maxErr = std::max(maxErr, std::abs(v - a));
      }
  EXPECT_EQ(wrongSign, 0);
  EXPECT_LE(maxErr, 0.05 * 0.9);
}

TEST(ShapeRepresentation, ShellThicknessAndGrow) {
  const double h = 1.0, r = 12.0;
  const Geometry g = cube(40, h);
  const VolumeU8 m = sphereMask(g, r);
  const LabelVolume labels = labelsOf(m, 1, "ball");
  ill::ShapeOptions opt;
  opt.targetFaces = 0;
  const std::vector<ill::Segment> segs = {ill::parseSegmentSpec("ball=1", labels)};
  // Shell of 3 mm: the "ball boundary" voxels lie between radius r-3 and r (within a voxel).
  const auto res = ill::runShapePipeline(labels, segs, {{"ball", 3.0}}, {}, opt);
  ASSERT_EQ(res.segmentation.table().size(), 2u);
  EXPECT_EQ(res.segmentation.table()[1].name, "ball boundary");
  double minShell = 1e9, maxShell = 0, maxCore = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const double rr = norm(g.indexToPhysical(Vec3{double(i), double(j), double(k)}));
        const auto id = res.segmentation(i, j, k);
        if (id == 2) {
          minShell = std::min(minShell, rr);
          maxShell = std::max(maxShell, rr);
        }
        if (id == 1) maxCore = std::max(maxCore, rr);
      }
  EXPECT_NEAR(maxShell - minShell, 3.0, h);
  EXPECT_NEAR(maxCore, r - 3.0, h);
  // Grow by +2 and -2 mm: the zero level set of the distance moves the radius by the offset.
  for (double off : {2.0, -2.0}) {
    const auto grown = ill::runShapePipeline(labels, segs, {}, {{"ball", off}}, opt);
    // Radius of the zero crossing along +x through the centre row.
    const int64_t j = g.dims.y / 2, k = g.dims.z / 2;
    double crossing = 0;
    for (int64_t i = g.dims.x / 2; i + 1 < g.dims.x; ++i) {
      const double a = grown.distance(i, j, k), b = grown.distance(i + 1, j, k);
      if (a < 0 && b >= 0) {
        const double x0 = g.indexToPhysical(Vec3{double(i), double(j), double(k)}).x;
        crossing = x0 + h * a / (a - b);
        break;
      }
    }
    const double y = g.indexToPhysical(Vec3{0.0, double(j), double(k)}).y;
    const double z = g.indexToPhysical(Vec3{0.0, double(j), double(k)}).z;
    const double radius = std::sqrt(crossing * crossing + y * y + z * z);
    // The ungrown mesh's radius is r within half a voxel (band constraint).
    EXPECT_NEAR(radius, r + off, 0.5 * h + 0.1) << "offset " << off;
  }
}

/// Issue 21: nested segments (skin = 1,2 then bone = 2, the later wins) each keep their own
/// surface. The union distance is deep inside at the bone's boundary; the bone's own field
/// crosses zero there, equals the bone-alone field, and survives the folder round trip.
TEST(ShapeRepresentation, NestedSegmentsKeepTheirOwnSurfaces) {
  const Geometry g = cube(40, 1.0);
  const VolumeU8 outer = sphereMask(g, 15.0), inner = sphereMask(g, 7.0);
  VolumeU16 ids(g, 0);
  for (size_t v = 0; v < ids.size(); ++v) ids.data()[v] = inner.data()[v] ? 2 : outer.data()[v] ? 1 : 0;
  const LabelVolume labels(std::move(ids), {{1, "soft", {}}, {2, "bone", {}}});
  ill::ShapeOptions opt;
  opt.targetFaces = 0;
  const auto nested = ill::runShapePipeline(
      labels, {ill::parseSegmentSpec("skin=1,2", labels), ill::parseSegmentSpec("bone=2", labels)}, {}, {}, opt);
  const auto alone = ill::runShapePipeline(labels, {ill::parseSegmentSpec("bone=2", labels)}, {}, {}, opt);
  ASSERT_EQ(nested.fields.size(), 2u);
  ASSERT_EQ(alone.fields.size(), 1u);
  EXPECT_EQ(nested.fields[1].id, 2);
  EXPECT_EQ(nested.fields[1].name, "bone");
  EXPECT_EQ(nested.fields[1].distance.voxels(), alone.fields[0].distance.voxels());
  // Along +x from the centre: the bone field crosses zero at ~7 mm, the skin's at ~15 mm,
  // while the union distance at 7 mm is ~ -8 mm (the skin's surface is the nearest).
  const int64_t c = 20;
  auto crossing = [&](const VolumeI16& f) {
    for (int64_t i = c; i + 1 < 40; ++i)
      if (f(i, c, c) < 0 && f(i + 1, c, c) >= 0) {
        const double a = f(i, c, c), b = f(i + 1, c, c);
        return g.indexToPhysical(Vec3{double(i), double(c), double(c)}).x + a / (a - b);
      }
    return -1.0;
  };
  const double y = g.indexToPhysical(Vec3{0.0, double(c), double(c)}).y;
  EXPECT_NEAR(std::hypot(crossing(nested.fields[1].distance), y, y), 7.0, 0.6);
  EXPECT_NEAR(std::hypot(crossing(nested.fields[0].distance), y, y), 15.0, 0.6);
  const int64_t at7 = c + 7;
  EXPECT_LT(nested.distance(at7, c, c), -5.0f);
  EXPECT_NEAR(nested.fields[1].distance(at7, c, c) * ill::kFieldQuantumMm, 0.0, 1.0);
  // Quantised to hundredths of a mm; clamped to the band beyond it, with the right sign.
  const double band = ill::defaultExactBandMm(g);
  EXPECT_NEAR(nested.fields[1].distance(0, 0, 0) * ill::kFieldQuantumMm, band, 1.01);
  EXPECT_LT(nested.fields[1].distance(c, c, c), 0);
  const auto dir = test::tempDir("fields");
  ill::saveSegmentFields(nested.fields, dir);
  const auto back = ill::loadSegmentFields(dir);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].distance.voxels(), nested.fields[1].distance.voxels());
  EXPECT_EQ(back[0].name, "skin");
  std::ofstream(dir / "distances.json") << R"({"version": 1, "quantum_mm": 0.01, "fields": [{"id": 1}]})";
  EXPECT_THROW(ill::loadSegmentFields(dir), FileError);
}

/// Shells: the field's shell id and thickness follow buildRepresentation's ids.
TEST(ShapeRepresentation, FieldsNameTheirShells) {
  const Geometry g = cube(32, 1.0);
  const LabelVolume labels = labelsOf(sphereMask(g, 10.0), 1, "ball");
  ill::ShapeOptions opt;
  opt.targetFaces = 0;
  const auto r = ill::runShapePipeline(labels, {ill::parseSegmentSpec("ball=1", labels)}, {{"ball", 2.0}}, {}, opt);
  ASSERT_EQ(r.fields.size(), 1u);
  EXPECT_EQ(r.fields[0].shellId, 2);
  EXPECT_FLOAT_EQ(r.fields[0].shellMm, 2.0f);
  EXPECT_EQ(r.segmentation.table()[1].id, 2);
}

TEST(ShapeSegments, SpecErrors) {
  const LabelVolume labels = labelsOf(sphereMask(cube(16), 5), 3, "muscle");
  EXPECT_EQ(ill::parseSegmentSpec("3", labels).name, "muscle");
  EXPECT_EQ(ill::parseSegmentSpec("m=3", labels).ids, std::vector<uint16_t>{3});
  EXPECT_THROW(ill::parseSegmentSpec("m=x", labels), Error);
  EXPECT_THROW(ill::parseSegmentSpec("m=3,", labels), Error);
  EXPECT_THROW(ill::parseSegmentSpec("m=99", labels), Error);
  EXPECT_THROW(ill::parseSegmentSpec("=3", labels), Error);
  EXPECT_THROW(ill::parseSegmentSpec("m=", labels), Error);
  EXPECT_THROW(ill::parseSegmentSpec("3,4", labels), Error);
  EXPECT_THROW(ill::runShapePipeline(labels, {ill::parseSegmentSpec("3", labels)}, {{"bone", 1.0}}, {}, {}),
               Error);
}

TEST(ShapeMeshIo, PlyObjStlLayouts) {
  const auto dir = test::tempDir("shape-mesh-io");
  const auto mesh = icosphere(5.0, 2);  // 162 vertices, 320 faces
  ASSERT_EQ(mesh.vertices.size(), 162u);
  ASSERT_EQ(mesh.faces.size(), 320u);
  ill::saveMesh(mesh, dir / "m.ply", "ply");
  ill::saveMesh(mesh, dir / "m.obj", "obj");
  ill::saveMesh(mesh, dir / "m.stl", "stl");
  EXPECT_THROW(ill::saveMesh(mesh, dir / "m.off", "off"), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.off"));
  // PLY: ASCII header, then 3 floats a vertex and (uchar 3 + 3 int32) a face.
  std::ifstream ply(dir / "m.ply", std::ios::binary);
  std::string line, header;
  while (std::getline(ply, line)) {
    header += line + "\n";
    if (line == "end_header") break;
  }
  EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(header.find("element vertex 162"), std::string::npos);
  EXPECT_NE(header.find("element face 320"), std::string::npos);
  EXPECT_EQ(std::filesystem::file_size(dir / "m.ply"), header.size() + 162u * 12 + 320u * 13);
  // OBJ: one "v" line a vertex, one "f" line a face (1-based).
  std::ifstream obj(dir / "m.obj");
  int v = 0, f = 0, maxIndex = 0;
  while (std::getline(obj, line)) {
    if (line.rfind("v ", 0) == 0) ++v;
    if (line.rfind("f ", 0) == 0) {
      ++f;
      std::istringstream ss(line.substr(2));
      int a, b, c;
      ss >> a >> b >> c;
      maxIndex = std::max({maxIndex, a, b, c});
      EXPECT_GE(std::min({a, b, c}), 1);
    }
  }
  EXPECT_EQ(v, 162);
  EXPECT_EQ(f, 320);
  EXPECT_EQ(maxIndex, 162);
  // STL: 80-byte header, face count, 50 bytes a face; normals point outward.
  EXPECT_EQ(std::filesystem::file_size(dir / "m.stl"), 84u + 50u * 320);
  std::ifstream stl(dir / "m.stl", std::ios::binary);
  stl.seekg(80);
  uint32_t count = 0;
  stl.read(reinterpret_cast<char*>(&count), 4);
  EXPECT_EQ(count, 320u);
  float rec[12];
  stl.read(reinterpret_cast<char*>(rec), 48);
  const Vec3 n{rec[0], rec[1], rec[2]};
  const Vec3 c = (Vec3{rec[3], rec[4], rec[5]} + Vec3{rec[6], rec[7], rec[8]} + Vec3{rec[9], rec[10], rec[11]}) * (1.0 / 3);
  EXPECT_GT(dot(n, c), 0.0);
  EXPECT_NEAR(norm(n), 1.0, 1e-5);
}

TEST(ShapeMesh, MirroredRotatedGridKeepsOutwardMeshesAndSigns) {
  // A grid whose direction mirrors and rotates the index axes: meshes must still be outward
  // in physical space, and the distance volume negative exactly inside the ball.
  Geometry g = cube(36, 0.8);
  g.direction = Mat3{};
  // columns: i -> -x, j -> z, k -> -y (determinant -1)
  g.direction(0, 0) = -1; g.direction(1, 0) = 0;  g.direction(2, 0) = 0;
  g.direction(0, 1) = 0;  g.direction(1, 1) = 0;  g.direction(2, 1) = 1;
  g.direction(0, 2) = 0;  g.direction(1, 2) = -1; g.direction(2, 2) = 0;
  g.origin = {0.5 * 35 * 0.8, 0.5 * 35 * 0.8, -0.5 * 35 * 0.8};
  ASSERT_LT(g.direction.determinant(), 0);
  const Vec3 centre{2.0, -1.0, 1.5};
  VolumeU8 m(g, 0);
  for (int64_t k = 0; k < 36; ++k)
    for (int64_t j = 0; j < 36; ++j)
      for (int64_t i = 0; i < 36; ++i)
        m(i, j, k) = norm(g.indexToPhysical(Vec3{double(i), double(j), double(k)}) - centre) < 9.0;
  const LabelVolume labels = labelsOf(m, 2, "ball");
  ill::ShapeOptions opt;
  opt.targetFaces = 2000;
  const auto r = ill::runShapePipeline(labels, {ill::parseSegmentSpec("2", labels)}, {}, {}, opt);
  expectCleanMesh(r.shapes[0]);
  EXPECT_NEAR(r.shapes[0].checks.volumeMm3, 4.0 / 3 * M_PI * 729, 0.06 * 4.0 / 3 * M_PI * 729);
  int64_t wrong = 0;
  for (int64_t k = 0; k < 36; ++k)
    for (int64_t j = 0; j < 36; ++j)
      for (int64_t i = 0; i < 36; ++i) {
        const double a = norm(g.indexToPhysical(Vec3{double(i), double(j), double(k)}) - centre) - 9.0;
        if (std::abs(a) > 0.8 && (a < 0) != (r.distance(i, j, k) < 0)) ++wrong;
        if (std::abs(a) > 0.8 && (a < 0) != (r.segmentation(i, j, k) == 1)) ++wrong;
      }
  EXPECT_EQ(wrong, 0);
}
