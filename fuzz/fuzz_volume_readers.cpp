// One harness per volume format, chosen at compile time by VELLUM_FUZZ_EXTENSION (the file
// name the bytes are saved under decides the reader, as it does for users).
#include "fuzz_harness.hpp"
#include "vellum/io/volume_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
#if defined(VELLUM_FUZZ_SIDECAR)
  // The fuzzed bytes are the JSON sidecar (or the detached NRRD header); the data file it
  // names ("input.raw", "data.raw") is a fixed 16^3 int16 block.
  static const bool dataWritten = [] {
    const std::string zeros(16 * 16 * 16 * 2, '\0');
    for (const char* name : {"input.raw", "data.raw"})
      vellum::fuzz::writeInput(reinterpret_cast<const uint8_t*>(zeros.data()), zeros.size(), name);
    return true;
  }();
  (void)dataWritten;
  vellum::fuzz::writeInput(data, size, VELLUM_FUZZ_SIDECAR);
  const auto path = vellum::fuzz::scratchDir() / ("input" VELLUM_FUZZ_EXTENSION);
#else
  const auto path = vellum::fuzz::writeInput(data, size, "input" VELLUM_FUZZ_EXTENSION);
#endif
  vellum::fuzz::expectCleanRefusal([&] {
    vellum::io::LoadOptions o;
#ifdef VELLUM_FUZZ_LABELS
    (void)vellum::io::loadLabels(path, o);
#else
    (void)vellum::io::loadVolume(path, o);
#endif
  });
  return 0;
}
