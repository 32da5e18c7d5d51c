#pragma once
// The CLI tests' input files: a phantom written as a CT and its label map, as the commands
// read them, instead of the same five lines in every end-to-end test.
#include <filesystem>
#include <string>

#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::test {

/// The phantom of `dims` voxels (default options otherwise), its CT written to DIR/ctName and
/// its labels to DIR/labels.nrrd. Returns the phantom (the truth the test compares with).
inline phantom::Phantom writePhantomFiles(const std::filesystem::path& dir, const Dims& dims,
                                          const std::string& ctName = "ct.nrrd") {
  phantom::PhantomOptions options;
  options.dims = dims;
  phantom::Phantom ph = phantom::makePhantom(options);
  io::saveVolume(ph.ct, dir / ctName);
  io::saveLabels(ph.labels, dir / "labels.nrrd");
  return ph;
}

}  // namespace vellum::test
