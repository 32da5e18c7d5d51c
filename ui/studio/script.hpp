#pragma once
// Scripted mode: a JSON list of actions played one step per frame through the app's input
// handlers (clicks and drags are GLFW events, not calls into the model). Every action is
// documented in docs/studio.md ("Scripts").
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace vellum::studio {

class StudioApp;

class ScriptRunner {
 public:
  /// Reads and checks the script (JSON shape, action names); throws vellum::Error.
  static std::unique_ptr<ScriptRunner> load(const std::filesystem::path& path);
  /// Runs the next step. Returns the exit code when the script has finished (quit, end of
  /// the list, or failure: non-zero, with "script action #N (name): why" on stderr).
  std::optional<int> step(StudioApp& app);
  /// Opens the file given on the command line before the first action; a failure fails the
  /// script ("command line: open failed: ...").
  void openFirst(const std::filesystem::path& path, const std::filesystem::path& labels);

 private:
  /// A step returns true when done, false to run again next frame (waiting).
  using Step = std::function<bool(StudioApp&)>;
  void expand(const nlohmann::json& action, StudioApp& app);

  nlohmann::json actions_;
  size_t next_ = 0;
  std::string where_;  ///< what runs now, for failures: "script action #7 (drag_point)"
  std::deque<Step> steps_;
  int waitedFrames_ = 0;
  std::optional<int> quitCode_;
};

}  // namespace vellum::studio
