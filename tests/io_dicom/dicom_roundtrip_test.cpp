// Writing a series and reading it back: voxels, geometry, tags, encodings, series choice.
#include <gtest/gtest.h>

#include <set>

#include "dicom_test_support.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::test {
namespace {

using io::detail::loadDicom;
using io::detail::saveDicomSeries;

void expectSameGeometry(const Geometry& a, const Geometry& b) {
  EXPECT_EQ(a.dims, b.dims);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(a.spacing[c], b.spacing[c], 1e-4) << "spacing " << c;
    EXPECT_NEAR(a.origin[c], b.origin[c], 1e-4) << "origin " << c;
  }
  EXPECT_LT(maxAbsDiff(a.direction, b.direction), 1e-5);
}

TEST(DicomRoundTrip, RotatedAnisotropicInt16IsIdentical) {
  const fs::path dir = tempDir("dicom-rt") / "series";
  VolumeI16 v = makeVolume();
  v(0, 0, 0) = -32768;  // extremes survive (stored directly, slope 1, intercept 0)
  v(11, 9, 5) = 32767;
  saveDicomSeries(v, dir, {});
  EXPECT_EQ(sliceFiles(dir).size(), 6u);

  const io::LoadedVolume loaded = loadDicom(dir, {});
  ASSERT_TRUE(std::holds_alternative<VolumeI16>(loaded.volume));
  const auto& r = std::get<VolumeI16>(loaded.volume);
  expectSameGeometry(r.geometry(), v.geometry());
  EXPECT_EQ(r.voxels(), v.voxels());
  EXPECT_EQ(r.background(), kCtAirHu);
  EXPECT_EQ(loaded.format, "dicom");
  EXPECT_EQ(loaded.modality, "CT");
  EXPECT_TRUE(loaded.warnings.empty()) << joined(loaded.warnings);
  ASSERT_EQ(loaded.series.size(), 1u);
  EXPECT_EQ(loaded.series[0].fileCount, 6);
  EXPECT_EQ(loaded.series[0].rows, 10);
  EXPECT_EQ(loaded.series[0].columns, 12);
  EXPECT_EQ(loaded.seriesUid, loaded.series[0].uid);
}

TEST(DicomRoundTrip, WrittenTagsFollowTheStandard) {
  const fs::path dir = tempDir("dicom-tags") / "series";
  const VolumeI16 v = makeVolume();
  saveDicomSeries(v, dir, {});
  const auto files = sliceFiles(dir);
  ASSERT_EQ(files.size(), 6u);
  EXPECT_EQ(getTag(files[0], 0x0008, 0x0016), "1.2.840.10008.5.1.4.1.1.2");
  EXPECT_EQ(getTag(files[0], 0x0008, 0x0060), "CT");
  EXPECT_EQ(getTag(files[0], 0x0010, 0x0010), "Vellum^Phantom");
  EXPECT_EQ(getTag(files[0], 0x0028, 0x0030), "0.9\\0.7");  // row spacing (y) first
  EXPECT_EQ(getTag(files[0], 0x0028, 0x1052), "0");
  EXPECT_EQ(getTag(files[0], 0x0028, 0x1053), "1");
  EXPECT_EQ(getTag(files[0], 0x0018, 0x0088), "2.5");
  EXPECT_EQ(getTag(files[2], 0x0020, 0x0013), "3");
  // One study/series/frame-of-reference UID, unique instance UIDs.
  std::set<std::string> sops;
  for (const auto& f : files) {
    EXPECT_EQ(getTag(f, 0x0020, 0x000e), getTag(files[0], 0x0020, 0x000e));
    EXPECT_EQ(getTag(f, 0x0020, 0x000d), getTag(files[0], 0x0020, 0x000d));
    EXPECT_EQ(getTag(f, 0x0020, 0x0052), getTag(files[0], 0x0020, 0x0052));
    sops.insert(getTag(f, 0x0008, 0x0018));
  }
  EXPECT_EQ(sops.size(), files.size());
  EXPECT_NE(getTag(files[0], 0x0020, 0x000e), getTag(files[0], 0x0020, 0x000d));
  // IPP of slice 3 = origin + third direction column * 2 * 2.5 mm.
  const Vec3 p = v.geometry().indexToPhysical({0, 0, 2});
  double x, y, z;
  ASSERT_EQ(std::sscanf(getTag(files[2], 0x0020, 0x0032).c_str(), "%lf\\%lf\\%lf", &x, &y, &z), 3);
  EXPECT_NEAR(x, p.x, 1e-9);
  EXPECT_NEAR(y, p.y, 1e-9);
  EXPECT_NEAR(z, p.z, 1e-9);
}

TEST(DicomRoundTrip, Uint8AndLargeUint16AreExact) {
  // uint8 is stored as is; uint16 above 32767 is shifted with intercept 32768.
  Geometry g;
  g.dims = {5, 4, 3};
  g.spacing = {1, 1, 2};
  VolumeU16 u(g);
  for (size_t n = 0; n < u.size(); ++n) u.voxels()[n] = static_cast<uint16_t>(n * 1000 + 5);  // up to 59005
  const fs::path dir = tempDir("dicom-u16") / "series";
  io::SaveOptions options;
  options.modality = "MR";
  saveDicomSeries(u, dir, options);
  EXPECT_EQ(getTag(sliceFiles(dir)[0], 0x0008, 0x0016), "1.2.840.10008.5.1.4.1.1.7");
  const io::LoadedVolume loaded = loadDicom(dir, {});
  EXPECT_EQ(loaded.modality, "MR");
  const auto& r = std::get<VolumeI16>(loaded.volume);
  EXPECT_EQ(r.background(), 0.0);
  // Values above 32767 do not fit the int16 result: they are clamped, and a warning says so.
  int64_t exact = 0, clamped = 0;
  for (size_t n = 0; n < u.size(); ++n) {
    if (u.voxels()[n] <= 32767) exact += r.voxels()[n] == u.voxels()[n];
    else clamped += r.voxels()[n] == 32767;
  }
  EXPECT_EQ(exact, 33);
  EXPECT_EQ(clamped, 27);
  EXPECT_TRUE(contains(loaded.warnings, "clamped")) << joined(loaded.warnings);

  VolumeU8 b(g);
  for (size_t n = 0; n < b.size(); ++n) b.voxels()[n] = static_cast<uint8_t>(n * 4);
  saveDicomSeries(b, dir, {});  // replaces the folder atomically
  EXPECT_EQ(sliceFiles(dir).size(), 3u);
  const VolumeI16 rb = loadI16(dir);
  for (size_t n = 0; n < b.size(); ++n) EXPECT_EQ(rb.voxels()[n], b.voxels()[n]);
}

TEST(DicomRoundTrip, FloatUsesSlopeThatKeepsPrecision) {
  Geometry g;
  g.dims = {6, 5, 2};
  VolumeF32 f(g);
  for (size_t n = 0; n < f.size(); ++n) f.voxels()[n] = -1000.0f + 37.25f * static_cast<float>(n);
  const fs::path dir = tempDir("dicom-float") / "series";
  saveDicomSeries(f, dir, {});
  const fs::path file = sliceFiles(dir)[0];
  const double slope = std::stod(getTag(file, 0x0028, 0x1053));
  const double intercept = std::stod(getTag(file, 0x0028, 0x1052));
  const double range = 37.25 * 59;  // over 65534 steps, centred
  EXPECT_NEAR(slope, range / 65534.0, 1e-12);
  EXPECT_NEAR(intercept, -1000 + range / 2, 1e-9);
  // Read back as HU integers: each value within 0.5 + half a slope step.
  const VolumeI16 r = loadI16(dir);
  for (size_t n = 0; n < f.size(); ++n) EXPECT_NEAR(r.voxels()[n], f.voxels()[n], 0.5 + slope);
}

TEST(DicomRoundTrip, NonCtFloatReadsBackAsFloat) {
  Geometry g;
  g.dims = {6, 5, 3};
  VolumeF32 f(g);
  for (size_t n = 0; n < f.size(); ++n) f.voxels()[n] = 0.125f * static_cast<float>(n) - 3.3f;  // a dose map, say
  const fs::path dir = tempDir("dicom-float-ot") / "series";
  io::SaveOptions o;
  o.modality = "OT";
  io::saveVolume(f, dir, o);
  const double slope = std::stod(getTag(sliceFiles(dir)[0], 0x0028, 0x1053));
  const io::LoadedVolume lv = io::loadVolume(dir);
  ASSERT_TRUE(std::holds_alternative<VolumeF32>(lv.volume)) << "rounded to integers";
  const VolumeF32& r = std::get<VolumeF32>(lv.volume);
  for (size_t n = 0; n < f.size(); ++n) EXPECT_NEAR(r.voxels()[n], f.voxels()[n], 0.5 * slope + 1e-5);
  for (const auto& w : lv.warnings) EXPECT_EQ(w.find("rounded"), std::string::npos) << w;
  EXPECT_EQ(getTag(sliceFiles(dir)[0], 0x0018, 0x5100), "HFS");  // Patient Position
}

TEST(DicomRoundTrip, IntegralFloatIsStoredExactly) {
  Geometry g;
  g.dims = {4, 4, 2};
  VolumeF32 f(g);
  for (size_t n = 0; n < f.size(); ++n) f.voxels()[n] = static_cast<float>(n) * 100 - 1500;
  const fs::path dir = tempDir("dicom-float-int") / "series";
  saveDicomSeries(f, dir, {});
  EXPECT_EQ(getTag(sliceFiles(dir)[0], 0x0028, 0x1053), "1");
  const VolumeI16 r = loadI16(dir);
  for (size_t n = 0; n < f.size(); ++n) EXPECT_EQ(r.voxels()[n], f.voxels()[n]);
}

TEST(DicomRoundTrip, ThroughThePublicApi) {
  const fs::path dir = tempDir("dicom-public") / "series";
  const VolumeI16 v = makeVolume({8, 7, 4});
  io::saveVolume(v, dir, {});  // a path without extension is a DICOM folder
  const io::LoadedVolume loaded = io::loadVolume(dir);
  EXPECT_EQ(loaded.format, "dicom");
  EXPECT_EQ(std::get<VolumeI16>(loaded.volume).voxels(), v.voxels());
  // A single slice file also loads (one slice; spacing from SpacingBetweenSlices).
  const io::LoadedVolume one = io::loadVolume(sliceFiles(dir)[1]);
  const auto& s = std::get<VolumeI16>(one.volume);
  EXPECT_EQ(s.dims(), (Dims{8, 7, 1}));
  EXPECT_NEAR(s.geometry().spacing.z, 2.5, 1e-9);
  const Vec3 p = v.geometry().indexToPhysical({0, 0, 1});
  EXPECT_NEAR(norm(s.geometry().origin - p), 0, 1e-4);
  for (int64_t j = 0; j < 7; ++j)
    for (int64_t i = 0; i < 8; ++i) EXPECT_EQ(s(i, j, 0), v(i, j, 1));

  const auto listed = io::listDicomSeries(dir);
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].fileCount, 4);
  EXPECT_EQ(listed[0].frames, 4);
  EXPECT_EQ(listed[0].modality, "CT");
  EXPECT_EQ(listed[0].description, "Vellum");
}

TEST(DicomRoundTrip, PicksLargestCtSeriesOrTheRequestedOne) {
  const fs::path root = tempDir("dicom-two");
  saveDicomSeries(makeVolume({6, 5, 3}), root / "small", {});
  saveDicomSeries(makeVolume({6, 5, 5}), root / "large", {});
  const io::LoadedVolume def = loadDicom(root, {});
  ASSERT_EQ(def.series.size(), 2u);
  EXPECT_EQ(geometryOf(def.volume).dims.z, 5);
  EXPECT_TRUE(contains(def.warnings, "found 2 series")) << joined(def.warnings);
  const std::string smallUid = def.series[1].uid;
  EXPECT_EQ(def.series[1].frames, 3);
  io::LoadOptions options;
  options.seriesUid = smallUid;
  const io::LoadedVolume picked = loadDicom(root, options);
  EXPECT_EQ(geometryOf(picked.volume).dims.z, 3);
  EXPECT_EQ(picked.seriesUid, smallUid);
  options.seriesUid = "1.2.3.4";
  try {
    loadDicom(root, options);
    FAIL() << "unknown series accepted";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("1.2.3.4 not found"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(smallUid), std::string::npos) << e.what();
  }
}

TEST(DicomRoundTrip, ProgressReportsAndCancels) {
  const fs::path dir = tempDir("dicom-progress") / "series";
  saveDicomSeries(makeVolume({8, 8, 6}), dir, {});
  std::vector<std::string> stages;
  double last = 0;
  Progress p([&](const std::string& stage, double f) {
    if (stages.empty() || stages.back() != stage) stages.push_back(stage);
    last = f;
  });
  io::LoadOptions options;
  options.progress = &p;
  loadDicom(dir, options);
  EXPECT_GE(stages.size(), 2u);
  EXPECT_DOUBLE_EQ(last, 1.0);

  Progress cancelling;
  cancelling.cancel();
  options.progress = &cancelling;
  EXPECT_THROW(loadDicom(dir, options), Cancelled);
  io::SaveOptions saveOptions;
  saveOptions.progress = &cancelling;
  const fs::path other = dir.parent_path() / "cancelled";
  EXPECT_THROW(saveDicomSeries(makeVolume({8, 8, 6}), other, saveOptions), Cancelled);
  EXPECT_FALSE(fs::exists(other));  // atomic: nothing half-written is left
}

}  // namespace
}  // namespace vellum::test
