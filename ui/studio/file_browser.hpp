#pragma once
// A small ImGui file browser (no native dialog dependency): folders first, then files;
// ".." goes up; a path field accepts typed paths. One instance serves Open and Save As.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace vellum::studio {

class FileBrowser {
 public:
  enum class Mode { Open, Save };
  using Callback = std::function<void(const std::filesystem::path&)>;

  /// Opens the dialog; `onChoose` runs with the chosen path when the user confirms.
  void open(Mode mode, const std::string& title, Callback onChoose);
  /// Draws the dialog when open; call once per frame inside the ImGui frame.
  void draw();
  bool isOpen() const { return open_; }
  const std::string& title() const { return title_; }
  /// Answers the open dialog in the next draw, as typing `path` and confirming does (scripts).
  void choose(const std::filesystem::path& path) { answer_ = path; }
  /// Closes the open dialog in the next draw, as its Cancel button does.
  void cancel() { cancelRequested_ = true; }

 private:
  void list(const std::filesystem::path& dir);
  bool open_ = false, popupRequested_ = false, cancelRequested_ = false;
  std::filesystem::path answer_;  ///< choose()'s path, taken by the next draw
  Mode mode_ = Mode::Open;
  std::string title_;
  Callback onChoose_;
  std::filesystem::path dir_;
  std::vector<std::filesystem::directory_entry> entries_;
  std::string listError_;
  char pathField_[1024] = {};
};

}  // namespace vellum::studio
