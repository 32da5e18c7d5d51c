// `vellum deform --attributes-out` + `vellum render --attributes`: the exported deformed volume,
// rendered with its attribute field, looks like the live deformed render (GL, node map + snap +
// Gaussian upsampling + attributes) of the same deformation.
#include <gtest/gtest.h>

#include <iostream>

#include "child_process.hpp"
#include "image_compare.hpp"
#include "scene.hpp"
#include "phantom_files.hpp"
#include "test_data.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/volume_renderer.hpp"

using namespace vellum;
using namespace vellum::deformation;
namespace fs = std::filesystem;

namespace {

int vellumCli(const std::vector<std::string>& args, const fs::path& log, std::string* out = nullptr) {
  test::Child child(args, log);
  const int rc = child.wait();
  if (out) *out = child.errors();
  return rc;
}

const std::vector<uint16_t> kBones = {4, 5, 6, 7, 8, 9, 11};

}  // namespace

TEST(WysiwygCli, DeformedVolumeWithItsAttributeFieldRendersLikeTheLiveRender) {
  const fs::path dir = test::tempDir("wysiwyg-cli");
  const phantom::Phantom ph = test::writePhantomFiles(dir, {64, 64, 72});
  PointFile pf;
  pf.points = kneeBendTrack(ph.ct.geometry(), 30.0, 2.0, phantom::flexionAxisPointMm()).keyframes[1].points;
  pf.points[0].attributes.lightness = 30;
  pf.points[1].attributes.a = 25;
  pf.points[1].attributes.density = 1.5;
  saveControlPoints(pf, dir / "cp.json");
  std::string log;
  ASSERT_EQ(vellumCli({"deform", (dir / "ct.nrrd").string(), "--points", (dir / "cp.json").string(), "--labels",
                       (dir / "labels.nrrd").string(), "--rigid-labels", "4,5,6,7,8,9,11", "--upsampling", "gaussian",
                       "--out", (dir / "bent.nrrd").string(), "--attributes-out", (dir / "attr.nrrd").string()},
                      dir / "deform.log", &log),
            0)
      << log;
  const std::vector<std::string> view = {"--size", "128x128", "--azimuth", "90", "--elevation", "5", "--shading=false"};
  auto render = [&](const std::vector<std::string>& extra, const fs::path& png) {
    std::vector<std::string> args = {"render", (dir / "bent.nrrd").string(), "--out", png.string()};
    args.insert(args.end(), view.begin(), view.end());
    args.insert(args.end(), extra.begin(), extra.end());
    std::string err;
    EXPECT_EQ(vellumCli(args, dir / "render.log", &err), 0) << err;
    return io::loadImage(png);
  };
  const RgbaImage exported = render({"--attributes", (dir / "attr.nrrd").string()}, dir / "with.png");
  const RgbaImage withoutAttributes = render({}, dir / "without.png");

  // The live render of the same deformation (same defaults as the CLI: DeformParams{}, falloff 10 mm).
  Deformer deformer(AnyVolume(ph.ct), DeformParams{});
  deformer.setPoints(pf.points);
  ControlVolume cv = deformer.update();
  applyRigidity(cv, RigidBodies::fromLabels(ph.labels, kBones), {10.0});
  ASSERT_FALSE(cv.attributes.empty());
  Geometry fieldGrid;
  EXPECT_EQ(loadAttributeFieldNrrd(dir / "attr.nrrd", &fieldGrid), cv.attributes);  // exact floats
  EXPECT_TRUE(fieldGrid.dims == cv.grid.dims && fieldGrid.approxEqual(cv.grid));
  auto context = render::GlContext::createHeadless();
  render::VolumeRenderer renderer(*context);
  renderer.setVolume(AnyVolume(ph.ct));
  const render::BackwardMap live = deformation::renderedMap(cv, ph.ct.geometry(), Upsampling::Gaussian);
  renderer.setBackwardMap(&live);
  render::RenderSettings s;
  s.width = s.height = 128;
  s.camera.azimuthDeg = 90;
  s.camera.elevationDeg = 5;
  s.shading = false;
  const RgbaImage liveFrame = renderer.render(s);

  const test::ImageDiff with = test::compareImages(liveFrame, exported);
  const test::ImageDiff without = test::compareImages(liveFrame, withoutAttributes);
  std::cout << "[ diff ] live vs `vellum render --attributes`: psnr " << with.psnr << " dB; without --attributes "
            << without.psnr << " dB\n";
  EXPECT_GE(with.psnr, 40.0);
  EXPECT_GT(with.psnr, without.psnr + 5.0);  // the attributes are what makes them agree
}

TEST(WysiwygCli, AttributeFieldErrorsNameTheFile) {
  const fs::path dir = test::tempDir("wysiwyg-cli-errors");
  phantom::PhantomOptions o;
  o.dims = {32, 32, 32};
  const phantom::Phantom ph = phantom::makePhantom(o);
  io::saveVolume(ph.ct, dir / "ct.nrrd");
  const ControlVolume cv = identityControlVolume(ph.ct.geometry(), 4);
  // A field for another grid (the volume cropped), and a 3-component file.
  Geometry other = cv.grid;
  other.origin = other.origin + Vec3{10, 0, 0};
  saveAttributeFieldNrrd(std::vector<float>(4 * other.dims.voxelCount(), 0.f), other, dir / "shifted.nrrd");
  saveBackwardMapNrrd(cv.sourceMm, cv.grid, dir / "map.nrrd");
  for (const char* file : {"shifted.nrrd", "map.nrrd", "missing.nrrd"}) {
    std::string err;
    EXPECT_NE(vellumCli({"render", (dir / "ct.nrrd").string(), "--size", "32x32", "--attributes",
                         (dir / file).string(), "--out", (dir / "x.png").string()},
                        dir / "err.log", &err),
              0);
    EXPECT_NE(err.find(file), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(dir / "x.png")) << file;
  }
}
