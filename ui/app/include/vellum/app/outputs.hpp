#pragma once
// Output rules every pipeline (and every `vellum` command) follows: the output policy
// (vellum/io/output_policy.hpp: never an input, never a folder Vellum did not write), the
// output's folder created, JSON written atomically, and no half-finished result left claimed
// as done.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <vector>

#include "vellum/io/output_policy.hpp"
#include "vellum/io/replaced_files.hpp"

namespace vellum::app {

/// Creates the parent folder of `path` if needed.
void ensureParentFolder(const std::filesystem::path& path);

/// Writes JSON text atomically (pretty-printed, trailing newline), creating the folder.
void writeJsonFile(const nlohmann::json& j, const std::filesystem::path& path);

/// What one run has written so far. Unless commit() is called (the run finished), the
/// destructor removes it and puts back any file or folder the run replaced: a run that fails
/// after its main output (a report or a truth comparison that fails) exits with an error,
/// leaves no result that looks finished and loses nothing that was there before.
class RunOutputs {
 public:
  RunOutputs() = default;
  RunOutputs(const RunOutputs&) = delete;
  RunOutputs& operator=(const RunOutputs&) = delete;
  ~RunOutputs();
  /// Records a file or folder this run has just written (with a volume's data file and sidecar).
  void wrote(const std::filesystem::path& path);
  void commit() {
    written_.clear();
    replaced_.commit();
  }

 private:
  std::vector<std::filesystem::path> written_;
  io::ReplacedFiles replaced_;  // opened first, closed last: the old versions come back after the removal
};

}  // namespace vellum::app
