#include "autosave.hpp"

#include <chrono>
#include <cstring>
#include <iostream>
#include <optional>
#include <nlohmann/json.hpp>

#include "scene_file.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

Autosaver::~Autosaver() {
  if (job_.valid()) job_.wait();  // never leave a half-written autosave behind a running thread
}

fs::path Autosaver::targetFor(const Scene& scene) {
  if (!scene.hasVolume()) return {};
  const fs::path base = scene.scenePath.empty() ? scene.volumePath : scene.scenePath;
  std::string stem = base.filename().string();
  for (const char* ext : {".json", ".nii.gz", ".nrrd", ".nhdr", ".mha", ".mhd", ".nii", ".vti", ".raw", ".dcm"})
    if (stem.size() > std::strlen(ext) && stem.ends_with(ext)) {
      stem.resize(stem.size() - std::strlen(ext));
      break;
    }
  return base.parent_path() / (stem + ".autosave.json");
}

std::string Autosaver::lastError() {
  if (job_.valid() && job_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) lastError_ = job_.get();
  return lastError_;
}

void Autosaver::tick(const Scene& scene, uint64_t labelsRevision, double now) {
  if (interval_ <= 0 || !scene.hasVolume() || now - lastCheck_ < interval_) return;
  if (job_.valid()) {
    if (job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;  // still writing
    lastError_ = job_.get();
    if (!lastError_.empty()) std::cerr << "vellum-studio: autosave failed: " << lastError_ << "\n";
  }
  lastCheck_ = now;
  const fs::path target = targetFor(scene);
  SceneFile file = describeScene(scene);
  const bool labelsEdited = scene.labelsModified && labelsRevision != savedLabelsRevision_;
  fs::path labelsTarget = target.parent_path() / (target.stem().string() + ".labels.nrrd");
  if (scene.labelsModified) file.labels = labelsTarget;  // the edited map lives in the autosave
  // Compare what would be written with the last autosave: unchanged scenes are not rewritten.
  std::string text = file.volume.string() + "|" + file.labels.string();
  text += sceneViewJson(file).dump();
  // The keyframe track (control points): its revision counts every edit (and playback).
  if (file.deformation) text += " track " + std::to_string(scene.authoring.revision);
  if (!labelsEdited && text == lastSceneText_) return;
  lastSceneText_ = text;
  std::optional<LabelVolume> labels;
  if (labelsEdited) {
    labels = scene.labels;  // a copy: the user keeps editing while it is written
    savedLabelsRevision_ = labelsRevision;
  }
  job_ = std::async(std::launch::async, [file, target, labelsTarget, labels = std::move(labels)]() -> std::string {
    try {
      if (labels) io::saveLabels(*labels, labelsTarget);
      writeSceneFile(file, target);
      return "";
    } catch (const std::exception& e) {
      return e.what();
    }
  });
}

}  // namespace vellum::studio
