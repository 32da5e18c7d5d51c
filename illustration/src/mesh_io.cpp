// Mesh export: binary PLY, OBJ, binary STL (what Blender and 3D Slicer import). Atomic.
#include <cmath>
#include <cstring>
#include <fstream>
#include <string>

#include "vellum/core/error.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::illustration {

namespace {
template <class T>
void put(std::ostream& os, T v) {
  os.write(reinterpret_cast<const char*>(&v), sizeof(T));  // x86-64: little endian
}
}  // namespace

void saveMesh(const TriMesh& mesh, const std::filesystem::path& path, const std::string& format) {
  if (format != "ply" && format != "obj" && format != "stl")
    throw Error("mesh format '" + format + "': expected ply, obj or stl");
  io::writeAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream os(tmp, std::ios::binary);
    if (!os) throw FileError(path, "cannot open for writing");
    if (format == "ply") {
      os << "ply\nformat binary_little_endian 1.0\ncomment Vellum shape mesh (mm, LPS)\n"
         << "element vertex " << mesh.vertices.size() << "\nproperty float x\nproperty float y\n"
         << "property float z\nelement face " << mesh.faces.size()
         << "\nproperty list uchar int vertex_indices\nend_header\n";
      for (const auto& v : mesh.vertices)
        for (float c : v) put(os, c);
      for (const auto& f : mesh.faces) {
        put<uint8_t>(os, 3);
        for (uint32_t i : f) put<int32_t>(os, static_cast<int32_t>(i));
      }
    } else if (format == "obj") {
      os << "# Vellum shape mesh (mm, LPS)\n";
      char buf[96];
      for (const auto& v : mesh.vertices) {
        std::snprintf(buf, sizeof buf, "v %.6g %.6g %.6g\n", v[0], v[1], v[2]);
        os << buf;
      }
      for (const auto& f : mesh.faces) os << "f " << f[0] + 1 << ' ' << f[1] + 1 << ' ' << f[2] + 1 << '\n';
    } else {
      char header[80] = {};
      std::strncpy(header, "Vellum shape mesh (mm, LPS)", sizeof header - 1);
      os.write(header, 80);
      put<uint32_t>(os, static_cast<uint32_t>(mesh.faces.size()));
      for (const auto& f : mesh.faces) {
        const auto& a = mesh.vertices[f[0]];
        const auto& b = mesh.vertices[f[1]];
        const auto& c = mesh.vertices[f[2]];
        const float u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const float w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        float nrm[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
        const float len = std::sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        for (float& x : nrm) x = len > 0 ? x / len : 0.0f;
        for (float x : nrm) put(os, x);
        for (const auto* p : {&a, &b, &c})
          for (float x : *p) put(os, x);
        put<uint16_t>(os, 0);
      }
    }
    os.flush();
    if (!os) throw FileError(path, "write failed (disk full?)");
  });
}

TriMesh loadMesh(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  if (!is) throw FileError(path, "cannot open the mesh");
  std::string line;
  int64_t nv = -1, nf = -1;
  bool binary = false;
  while (std::getline(is, line)) {
    if (line.rfind("format binary_little_endian", 0) == 0) binary = true;
    if (line.rfind("element vertex ", 0) == 0) nv = std::stoll(line.substr(15));
    if (line.rfind("element face ", 0) == 0) nf = std::stoll(line.substr(13));
    if (line == "end_header") break;
  }
  if (!binary || nv < 0 || nf < 0)
    throw FileError(path, "not a binary little-endian PLY with vertices and faces (as vellum shape writes)");
  TriMesh m;
  m.vertices.resize(static_cast<size_t>(nv));
  is.read(reinterpret_cast<char*>(m.vertices.data()), static_cast<std::streamsize>(nv * 12));
  m.faces.resize(static_cast<size_t>(nf));
  for (auto& f : m.faces) {
    uint8_t n = 0;
    int32_t idx[3] = {};
    is.read(reinterpret_cast<char*>(&n), 1);
    is.read(reinterpret_cast<char*>(idx), 12);
    if (!is) throw FileError(path, "truncated mesh");
    if (n != 3) throw FileError(path, "only triangle faces are supported");
    for (int i = 0; i < 3; ++i) {
      if (idx[i] < 0 || idx[i] >= nv) throw FileError(path, "face index out of range");
      f[static_cast<size_t>(i)] = static_cast<uint32_t>(idx[i]);
    }
  }
  return m;
}

}  // namespace vellum::illustration
