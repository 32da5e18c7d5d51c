#pragma once
// JSON files of control points and keyframes (mm). Formats: docs/deformation.md.
//   {"units":"mm","power":2,"points":[{"source":[x,y,z],"target":[x,y,z],
//     "attributes":{"lightness":0,"a":0,"b":0,"density":1}}, ...]}
//   {"interpolation":"linear|smooth|eased","loop":false,
//    "keyframes":[{"duration":1.0,"points":[...]}, ...]}
#include <nlohmann/json_fwd.hpp>

#include <filesystem>
#include <optional>

#include "vellum/deformation/keyframes.hpp"

namespace vellum::deformation {

/// Control points one file (or keyframe) may hold; more is refused as a named error.
constexpr size_t kMaxControlPoints = 100000;

struct PointFile {
  ControlPoints points;
  std::optional<double> power;  ///< "power" when the file gives one
};

/// Throws vellum::FileError naming the file and the problem (missing, bad JSON, units other
/// than mm, missing/non-numeric coordinates, no points).
PointFile loadControlPoints(const std::filesystem::path& path);
/// Writes atomically (temporary sibling, then rename).
void saveControlPoints(const PointFile& file, const std::filesystem::path& path);

KeyframeTrack loadKeyframes(const std::filesystem::path& path);
/// The track-level keys of a keyframe file's JSON (or a pose file's, which times its angles
/// the same way): "interpolation", "loop", and checks that "keyframes" is a non-empty array
/// of at most kMaxKeyframes entries. FileError naming `path` and the key.
void readTrackSettings(const nlohmann::json& j, const std::filesystem::path& path, KeyframeTrack& track);
void saveKeyframes(const KeyframeTrack& track, const std::filesystem::path& path);

}  // namespace vellum::deformation
