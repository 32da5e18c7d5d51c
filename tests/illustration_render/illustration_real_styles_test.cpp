// Issue 21, section 3, on real data (labels data, long): x-ray's empty-space skipping never
// changes the picture on a crop of the feet CT, and pen's creases and lines are the CPU
// reference's (GL = CPU). Skips without the data.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

#include "headless_gl.hpp"
#include "image_compare.hpp"
#include "test_data.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/illustration/style.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::illustration {
namespace {

render::GlContext& gl() { return test::headlessGl(); }

RgbaImage gpu(const ShapeScene& scene, const Style& st, const IllustrationSettings& s) {
  IllustrationRenderer r(gl());
  r.setScene(scene);
  return r.render(st, s);
}

IllustrationSettings front(int size, std::array<float, 4> background) {
  IllustrationSettings s;
  s.render.width = s.render.height = size;
  s.render.camera.fieldOfViewDeg = 0;
  s.render.background = background;
  return s;
}

void maybeSave(const RgbaImage& img, const std::string& name) {
  if (const char* dir = std::getenv("VELLUM_ILLUSTRATION_PNG_DIR"); dir && *dir) {
    std::filesystem::create_directories(dir);
    test::writePng(img, std::filesystem::path(dir) / (name + ".png"));
  }
}

/// The same on a crop of a real CT (feet, Visible Human Female): skin and bone by threshold,
/// nested as in the user guide, x-ray preset at zoom 1.8. Skips without the sample data.
TEST(IllustrationStyles, XrayGlEqualsCpuOnARealCrop) {
  VELLUM_REQUIRE_DATA("ct-feet-vhf");
  const VolumeF32 full = toFloat32(io::loadVolume(test::dataDir() / "ct-feet-vhf").volume);
  // 64 x 64 x 40 voxels (1 mm) around the centre of the bone (> 400 HU) of one foot (x < half).
  const Dims fd = full.dims();
  double si = 0, sj = 0, sk = 0, sn = 0;
  for (int64_t k = 0; k < fd.z; ++k)
    for (int64_t j = 0; j < fd.y; ++j)
      for (int64_t i = 0; i < fd.x / 2; ++i)
        if (full(i, j, k) > 400) si += double(i), sj += double(j), sk += double(k), sn += 1;
  ASSERT_GT(sn, 1000);
  const int64_t i0 = std::clamp<int64_t>(int64_t(si / sn) - 32, 0, fd.x - 64);
  const int64_t j0 = std::clamp<int64_t>(int64_t(sj / sn) - 32, 0, fd.y - 64);
  const int64_t k0 = std::clamp<int64_t>(int64_t(sk / sn) - 20, 0, fd.z - 40);
  Geometry g = full.geometry();
  g.dims = {64, 64, 40};
  g.origin = full.geometry().indexToPhysical({double(i0), double(j0), double(k0)});
  VolumeU16 ids(g, 0);
  VolumeF32 ct(g, 0.f);
  int64_t bone = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const float v = full(i0 + i, j0 + j, k0 + k);
        ct(i, j, k) = v;
        ids(i, j, k) = v > 200 ? 2 : v > -300 ? 1 : 0;
        bone += v > 200;
      }
  ASSERT_GT(bone, 5000) << "the crop should hold bone";
  const LabelVolume labels(std::move(ids), {{1, "skin", {200, 150, 120}}, {2, "bone", {240, 230, 200}}});
  ShapeOptions opt;
  const ShapeResult r = runShapePipeline(labels, {parseSegmentSpec("skin=1,2", labels), parseSegmentSpec("bone=2", labels)},
                                         {}, {}, opt);
  ShapeScene scene;
  scene.distance = r.distance;
  scene.segments = r.segmentation;
  scene.fields = r.fields;
  const Style st = stylePreset("x-ray");
  IllustrationSettings s = front(128, {0.02f, 0.03f, 0.05f, 1});
  s.render.camera.azimuthDeg = 20;
  s.render.camera.elevationDeg = 50;
  s.render.camera.zoom = 1.8;
  const RgbaImage a = gpu(scene, st, s), b = renderIllustrationCpu(scene, st, s);
  maybeSave(a, "xray-real-crop");
  const test::ImageDiff d = test::compareImages(a, b);
  std::cout << "[ x-ray ] real crop: max " << d.maxAbs << " psnr " << d.psnr << " dB\n";
  EXPECT_LE(d.maxAbs, 2.0);
  // The pen preset on the same crop (s16): creases probed across 3 voxels, silhouettes and
  // hatching; GL equals the CPU reference (the crease profile is the same steps on both).
  IllustrationSettings w = front(128, {1, 1, 1, 1});
  w.render.camera = s.render.camera;
  const Style pen = stylePreset("pen");
  const RgbaImage pa = gpu(scene, pen, w), pb = renderIllustrationCpu(scene, pen, w);
  maybeSave(pa, "pen-real-crop");
  const test::ImageDiff pd = test::compareImages(pa, pb);
  std::cout << "[ pen ] real crop: mean " << pd.meanAbs[1] << " max " << pd.maxAbs << " psnr " << pd.psnr << " dB\n";
  EXPECT_LE(pd.meanAbs[1], 1.0);
  EXPECT_GE(pd.psnr, 35.0);
}

}  // namespace
}  // namespace vellum::illustration
