// Per-segment distances of the shape folder (docs/shape.md, "Per-segment distances"): each
// segment keeps a signed distance to its own surface, so nested and touching segments each
// keep a shaded surface in the renderer. int16 hundredths of a millimetre: half the size of
// float32, far finer than a voxel, and uploaded to GL as-is (RGBA16_SNORM).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/core/parallel.hpp"
#include "shape_internal.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/nrrd_writer.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::illustration {

namespace fs = std::filesystem;

namespace {

/// The value voxel (i, j, k) takes so that trilinear interpolation keeps a structure thinner
/// than a voxel (issue 21: thin structures drew beaded). Exact distances at voxel centres lose
/// such a structure wherever it passes between two centres: both are outside (d > 0) and the
/// interpolation between them never goes below min(d); along an oblique rod the visible part
/// comes and goes with the grid's phase. Where two neighbours p, q along an axis (spacing s)
/// lie on either side of a valley - the field falls towards the pair from both sides (slopes
/// over half the spacing: not a row grazing a convex surface, whose slope along the row is
/// small) and d_p + d_q < s (their distance spheres leave part of the segment pq to the
/// structure, whose chord there is s - d_p - d_q) - both take at most minus half that chord:
/// the interpolated field then crosses zero around the pair, so the structure is drawn about
/// a voxel thick (the grid's resolution) instead of in beads.
float keepThin(const VolumeF32& d, int64_t i, int64_t j, int64_t k) {
  const Dims n = d.dims();
  const float dv = d(i, j, k);
  float out = dv;
  if (!(dv > 0.f)) return out;
  const int64_t idx[3] = {i, j, k}, size[3] = {n.x, n.y, n.z};
  const double sp[3] = {d.geometry().spacing.x, d.geometry().spacing.y, d.geometry().spacing.z};
  auto at = [&](int axis, int64_t off) {
    int64_t c[3] = {i, j, k};
    c[axis] += off;
    return d(c[0], c[1], c[2]);
  };
  for (int a = 0; a < 3; ++a) {
    const float s = float(sp[a]);
    // The pair (v, v + e) with v nearer (ties: the lower index), then (v - e, v) with v nearer.
    for (int side : {1, -1}) {
      if (idx[a] - side < 0 || idx[a] - side >= size[a] || idx[a] + 2 * side < 0 || idx[a] + 2 * side >= size[a]) continue;
      const float dq = at(a, side), behind = at(a, -side), beyond = at(a, 2 * side);
      if (!(dq > 0.f) || dv + dq >= s) continue;
      if (!(behind - dv > 0.5f * s && beyond - dq > 0.5f * s)) continue;
      out = std::min(out, -0.5f * (s - dv - dq));
    }
  }
  return out;
}

}  // namespace

VolumeI16 quantiseField(const VolumeF32& d) {
  VolumeI16 q(d.geometry(), 0);
  const Dims n = d.dims();
  int16_t* dst = q.data();
  parallelFor(n.z, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < n.y; ++j)
        for (int64_t i = 0; i < n.x; ++i) {
          const double x = std::nearbyint(double(keepThin(d, i, j, k)) / kFieldQuantumMm);
          dst[d.linearIndex(i, j, k)] = static_cast<int16_t>(std::clamp(x, -32767.0, 32767.0));
        }
  });
  return q;
}

double defaultExactBandMm(const Geometry& g) {
  const Vec3 s = g.spacing;
  return std::max(3 * std::min({s.x, s.y, s.z}), 2 * std::max({s.x, s.y, s.z}));
}

SegmentField detail::segmentField(size_t i, const VolumeF32& distance, const std::vector<Segment>& segments,
                                  const std::vector<Shell>& shells, size_t count) {
  SegmentField f;
  f.id = static_cast<uint16_t>(i + 1);
  f.name = i < segments.size() ? segments[i].name : std::to_string(i + 1);
  f.distance = quantiseField(distance);
  // As buildRepresentation: shell s has id count + 1 + s; a segment's first shell is painted.
  for (size_t s = 0; s < shells.size() && i < segments.size(); ++s)
    if (segments[i].name == shells[s].segment && f.shellId == 0) {
      f.shellId = static_cast<uint16_t>(count + 1 + s);
      f.shellMm = static_cast<float>(shells[s].thicknessMm);
    }
  return f;
}

std::vector<SegmentField> makeSegmentFields(const std::vector<VolumeF32>& distances,
                                            const std::vector<Segment>& segments,
                                            const std::vector<Shell>& shells) {
  std::vector<SegmentField> out;
  out.reserve(distances.size());
  for (size_t i = 0; i < distances.size(); ++i)
    out.push_back(detail::segmentField(i, distances[i], segments, shells, distances.size()));
  return out;
}

void saveSegmentFields(const std::vector<SegmentField>& fields, const fs::path& dir) {
  nlohmann::json j;
  j["version"] = 1;
  j["quantum_mm"] = kFieldQuantumMm;
  j["fields"] = nlohmann::json::array();
  auto fileOf = [](const SegmentField& f) { return "distance-" + std::to_string(f.id) + ".nrrd"; };
  // The files side by side (each is mostly the copy into the page cache).
  parallelFor(static_cast<int64_t>(fields.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const SegmentField& f = fields[size_t(i)];
      // The NRRD writer straight from the field's voxels (io::saveVolume would first copy
      // them into an AnyVolume: a volume-sized allocation). Not gzipped: the renderer reads
      // them at every start, no inflate.
      io::NrrdLayout layout;
      layout.type = "short";
      layout.geometry = f.distance.geometry();
      layout.comments = {"Written by Vellum. Format: http://teem.sourceforge.net/nrrd/format.html"};
      io::writeNrrd(dir / fileOf(f), layout, f.distance.data(), f.distance.size() * sizeof(int16_t), false, nullptr);
    }
  }, 1);
  for (const auto& f : fields)
    j["fields"].push_back({{"id", f.id}, {"name", f.name}, {"file", fileOf(f)}, {"shell_id", f.shellId},
                           {"shell_mm", f.shellMm}});
  const std::string text = j.dump(2) + "\n";
  const fs::path target = dir / "distances.json";
  io::writeAtomically(target, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    out.close();
    if (!out) throw FileError(target, "could not be written");
  });
}

std::vector<SegmentField> loadSegmentFields(const fs::path& dir) {
  const fs::path index = dir / "distances.json";
  if (!fs::exists(index))
    throw FileError(index, "missing: the shape folder was made by an older `vellum shape` without per-segment "
                           "distances; run `vellum shape` again");
  const nlohmann::json j = readJsonFile(index, 1u << 20, "distances index");
  std::vector<SegmentField> out;
  try {
    if (j.at("version").get<int>() != 1) throw FileError(index, "unsupported version");
    if (std::abs(j.at("quantum_mm").get<double>() - kFieldQuantumMm) > 1e-12)
      throw FileError(index, "quantum_mm must be " + std::to_string(kFieldQuantumMm));
    for (const auto& e : j.at("fields")) {
      SegmentField f;
      f.id = e.at("id").get<uint16_t>();
      f.name = e.at("name").get<std::string>();
      f.shellId = e.at("shell_id").get<uint16_t>();
      f.shellMm = e.at("shell_mm").get<float>();
      const std::string file = e.at("file").get<std::string>();
      if (file.find('/') != std::string::npos || file.find("..") != std::string::npos)
        throw FileError(index, "field file '" + file + "' is not a plain file name");
      if (f.id == 0 || f.id > 255 || (f.shellId != 0 && !(f.shellMm > 0)))
        throw FileError(index, "field '" + f.name + "': bad id or shell");
      AnyVolume v = io::loadVolume(dir / file).volume;
      if (!std::holds_alternative<VolumeI16>(v))
        throw FileError(dir / file, std::string("expected int16 distances (hundredths of a mm), got ") +
                                        voxelTypeName(voxelTypeOf(v)));
      f.distance = std::move(std::get<VolumeI16>(v));
      out.push_back(std::move(f));
    }
  } catch (const nlohmann::json::exception& e) {
    throw FileError(index, std::string("malformed: ") + e.what());
  }
  for (size_t i = 1; i < out.size(); ++i)
    if (out[i].id <= out[i - 1].id) throw FileError(index, "field ids must increase (paint order)");
  return out;
}

}  // namespace vellum::illustration
