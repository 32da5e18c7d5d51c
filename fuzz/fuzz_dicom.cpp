// DICOM: the structure pre-check, then GDCM, for one file handed in directly and as a folder.
#include "fuzz_harness.hpp"
#include "vellum/io/volume_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace fs = std::filesystem;
  const fs::path folder = vellum::fuzz::scratchDir() / "series";
  fs::create_directories(folder);
  const auto file = vellum::fuzz::writeInput(data, size, "series/slice.dcm");
  vellum::fuzz::expectCleanRefusal([&] { (void)vellum::io::loadVolume(file); });
  vellum::fuzz::expectCleanRefusal([&] { (void)vellum::io::loadVolume(folder); });
  vellum::fuzz::expectCleanRefusal([&] { (void)vellum::io::listDicomSeries(folder); });
  return 0;
}
