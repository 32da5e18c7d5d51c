// `vellum curve-analogy` end to end on a small phantom shape folder, and its one-line errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "phantom_files.hpp"
#include "test_data.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/illustration/curve_analogy.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {
int run(const std::string& cmd, const std::string& args, const fs::path& log) {
  const std::string line = std::string(VELLUM_CLI_PATH) + " " + cmd + " " + args + " > " + log.string() + " 2>&1";
  return std::system(line.c_str());
}
std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  return {std::istreambuf_iterator<char>(f), {}};
}

class CurveAnalogyCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("vellum-curve-cli-" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    test::writePhantomFiles(*dir_, {48, 48, 48});
    const std::string args = (*dir_ / "ct.nrrd").string() + " --labels " + (*dir_ / "labels.nrrd").string() +
                             " --segment skin=1,2,3,4,5,6,7,8,9,10,11 --segment bone=4,5,6,7,8,9,11 --out " +
                             (*dir_ / "shape").string();
    ASSERT_EQ(run("shape", args, *dir_ / "shape.log"), 0) << slurp(*dir_ / "shape.log");
  }
  static void TearDownTestSuite() {
    if (std::getenv("VELLUM_KEEP_TEST_FILES")) return;
    std::error_code ec;
    fs::remove_all(*dir_, ec);
    delete dir_;
  }
  static fs::path* dir_;
};
fs::path* CurveAnalogyCli::dir_ = nullptr;
}  // namespace

namespace {
/// C1 of the side view (the same proxy and camera as the command, 256x256), bulged on the
/// posterior lower leg: the illustrator's "calf".
illustration::Polyline2 calfCurve(const fs::path& shapeDir) {
  const auto skin = illustration::loadMesh(shapeDir / "meshes" / "skin.ply");
  const LabelVolume labels = io::loadLabels(shapeDir / "segments.nrrd");
  render::RenderSettings s;
  s.width = s.height = 256;
  s.camera.azimuthDeg = 90;
  s.camera.elevationDeg = 0;
  s.camera.fieldOfViewDeg = 0;
  const render::Projection proj(labels.geometry(), s);
  const auto c1 = illustration::projectedOutline(illustration::simplifyProxy(skin, 1500), proj);
  double y0 = 1e9, y1 = -1e9, cx = 0;
  for (const auto& p : c1) { y0 = std::min(y0, p.y); y1 = std::max(y1, p.y); cx += p.x / double(c1.size()); }
  illustration::Polyline2 out;
  for (const auto& p : c1) {
    const double t = (p.y - (y0 + 0.6 * (y1 - y0))) / (0.15 * (y1 - y0));
    out.push_back({p.x < cx ? p.x - 12 * std::exp(-t * t) : p.x, p.y});
  }
  return out;
}
}  // namespace

TEST_F(CurveAnalogyCli, BendsSkinCarriesBoneWritesFolderAndMap) {
  const fs::path d = *dir_;
  const LabelVolume labels = io::loadLabels(d / "shape" / "segments.nrrd");
  nlohmann::json pts = nlohmann::json::array();
  for (const auto& p : calfCurve(d / "shape")) pts.push_back({p.x, p.y});
  std::ofstream(d / "c0.json") << nlohmann::json{{"points", pts}}.dump();

  const fs::path out = d / "bent";
  ASSERT_EQ(run("curve-analogy", (d / "shape").string() + " --segment skin --curve " + (d / "c0.json").string() +
                                     " --size 256x256 --view side --transfer bone --out " + out.string() +
                                     " --map-out " + (d / "map.nrrd").string() + " --map-step 4 --report " +
                                     (d / "r.json").string(),
                d / "ca.log"),
            0)
      << slurp(d / "ca.log");
  for (const char* f : {"distance.nrrd", "segments.nrrd", "shape.json", "meshes/skin.ply", "meshes/bone.ply",
                        "curve_analogy/before_after.png", "curve_analogy/c0_aligned.json"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  const auto r = nlohmann::json::parse(slurp(d / "r.json"));
  EXPECT_LE(r["hausdorff_after_px"].get<double>(), 0.5 * r["hausdorff_before_px"].get<double>());
  const auto j = nlohmann::json::parse(slurp(out / "shape.json"));
  for (const auto& seg : j["segments"]) {
    EXPECT_TRUE(seg["closed"].get<bool>() && seg["manifold"].get<bool>()) << seg["name"];
    EXPECT_EQ(seg["self_intersections"].get<int>(), 0) << seg["name"];
  }
  Geometry g;
  const auto map = deformation::loadBackwardMapNrrd(d / "map.nrrd", &g);
  EXPECT_EQ(g.dims, labels.geometry().dims);
  ASSERT_EQ(map.size(), size_t(g.dims.x * g.dims.y * g.dims.z * 3));
  // The map (trilinear between voxels) sends the deformed skin back onto the original.
  const auto before = illustration::loadMesh(d / "shape" / "meshes" / "skin.ply");
  const auto after = illustration::loadMesh(out / "meshes" / "skin.ply");
  auto sample = [&](const Vec3& mm) {
    const Vec3 q = g.physicalToIndex(mm);
    const int64_t i0 = std::clamp<int64_t>(int64_t(std::floor(q.x)), 0, g.dims.x - 2);
    const int64_t j0 = std::clamp<int64_t>(int64_t(std::floor(q.y)), 0, g.dims.y - 2);
    const int64_t k0 = std::clamp<int64_t>(int64_t(std::floor(q.z)), 0, g.dims.z - 2);
    Vec3 r{0, 0, 0};
    for (int c = 0; c < 8; ++c) {
      const int64_t i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), k = k0 + (c >> 2);
      const double w = (1 - std::abs(q.x - double(i))) * (1 - std::abs(q.y - double(j))) * (1 - std::abs(q.z - double(k)));
      const float* m = &map[size_t(((k * g.dims.y + j) * g.dims.x + i) * 3)];
      r += Vec3{m[0], m[1], m[2]} * w;
    }
    return r;
  };
  const double voxel = std::max({g.spacing.x, g.spacing.y, g.spacing.z});
  double worst = 0, moved = 0;
  for (size_t v = 0; v < after.vertices.size(); v += 7) {
    const Vec3 a{after.vertices[v][0], after.vertices[v][1], after.vertices[v][2]};
    const Vec3 b{before.vertices[v][0], before.vertices[v][1], before.vertices[v][2]};
    const Vec3 q = g.physicalToIndex(a);
    if (q.x < 0 || q.y < 0 || q.z < 0 || q.x > double(g.dims.x - 1) || q.y > double(g.dims.y - 1) ||
        q.z > double(g.dims.z - 1))
      continue;  // the phantom's skin is cut by the volume's ends: the map covers the grid only
    moved = std::max(moved, norm(a - b));
    worst = std::max(worst, norm(sample(a) - b));
  }
  std::printf("skin moved up to %.2f mm; map sends it back within %.3f mm (voxel %.2f mm)\n", moved, worst, voxel);
  EXPECT_GT(moved, voxel);
  EXPECT_LE(worst, voxel);
}

TEST_F(CurveAnalogyCli, DrawingGivesTheOutline) {
  // A pen drawing of the calf outline (3-pixel dark strokes on white, 256x256).
  const fs::path d = *dir_;
  const auto c = calfCurve(d / "shape");
  RgbaImage img(256, 256);
  std::fill(img.pixels.begin(), img.pixels.end(), uint8_t(255));
  for (size_t i = 0; i < c.size(); ++i) {
    const auto& a = c[i];
    const auto& b = c[(i + 1) % c.size()];
    for (double t = 0; t <= 1; t += 0.05)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = int(std::lround(a.x + t * (b.x - a.x))) + dx, y = int(std::lround(a.y + t * (b.y - a.y))) + dy;
          if (x >= 0 && y >= 0 && x < 256 && y < 256) std::fill(img.at(x, y), img.at(x, y) + 3, uint8_t(20));
        }
  }
  io::saveImage(img, d / "calf.png");
  int w = 0, h = 0;
  const auto outline = illustration::loadDrawingOutline(d / "calf.png", w, h);
  EXPECT_EQ(w, 256);
  EXPECT_LE(illustration::hausdorff(outline, c, true, true), 3.5);  // stroke half-width + closing
  ASSERT_EQ(run("curve-analogy", (d / "shape").string() + " --segment skin --drawing " + (d / "calf.png").string() +
                                     " --view side --out " + (d / "bent-drawing").string() + " --report " +
                                     (d / "rd.json").string(),
                d / "cd.log"),
            0)
      << slurp(d / "cd.log");
  const auto r = nlohmann::json::parse(slurp(d / "rd.json"));
  EXPECT_LE(r["hausdorff_after_px"].get<double>(), 0.5 * r["hausdorff_before_px"].get<double>());
}

TEST_F(CurveAnalogyCli, OneLineErrors) {
  const fs::path d = *dir_;
  std::ofstream(d / "bad.json") << "{\"points\": [[1, 2], [3, 4]";
  EXPECT_NE(run("curve-analogy", (d / "shape").string() + " --segment skin --curve " + (d / "bad.json").string() +
                                     " --out " + (d / "x").string(), d / "e1.log"), 0);
  EXPECT_NE(slurp(d / "e1.log").find("bad.json: not valid JSON"), std::string::npos) << slurp(d / "e1.log");
  std::ofstream(d / "ok.json") << "{\"points\": [[1, 2], [30, 4], [10, 40]]}";
  EXPECT_NE(run("curve-analogy", (d / "shape").string() + " --segment liver --curve " + (d / "ok.json").string() +
                                     " --out " + (d / "x").string(), d / "e2.log"), 0);
  EXPECT_NE(slurp(d / "e2.log").find("--segment liver: no such segment"), std::string::npos) << slurp(d / "e2.log");
}
