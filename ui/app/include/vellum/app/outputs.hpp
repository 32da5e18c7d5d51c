#pragma once
// Output rules every pipeline (and every `vellum` command) follows: the output policy
// (vellum/io/output_policy.hpp: never an input, never a folder Vellum did not write), the
// output's folder created, JSON written atomically, and no half-finished result left claimed
// as done.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <vector>

#include "vellum/io/output_policy.hpp"

namespace vellum::app {

/// Creates the parent folder of `path` if needed.
void ensureParentFolder(const std::filesystem::path& path);

/// Writes JSON text atomically (pretty-printed, trailing newline), creating the folder.
void writeJsonFile(const nlohmann::json& j, const std::filesystem::path& path);

/// What one run has written so far. Unless commit() is called (the run finished), the
/// destructor removes it: a run that fails after its main output (a report or a truth
/// comparison that fails) exits with an error and leaves no result that looks finished.
class RunOutputs {
 public:
  RunOutputs() = default;
  RunOutputs(const RunOutputs&) = delete;
  RunOutputs& operator=(const RunOutputs&) = delete;
  ~RunOutputs();
  /// Records a file or folder this run has just written (with a volume's data file and sidecar).
  void wrote(const std::filesystem::path& path);
  void commit() { written_.clear(); }

 private:
  std::vector<std::filesystem::path> written_;
};

}  // namespace vellum::app
