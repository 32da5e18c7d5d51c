#pragma once
// Helpers for the DICOM tests: a small volume with a rotated direction and known values, and
// tag editing of written files through GDCM (tests may include GDCM; the library API does not).
#include <gdcmDataElement.h>
#include <gdcmReader.h>
#include <gdcmWriter.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "dicom.hpp"
#include "test_data.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::test {

namespace fs = std::filesystem;

/// Rotation about x then z (degrees): a direction with no zero entries.
inline Mat3 rotatedDirection(double degX = 20, double degZ = 30) {
  const double a = degX * M_PI / 180, b = degZ * M_PI / 180;
  Mat3 rx, rz;
  rx.m = {{{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}}};
  rz.m = {{{std::cos(b), -std::sin(b), 0}, {std::sin(b), std::cos(b), 0}, {0, 0, 1}}};
  return rz * rx;
}

/// Known, position-dependent values (quadratic in k so linear interpolation is detectable).
inline int16_t knownValue(int64_t i, int64_t j, int64_t k) {
  return static_cast<int16_t>(7 * i - 13 * j + 40 * k * k - 500);
}

inline VolumeI16 makeVolume(Dims dims = {12, 10, 6}, Vec3 spacing = {0.7, 0.9, 2.5},
                            Mat3 direction = rotatedDirection(), Vec3 origin = {-30.25, 12.5, 101.75}) {
  Geometry g;
  g.dims = dims;
  g.spacing = spacing;
  g.direction = direction;
  g.origin = origin;
  VolumeI16 v(g, 0, kCtAirHu);
  for (int64_t k = 0; k < dims.z; ++k)
    for (int64_t j = 0; j < dims.y; ++j)
      for (int64_t i = 0; i < dims.x; ++i) v(i, j, k) = knownValue(i, j, k);
  return v;
}

/// The written slice files in file-name order.
inline std::vector<fs::path> sliceFiles(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename().string().rfind(".vellum-", 0) != 0)  // not the marker
      files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

/// Replaces (or inserts) a text element of a DICOM file in place.
inline void setTag(const fs::path& file, uint16_t group, uint16_t element, const std::string& vr,
                   std::string value, const fs::path& out = {}) {
  gdcm::Reader reader;
  reader.SetFileName(file.string().c_str());
  if (!reader.Read()) throw std::runtime_error("cannot read " + file.string());
  gdcm::File& f = reader.GetFile();
  if (value.size() % 2) value.push_back(vr == "UI" ? '\0' : ' ');
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::GetVRType(vr.c_str()));
  de.SetByteValue(value.data(), static_cast<uint32_t>(value.size()));
  f.GetDataSet().Replace(de);
  gdcm::Writer writer;
  writer.SetFile(f);
  writer.SetFileName((out.empty() ? file : out).string().c_str());
  if (!writer.Write()) throw std::runtime_error("cannot write " + file.string());
}

/// Removes an element of a DICOM file in place.
inline void removeTag(const fs::path& file, uint16_t group, uint16_t element) {
  gdcm::Reader reader;
  reader.SetFileName(file.string().c_str());
  if (!reader.Read()) throw std::runtime_error("cannot read " + file.string());
  gdcm::File& f = reader.GetFile();
  f.GetDataSet().Remove(gdcm::Tag(group, element));
  gdcm::Writer writer;
  writer.SetFile(f);
  writer.SetFileName(file.string().c_str());
  if (!writer.Write()) throw std::runtime_error("cannot write " + file.string());
}

/// Text value of an element ("" when absent), trailing padding removed.
inline std::string getTag(const fs::path& file, uint16_t group, uint16_t element) {
  gdcm::Reader reader;
  reader.SetFileName(file.string().c_str());
  if (!reader.Read()) throw std::runtime_error("cannot read " + file.string());
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  const gdcm::Tag tag(group, element);
  if (!ds.FindDataElement(tag)) return {};
  const gdcm::ByteValue* bv = ds.GetDataElement(tag).GetByteValue();
  if (!bv) return {};
  std::string s(bv->GetPointer(), bv->GetLength());
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return s;
}

inline std::string dsTriple(const Vec3& v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%.10g\\%.10g\\%.10g", v.x, v.y, v.z);
  return buf;
}

/// Loads with default options and returns the int16 volume (by value: no dangling reference).
inline VolumeI16 loadI16(const fs::path& path) {
  io::LoadedVolume l = io::detail::loadDicom(path, {});
  return std::get<VolumeI16>(std::move(l.volume));
}

inline bool contains(const std::vector<std::string>& warnings, const std::string& needle) {
  for (const auto& w : warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

inline std::string joined(const std::vector<std::string>& warnings) {
  std::string s;
  for (const auto& w : warnings) s += "[" + w + "] ";
  return s;
}

}  // namespace vellum::test
