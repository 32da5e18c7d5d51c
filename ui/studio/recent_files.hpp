#pragma once
// The Recent list: files opened successfully, most recent first, kept across sessions in
// $XDG_CONFIG_HOME/vellum/studio-recent.txt (else ~/.config/...), one path per line.
#include <filesystem>
#include <vector>

namespace vellum::studio {

class RecentFiles {
 public:
  static constexpr size_t kMax = 8;
  /// `storage` empty: in memory only (scripts and tests leave the user's list alone).
  explicit RecentFiles(std::filesystem::path storage = {});
  /// The default storage path (empty when neither XDG_CONFIG_HOME nor HOME is set).
  static std::filesystem::path defaultStorage();
  /// Moves `path` to the front (and writes the list, best effort).
  void add(const std::filesystem::path& path);
  const std::vector<std::filesystem::path>& paths() const { return paths_; }

 private:
  std::filesystem::path storage_;
  std::vector<std::filesystem::path> paths_;
};

}  // namespace vellum::studio
