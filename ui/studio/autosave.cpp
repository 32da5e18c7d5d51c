#include "autosave.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>

#include "scene_file.hpp"
#include "user_dirs.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

namespace {

std::string withoutExtension(const fs::path& p) {
  std::string stem = p.filename().string();
  for (const char* ext : {".json", ".nii.gz", ".nrrd", ".nhdr", ".mha", ".mhd", ".nii", ".vti", ".raw", ".dcm"})
    if (stem.size() > std::strlen(ext) && stem.ends_with(ext)) {
      stem.resize(stem.size() - std::strlen(ext));
      break;
    }
  return stem;
}

/// 12 hex digits of FNV-1a over `text`: short, stable across runs and builds.
std::string shortHash(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char out[16];
  std::snprintf(out, sizeof out, "%012llx", static_cast<unsigned long long>(h >> 16));
  return out;
}

fs::path absoluteOf(const fs::path& p) {
  std::error_code ec;
  const fs::path c = fs::weakly_canonical(p, ec);
  return ec ? fs::absolute(p).lexically_normal() : c;
}

/// Last write time, or the oldest time for a path that cannot be read.
fs::file_time_type writeTime(const fs::path& p) {
  std::error_code ec;
  const auto t = fs::last_write_time(p, ec);
  return ec ? fs::file_time_type::min() : t;
}

}  // namespace

Autosaver::~Autosaver() {
  if (job_.valid()) job_.wait();  // never leave a half-written autosave behind a running thread
}

fs::path Autosaver::targetFor(const Scene& scene) {
  if (!scene.hasVolume()) return {};
  if (!scene.scenePath.empty())
    return scene.scenePath.parent_path() / (withoutExtension(scene.scenePath) + ".autosave.json");
  const fs::path state = userFolder("XDG_STATE_HOME", ".local/state");
  if (state.empty()) return {};
  const std::string key = absoluteOf(scene.volumePath).string() + "|" + scene.seriesUid;
  return state / "autosave" / (withoutExtension(scene.volumePath) + "-" + shortHash(key) + ".autosave.json");
}

fs::path Autosaver::labelsFor(const fs::path& target) {
  return target.parent_path() / (target.stem().string() + ".labels.nrrd");
}

std::optional<fs::path> Autosaver::recoverable(const Scene& scene) {
  const fs::path target = targetFor(scene);
  std::error_code ec;
  if (target.empty() || !fs::exists(target, ec)) return std::nullopt;
  const fs::path& opened = scene.scenePath.empty() ? scene.volumePath : scene.scenePath;
  const auto newestSource = std::max(writeTime(opened), scene.labelsPath.empty() ? fs::file_time_type::min()
                                                                                  : writeTime(scene.labelsPath));
  if (writeTime(target) <= newestSource) return std::nullopt;
  return target;
}

void Autosaver::remove(const fs::path& target) {
  std::error_code ec;  // best effort: a file already gone is fine
  const fs::path stem = target.parent_path() / target.stem();  // writeSceneFile's files beside it
  for (const fs::path& p : {target, labelsFor(target), fs::path(stem.string() + ".keyframes.json"),
                            fs::path(stem.string() + ".pose.json")})
    fs::remove(p, ec);
}

void Autosaver::removeOwn() {
  if (job_.valid()) job_.wait();  // a write in progress would bring a file back
  for (const fs::path& t : own_) remove(t);
  own_.clear();
}

std::string Autosaver::lastError() {
  if (job_.valid() && job_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) lastError_ = job_.get();
  return lastError_;
}

std::optional<Autosaver::Plan> Autosaver::plan(const Scene& scene, uint64_t labelsRevision) const {
  Plan p;
  p.target = targetFor(scene);
  if (p.target.empty() || kept_.count(p.target)) return std::nullopt;
  p.file = describeScene(scene);
  p.labelsTarget = labelsFor(p.target);
  // Edited since the last write, or the target moved (the scene was saved elsewhere).
  p.labelsEdited =
      scene.labelsModified && (labelsRevision != savedLabelsRevision_ || p.labelsTarget != savedLabelsTarget_);
  if (scene.labelsModified) p.file.labels = p.labelsTarget;  // the edited map lives in the autosave
  // Compare what would be written with the last autosave: unchanged scenes are not rewritten.
  p.text = p.target.string() + "|" + p.file.volume.string() + "|" + p.file.labels.string();
  p.text += sceneViewJson(p.file).dump();
  // The keyframe track (control points): its revision counts every edit (and playback).
  if (p.file.deformation || p.file.pose) p.text += " track " + std::to_string(scene.authoring.revision);
  return p;
}

bool Autosaver::settled(const Scene& scene, uint64_t labelsRevision) {
  if (labelsCopy_.valid() || waiting_) return false;
  if (job_.valid() && job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return false;
  const auto p = plan(scene, labelsRevision);
  return !p || (!p->labelsEdited && p->text == lastSceneText_);
}

void Autosaver::write(Plan p, std::shared_ptr<const LabelVolume> labels) {
  own_.insert(p.target);
  job_ = std::async(std::launch::async, [file = std::move(p.file), target = p.target, labelsTarget = p.labelsTarget,
                                         labels = std::move(labels)]() -> std::string {
    try {
      fs::create_directories(target.parent_path());
      if (labels) io::saveLabels(*labels, labelsTarget);
      writeSceneFile(file, target);
      return "";
    } catch (const std::exception& e) {
      return e.what();
    }
  });
}

void Autosaver::tick(const Scene& scene, uint64_t labelsRevision, double now) {
  if (interval_ <= 0 || !scene.hasVolume()) return;
  if (labelsCopy_.valid()) {  // the copy of the labels, made on the task queue's worker
    if (labelsCopy_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    try {
      Copied c = labelsCopy_.get();
      savedLabelsRevision_ = c.revision;  // the revision copied, read where the labels were
      savedLabelsTarget_ = waiting_->labelsTarget;
      write(std::move(*waiting_), std::move(c.labels));
    } catch (const std::future_error&) {  // dropped (a cancelled task): planned again
      lastSceneText_.clear();
    }
    labelsCopy_ = {};
    waiting_.reset();
    return;
  }
  if (now - lastCheck_ < interval_) return;
  if (job_.valid()) {
    if (job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;  // still writing
    lastError_ = job_.get();
    if (!lastError_.empty()) std::cerr << "vellum-studio: autosave failed: " << lastError_ << "\n";
  }
  lastCheck_ = now;
  std::optional<Plan> p = plan(scene, labelsRevision);
  if (!p || (!p->labelsEdited && p->text == lastSceneText_)) return;
  if (p->labelsEdited && reader_) {
    // The copy (the size of the CT) on the task queue's worker, after the queued edits; the
    // write starts from a later tick once it is made.
    auto promise = std::make_shared<std::promise<Copied>>();
    std::future<Copied> copy = promise->get_future();
    if (!reader_("copying the labels for the autosave", [promise](const Scene& s) {
          promise->set_value({std::make_shared<const LabelVolume>(s.labels), s.labelsRevision});
        }))
      return;  // a brush stroke is writing them: the next check
    lastSceneText_ = p->text;
    labelsCopy_ = std::move(copy);
    waiting_ = std::move(p);
    return;
  }
  lastSceneText_ = p->text;
  std::shared_ptr<const LabelVolume> labels;
  if (p->labelsEdited) {
    labels = std::make_shared<const LabelVolume>(scene.labels);  // without a reader: a copy here
    savedLabelsRevision_ = labelsRevision;
    savedLabelsTarget_ = p->labelsTarget;
  }
  write(std::move(*p), std::move(labels));
}

}  // namespace vellum::studio
