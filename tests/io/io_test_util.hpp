#pragma once
// Shared fixtures for the io tests: volumes with non-trivial geometry and small file helpers.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "test_data.hpp"
#include "vellum/core/volume.hpp"

namespace vellum::test {

/// Rotation by `deg` degrees about the (normalised) axis `a`.
inline Mat3 rotation(Vec3 a, double deg) {
  a = normalized(a);
  const double t = deg * M_PI / 180.0, c = std::cos(t), s = std::sin(t), C = 1 - c;
  Mat3 r;
  r.m = {{{c + a.x * a.x * C, a.x * a.y * C - a.z * s, a.x * a.z * C + a.y * s},
          {a.y * a.x * C + a.z * s, c + a.y * a.y * C, a.y * a.z * C - a.x * s},
          {a.z * a.x * C - a.y * s, a.z * a.y * C + a.x * s, c + a.z * a.z * C}}};
  return r;
}

/// Anisotropic spacing, non-zero origin, oblique (non axis-aligned) direction.
inline Geometry obliqueGeometry(Dims d = {7, 5, 4}) {
  Geometry g;
  g.dims = d;
  g.spacing = {0.7, 1.3, 2.5};
  g.origin = {-12.5, 33.25, 101.125};
  g.direction = rotation({1, 2, 3}, 37.0);
  return g;
}

/// int16 CT with background -1000 and values from -1024 to ~3000, all distinct-ish.
inline VolumeI16 makeCt(Dims d = {7, 5, 4}) {
  VolumeI16 v(obliqueGeometry(d), 0, -1000.0);
  for (size_t i = 0; i < v.size(); ++i) v.data()[i] = static_cast<int16_t>(-1024 + (i * 37) % 4000);
  return v;
}

template <class T>
Volume<T> makeRamp(double scale, Dims d = {6, 4, 3}) {
  Volume<T> v(obliqueGeometry(d));
  for (size_t i = 0; i < v.size(); ++i) v.data()[i] = static_cast<T>(std::fmod(i * scale, 250.0) + (i % 3) * 0.25 * (std::is_floating_point_v<T>));
  return v;
}

inline void writeFile(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string readFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

template <class T>
std::string bytesOf(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

/// Files in `dir` whose names contain "vellum-tmp" or "vellum-old" (left-over temporaries).
inline int leftoverTemps(const std::filesystem::path& dir) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.find("vellum-tmp") != std::string::npos || name.find("vellum-old") != std::string::npos) ++n;
  }
  return n;
}

inline void expectGeometryNear(const Geometry& a, const Geometry& b, double tol = 1e-5) {
  EXPECT_EQ(a.dims, b.dims);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(a.spacing[i], b.spacing[i], tol) << "spacing " << i;
    EXPECT_NEAR(a.origin[i], b.origin[i], tol) << "origin " << i;
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a.direction(i, j), b.direction(i, j), tol) << "direction " << i << j;
  }
}

}  // namespace vellum::test
