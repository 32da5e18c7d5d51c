#include "vellum/deformation/map_file.hpp"

#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::deformation {
namespace fs = std::filesystem;
namespace {

Vec3 parseVec(const fs::path& path, const std::string& text) {
  Vec3 v;
  char c1 = 0, c2 = 0, c3 = 0, c4 = 0;
  std::istringstream s(text);
  if (!(s >> c1 >> v.x >> c2 >> v.y >> c3 >> v.z >> c4) || c1 != '(' || c2 != ',' || c3 != ',' || c4 != ')' ||
      !std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
    throw FileError(path, "bad vector '" + text + "' in the header");
  return v;
}

}  // namespace

void saveBackwardMapNrrd(const std::vector<float>& map, const Geometry& g, const fs::path& path, bool gzip) {
  if (map.size() != 3 * static_cast<size_t>(g.dims.voxelCount()))
    throw FileError(path, "backward map has " + std::to_string(map.size()) + " floats, the grid " +
                              g.dims.str() + " needs 3 per voxel");
  io::NrrdLayout layout;
  layout.type = "float";
  layout.leadingSizes = {3};
  layout.leadingKinds = {"vector"};
  layout.geometry = g;
  layout.comments = {"Vellum backward map: source position (mm, LPS) of every output voxel"};
  layout.extraFields = "space units: \"mm\" \"mm\" \"mm\"\n";
  io::writeNrrd(path, layout, map.data(), map.size() * sizeof(float), gzip);
}

std::vector<float> loadBackwardMapNrrd(const fs::path& path, Geometry* gridOut) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot open");
  std::string line;
  if (!std::getline(in, line) || line.rfind("NRRD000", 0) != 0) throw FileError(path, "not a NRRD file");
  Geometry g;
  std::string encoding, type, kinds, sizes, dirs, origin;
  while (std::getline(in, line) && !line.empty()) {
    if (line[0] == '#') continue;
    const auto colon = line.find(": ");
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon), value = line.substr(colon + 2);
    if (key == "type") type = value;
    else if (key == "encoding") encoding = value;
    else if (key == "kinds") kinds = value;
    else if (key == "sizes") sizes = value;
    else if (key == "space directions") dirs = value;
    else if (key == "space origin") origin = value;
    else if (key == "endian" && value != "little") throw FileError(path, "big-endian maps are not supported");
  }
  if (type != "float" || kinds != "vector domain domain domain")
    throw FileError(path, "not a Vellum backward map (needs type float, kinds vector domain domain domain)");
  std::istringstream ss(sizes);
  int64_t c = 0, x = 0, y = 0, z = 0;
  if (!(ss >> c >> x >> y >> z) || c != 3 || x < 1 || y < 1 || z < 1) throw FileError(path, "bad sizes '" + sizes + "'");
  g.dims = {x, y, z};
  if (dirs.rfind("none ", 0) != 0) throw FileError(path, "bad space directions '" + dirs + "'");
  std::istringstream ds(dirs.substr(5));
  Vec3 col[3];
  for (auto& v : col) {
    std::string tok;
    if (!(ds >> tok)) throw FileError(path, "bad space directions '" + dirs + "'");
    v = parseVec(path, tok);
  }
  for (int a = 0; a < 3; ++a) {
    g.spacing[a] = norm(col[a]);
    if (!(g.spacing[a] > 0)) throw FileError(path, "zero space direction");
  }
  g.direction = Mat3::fromColumns(col[0] / g.spacing.x, col[1] / g.spacing.y, col[2] / g.spacing.z);
  g.origin = parseVec(path, origin);
  checkMemoryBudget(g.dims, 3 * sizeof(float), "backward map");
  std::vector<float> map(static_cast<size_t>(g.dims.voxelCount()) * 3);
  const size_t bytes = map.size() * sizeof(float);
  if (encoding == "raw") {
    in.read(reinterpret_cast<char*>(map.data()), static_cast<std::streamsize>(bytes));
    if (static_cast<size_t>(in.gcount()) != bytes) throw FileError(path, "truncated data");
  } else if (encoding == "gzip" || encoding == "gz") {
    z_stream zs{};
    if (inflateInit2(&zs, 15 + 32) != Z_OK) throw FileError(path, "zlib initialisation failed");
    std::vector<unsigned char> buf(1 << 20);
    auto* dst = reinterpret_cast<unsigned char*>(map.data());
    size_t done = 0;
    int rc = Z_OK;
    while (done < bytes && rc != Z_STREAM_END) {
      if (zs.avail_in == 0) {
        in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
        zs.next_in = buf.data();
        zs.avail_in = static_cast<uInt>(in.gcount());
        if (zs.avail_in == 0) break;  // truncated: reported below
      }
      const size_t chunk = std::min<size_t>(bytes - done, 1u << 30);
      zs.next_out = dst + done;
      zs.avail_out = static_cast<uInt>(chunk);
      rc = inflate(&zs, Z_NO_FLUSH);
      done += chunk - zs.avail_out;
      if (rc != Z_OK && rc != Z_STREAM_END) { inflateEnd(&zs); throw FileError(path, "damaged gzip data"); }
    }
    inflateEnd(&zs);
    if (done != bytes) throw FileError(path, "truncated gzip data");
  } else {
    throw FileError(path, "unsupported encoding '" + encoding + "' (raw, gzip)");
  }
  if (gridOut) *gridOut = g;
  return map;
}

}  // namespace vellum::deformation
