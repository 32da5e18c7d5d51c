#pragma once
// Autosave: every `intervalSeconds`, if the scene changed, writes a scene file and, when the
// labels were edited, its label map "<name>.labels.nrrd" beside it. Where: beside the saved
// scene ("<scene>.autosave.json") once the scene has been saved, else in the user's state
// folder ($XDG_STATE_HOME/vellum/autosave/, else ~/.local/state/vellum/autosave/) as
// "<volume>-<hash>.autosave.json", the hash of the volume's absolute path (and DICOM series)
// keeping two volumes of the same name apart. Never beside the data: that may be a DICOM
// export, a read-only share or a PACS mount. Writing runs on a worker thread with a copy of
// the labels, itself made off the UI thread (setSceneReader: the size of the CT, 0.1-0.3 s at
// 512^2 x 350), so the UI does not stall; opening the autosave like any scene recovers it.
#include <filesystem>
#include <future>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "scene.hpp"
#include "scene_file.hpp"

namespace vellum::studio {

class Autosaver {
 public:
  explicit Autosaver(double intervalSeconds) : interval_(intervalSeconds) {}
  ~Autosaver();
  Autosaver(const Autosaver&) = delete;
  Autosaver& operator=(const Autosaver&) = delete;

  /// Call once per frame. `labelsRevision` changes whenever the label map changes.
  void tick(const Scene& scene, uint64_t labelsRevision, double nowSeconds);
  /// Where the copy of edited labels is made (see SceneReader); without one, on tick's thread.
  void setSceneReader(SceneReader reader) { reader_ = std::move(reader); }
  /// Nothing left to write: the last autosave holds `scene` as it is now (or this session
  /// keeps its target), and no copy or write is in progress. Scripts wait on it.
  bool settled(const Scene& scene, uint64_t labelsRevision);
  /// The autosave scene path for `scene` (empty without a volume, or without a state folder
  /// for a scene never saved).
  static std::filesystem::path targetFor(const Scene& scene);
  /// The label map written with the autosave `target`.
  static std::filesystem::path labelsFor(const std::filesystem::path& target);
  /// The autosave of `scene` when it is newer than the files the scene was opened from.
  static std::optional<std::filesystem::path> recoverable(const Scene& scene);
  /// Deletes the autosave `target` and the files written with it (labels, keyframes).
  static void remove(const std::filesystem::path& target);
  /// Never writes over `target` in this session (the user chose to keep it for later).
  void keep(const std::filesystem::path& target) { kept_.insert(target); }
  /// Counts `target` as this session's own (a recovered autosave), for removeOwn().
  void adopt(const std::filesystem::path& target) { own_.insert(target); }
  /// Deletes every autosave this session wrote or adopted (the scene is saved: a clean exit).
  void removeOwn();
  /// The last write's error ("" when fine).
  std::string lastError();

 private:
  double interval_;
  double lastCheck_ = 0;
  std::string lastSceneText_;
  uint64_t savedLabelsRevision_ = 0;
  std::filesystem::path savedLabelsTarget_;
  std::set<std::filesystem::path> kept_, own_;
  /// What tick would write for `scene`: its target, the scene file and the text compared
  /// with the last autosave's; whether the labels go with it.
  struct Plan {
    std::filesystem::path target, labelsTarget;
    SceneFile file;
    std::string text;
    bool labelsEdited = false;
  };
  std::optional<Plan> plan(const Scene& scene, uint64_t labelsRevision) const;
  /// Starts writing `plan` with `labels` (nullptr: the scene file alone) on a worker.
  void write(Plan plan, std::shared_ptr<const LabelVolume> labels);

  SceneReader reader_;
  /// An autosave waiting for its copy of the labels (made by reader_): the copy and revision.
  struct Copied {
    std::shared_ptr<const LabelVolume> labels;
    uint64_t revision = 0;
  };
  std::future<Copied> labelsCopy_;
  std::optional<Plan> waiting_;
  std::future<std::string> job_;  ///< returns the error message, "" on success
  std::string lastError_;
};

}  // namespace vellum::studio
