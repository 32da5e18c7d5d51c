#pragma once
// Autosave: every `intervalSeconds`, if the scene changed, writes a sibling scene
// "<name>.autosave.json" (next to the scene file, or to the volume when the scene was never
// saved) and, when the labels were edited, "<name>.autosave.labels.nrrd". Writing runs on a
// worker thread with a copy of the labels, so the UI does not stall; opening the autosave
// file like any scene recovers the session.
#include <filesystem>
#include <future>
#include <string>

#include "scene.hpp"

namespace vellum::studio {

class Autosaver {
 public:
  explicit Autosaver(double intervalSeconds) : interval_(intervalSeconds) {}
  ~Autosaver();
  Autosaver(const Autosaver&) = delete;
  Autosaver& operator=(const Autosaver&) = delete;

  /// Call once per frame. `labelsRevision` changes whenever the label map changes.
  void tick(const Scene& scene, uint64_t labelsRevision, double nowSeconds);
  /// The autosave scene path for `scene` (empty without a volume).
  static std::filesystem::path targetFor(const Scene& scene);
  /// The last write's error ("" when fine).
  std::string lastError();

 private:
  double interval_;
  double lastCheck_ = 0;
  std::string lastSceneText_;
  uint64_t savedLabelsRevision_ = 0;
  std::filesystem::path savedLabelsPath_;
  std::future<std::string> job_;  ///< returns the error message, "" on success
  std::string lastError_;
};

}  // namespace vellum::studio
