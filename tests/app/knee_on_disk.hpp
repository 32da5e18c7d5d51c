#pragma once
// The small knee the deform and animate pipeline tests start from: a 32x32x40 phantom written
// as ct.nrrd and labels.nrrd into a fresh temporary folder (removed when the test ends), and
// the ids of its bones.
#include <filesystem>
#include <string>
#include <vector>

#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::test {

/// The phantom's bones: cortex and marrow of femur and tibia, fibula, patella, cancellous bone.
inline const std::vector<uint16_t> kKneeBones = {4, 5, 6, 7, 8, 9, 11};

struct KneeOnDisk {
  std::filesystem::path dir, ct, labels;
  phantom::Phantom ph;
};

inline KneeOnDisk writeKnee(const std::string& name) {
  KneeOnDisk k;
  k.dir = tempDir(name);
  phantom::PhantomOptions o;
  o.dims = {32, 32, 40};
  k.ph = phantom::makePhantom(o);
  k.ct = k.dir / "ct.nrrd";
  k.labels = k.dir / "labels.nrrd";
  io::saveVolume(k.ph.ct, k.ct);
  io::saveLabels(k.ph.labels, k.labels);
  return k;
}

}  // namespace vellum::test
