#pragma once
// What a run replaced, so that a run which fails after writing can put the old files back.
//
// The atomic writers (writeAtomically, writeFolderAtomically, VideoWriter) rename a finished
// temporary over the target. While a ReplacedFiles journal is open on the writing thread, an
// existing target is first kept under a hidden sibling name (a hard link for a file: no copy;
// the old folder itself for a folder). The journal's owner then either commits (the run
// finished: the kept copies are deleted) or rolls back (the run failed: each kept copy is
// renamed back over what the run wrote). app::RunOutputs opens one per run.
#include <filesystem>
#include <utility>
#include <vector>

namespace vellum::io {

class ReplacedFiles {
 public:
  /// Opens the journal on this thread (journals nest: the innermost one records).
  ReplacedFiles();
  ReplacedFiles(const ReplacedFiles&) = delete;
  ReplacedFiles& operator=(const ReplacedFiles&) = delete;
  /// Rolls back unless committed, and closes the journal.
  ~ReplacedFiles();

  /// The run finished: the kept old versions are deleted (or, when an outer journal is open,
  /// handed to it, so that its run can still roll them back).
  void commit();
  /// The run failed: every replaced target gets its old version back (newest first).
  void rollBack();
  /// How many targets this journal has kept an old version of.
  size_t size() const { return kept_.size(); }

  /// For the atomic writers: called just before `target` is replaced. When a journal is open
  /// on this thread and `target` exists, keeps its current version and records it.
  static void keepBeforeReplacing(const std::filesystem::path& target);
  /// For folder writers that have already moved the old folder aside to `old`: the open
  /// journal takes it over (returns true) instead of the writer deleting it.
  static bool adoptOldFolder(const std::filesystem::path& target, const std::filesystem::path& old);

 private:
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> kept_;  // target, old copy
  ReplacedFiles* outer_ = nullptr;
  bool closed_ = false;
};

}  // namespace vellum::io
