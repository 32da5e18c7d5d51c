// Integration with the third-party samples in ../shared/data: VTK headsq (bare raw + index.json
// geometry) and the CT head phantom DICOM series converted to every writable format.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "io_test_util.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {

/// index.json comes from vtk.js, whose vtkImageData stores `direction` as a gl-matrix mat3,
/// i.e. COLUMN-major: numbers 0-2 are the physical direction of the i axis. Here that is
/// (0.866, 0.5, 0): the i axis rotated +30 degrees about z, as the data README says.
io::RawLayout headsqLayout() {
  const auto j = nlohmann::json::parse(readFile(dataDir() / "headsq" / "index.json"));
  io::RawLayout r;
  r.dims = {64, 64, 93};
  r.type = VoxelType::Int16;
  r.endian = io::Endian::Little;
  r.spacing = {j["spacing"][0].get<double>(), j["spacing"][1].get<double>(), j["spacing"][2].get<double>()};
  r.origin = {j["origin"][0].get<double>(), j["origin"][1].get<double>(), j["origin"][2].get<double>()};
  const auto& d = j["direction"];
  r.direction = Mat3::fromColumns({d[0].get<double>(), d[1].get<double>(), d[2].get<double>()},
                                  {d[3].get<double>(), d[4].get<double>(), d[5].get<double>()},
                                  {d[6].get<double>(), d[7].get<double>(), d[8].get<double>()});
  return r;
}

}  // namespace

TEST(Headsq, RawLoadsWithIndexJsonGeometryAndConvertsWithDirectionIntact) {
  VELLUM_REQUIRE_DATA("headsq/headsq_64x64x93_int16.raw");
  io::LoadOptions opt;
  opt.raw = headsqLayout();
  const io::LoadedVolume lv = io::loadVolume(dataDir() / "headsq" / "headsq_64x64x93_int16.raw", opt);
  ASSERT_TRUE(std::holds_alternative<VolumeI16>(lv.volume));
  const auto& v = std::get<VolumeI16>(lv.volume);
  EXPECT_EQ(v.dims(), (Dims{64, 64, 93}));
  const auto [lo, hi] = v.valueRange();
  EXPECT_EQ(lo, 0);
  EXPECT_EQ(hi, 3926);
  EXPECT_EQ(lv.modality, "");  // 0..3926 is not HU
  EXPECT_EQ(v.background(), 0.0);
  const Geometry& g = v.geometry();
  EXPECT_NEAR(g.spacing.x, 3.2, 1e-12);
  EXPECT_NEAR(g.spacing.z, 1.5, 1e-12);
  // index.json rounds cos 30 to 0.866; the loader scales columns to unit length.
  EXPECT_NEAR(g.direction(0, 0), std::cos(M_PI / 6), 1e-4);
  EXPECT_NEAR(g.direction(1, 0), 0.5, 1e-4);  // i axis points towards +y: rotation +30 deg
  EXPECT_NEAR(g.direction(0, 1), -0.5, 1e-4);
  EXPECT_NEAR(norm(g.direction.column(0)), 1.0, 1e-12);
  EXPECT_NEAR(g.direction.determinant(), 1.0, 1e-12);

  const fs::path dir = tempDir("headsq");
  for (const char* name : {"h.nrrd", "h.vti", "h.mha", "h.raw"}) {
    io::saveVolume(lv.volume, dir / name);
    const auto back = io::loadVolume(dir / name);
    ASSERT_TRUE(std::holds_alternative<VolumeI16>(back.volume)) << name;
    EXPECT_EQ(std::get<VolumeI16>(back.volume).voxels(), v.voxels()) << name;
    expectGeometryNear(g, geometryOf(back.volume), 1e-9);
    EXPECT_EQ(back.modality, "") << name;
    // A voxel's physical position survives the trip.
    const Vec3 p0 = g.indexToPhysical({10, 20, 30});
    const Vec3 p1 = geometryOf(back.volume).indexToPhysical({10, 20, 30});
    EXPECT_NEAR(norm(p0 - p1), 0.0, 1e-9) << name;
  }
}

TEST(CtHeadPhantom, DicomConvertsToEveryFormatAndBackExactly) {
  VELLUM_REQUIRE_DATA("ct-head-phantom");
  const io::LoadedVolume dcm = io::loadVolume(dataDir() / "ct-head-phantom");
  ASSERT_EQ(dcm.format, "dicom");
  ASSERT_TRUE(std::holds_alternative<VolumeI16>(dcm.volume));
  const auto& ct = std::get<VolumeI16>(dcm.volume);
  EXPECT_EQ(ct.dims(), (Dims{512, 512, 28}));
  EXPECT_EQ(dcm.modality, "CT");
  const fs::path dir = tempDir("phantom-convert");
  for (const char* name : {"p.nrrd", "p.mha", "p.vti"}) {
    io::saveVolume(dcm.volume, dir / name);
    const auto back = io::loadVolume(dir / name);
    EXPECT_EQ(back.modality, "CT") << name;
    EXPECT_EQ(backgroundOf(back.volume), -1000.0) << name;
    ASSERT_TRUE(std::holds_alternative<VolumeI16>(back.volume)) << name;
    EXPECT_EQ(std::get<VolumeI16>(back.volume).voxels(), ct.voxels()) << name;
    expectGeometryNear(ct.geometry(), geometryOf(back.volume), 1e-9);
  }
}
