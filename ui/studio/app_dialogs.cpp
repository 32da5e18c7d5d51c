// StudioApp: the modal dialogs (error box, autosave recovery, unsaved changes on close) and
// closing the window. Each dialog's buttons call answerDialog() with their own name in lower
// case, which is also what a script's "dialog" action calls: one path for both.
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <cctype>
#include <initializer_list>
#include <string>
#include <utility>

#include "app.hpp"
#include "autosave.hpp"
#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

namespace {

constexpr const char* kErrorTitle = "Error";
constexpr const char* kRecoveryTitle = "Recover autosave?";
constexpr const char* kUnsavedTitle = "Unsaved changes";

/// The modal `title` while `isOpen()`: opened when it is not yet, closed once the app's state
/// says it was answered (by a button in `body`, or by a script).
void modal(const char* title, const std::function<bool()>& isOpen, const std::function<void()>& body) {
  if (isOpen() && !ImGui::IsPopupOpen(title)) ImGui::OpenPopup(title);
  if (!ImGui::BeginPopupModal(title, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  ImGui::PushTextWrapPos(560);
  if (isOpen()) body();
  ImGui::PopTextWrapPos();
  if (!isOpen()) ImGui::CloseCurrentPopup();
  ImGui::EndPopup();
}

/// One button per answer, on one row; a click answers the dialog with the lower-case label.
void answerButtons(StudioApp& app, std::initializer_list<const char*> labels) {
  bool first = true;
  for (const char* label : labels) {
    if (!std::exchange(first, false)) ImGui::SameLine();
    if (ImGui::Button(label, {120, 0})) {
      std::string answer = label;
      for (char& c : answer) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      guarded(app, [&] { app.answerDialog(answer); });
    }
  }
}

[[noreturn]] void noSuchAnswer(const std::string& title, const std::string& answer, const char* answers) {
  throw Error("the '" + title + "' dialog has no answer '" + answer + "' (" + answers + ")");
}

}  // namespace

std::string StudioApp::openDialog() const {
  if (browser_.isOpen()) return browser_.title();
  if (errorOpen_) return kErrorTitle;
  if (dialog_ == Dialog::Recovery) return kRecoveryTitle;
  if (dialog_ == Dialog::Unsaved) return kUnsavedTitle;
  return "";
}

void StudioApp::drawDialogs() {
  // One at a time, the error box first: ImGui replaces a modal opened beside another.
  if (errorOpen_ || ImGui::IsPopupOpen(kErrorTitle)) {
    modal(kErrorTitle, [this] { return errorOpen_; }, [this] {
      ImGui::TextUnformatted(errorMessage_.c_str());
      answerButtons(*this, {"OK"});
    });
    return;
  }
  modal(kRecoveryTitle, [this] { return dialog_ == Dialog::Recovery; }, [this] {
    ImGui::Text("An autosave newer than what was opened exists:\n%s", recoveryPath_.string().c_str());
    ImGui::TextUnformatted("Recover opens it; Discard deletes it; Later keeps it for the next start.");
    answerButtons(*this, {"Recover", "Discard", "Later"});
  });
  modal(kUnsavedTitle, [this] { return dialog_ == Dialog::Unsaved; }, [this] {
    ImGui::TextUnformatted("The scene has unsaved changes. Save them before closing?");
    answerButtons(*this, {"Save", "Discard", "Cancel"});
  });
}

void StudioApp::answerDialog(const std::string& answer) {
  const std::string title = openDialog();
  if (title.empty()) throw Error("no dialog is open");
  if (browser_.isOpen()) {
    if (answer != "cancel") noSuchAnswer(title, answer, "cancel, or {\"path\": P}");
    browser_.cancel();
  } else if (errorOpen_) {
    if (answer != "ok") noSuchAnswer(title, answer, "ok");
    errorOpen_ = false;
  } else if (dialog_ == Dialog::Recovery) {
    if (answer == "recover") {
      recovering_ = Recovering{recoveryPath_, scene_.scenePath};
      requestOpen(recoveryPath_);
    } else if (answer == "discard") Autosaver::remove(recoveryPath_);
    else if (answer == "later") autosaver_->keep(recoveryPath_);  // this session must not write over it
    else noSuchAnswer(title, answer, "recover, discard, later");
    dialog_ = Dialog::None;
  } else {
    if (answer == "save") saveSceneOrAsk([this] { quit(0); });
    else if (answer == "discard") quit(0);  // the autosave stays: recovery can still bring the edits back
    else if (answer != "cancel") noSuchAnswer(title, answer, "save, discard, cancel");
    dialog_ = Dialog::None;
  }
}

void StudioApp::answerFileBrowser(const fs::path& path) {
  if (!browser_.isOpen()) throw Error("no file browser is open (the open dialog: '" + openDialog() + "')");
  browser_.choose(path);
}

void StudioApp::requestClose() { glfwSetWindowShouldClose(window_, GLFW_TRUE); }

void StudioApp::onWindowClose() {
  glfwSetWindowShouldClose(window_, GLFW_FALSE);  // the window stays until the answer says otherwise
  if (!unsavedChanges()) quit(exitCode_);
  else dialog_ = Dialog::Unsaved;
}

bool StudioApp::unsavedChanges() const {
  return scene_.hasVolume() && (scene_.labelsModified || undo_.changes() != savedChanges_);
}

void StudioApp::saveSceneOrAsk(std::function<void()> then) {
  if (!scene_.hasVolume()) return;
  auto save = [this, then](const fs::path& path) {
    guarded(*this, [&] { saveScene(path, then); });  // `then` once written (labels on a worker)
  };
  if (scene_.scenePath.empty()) browser_.open(FileBrowser::Mode::Save, "Save scene as", save);
  else save(scene_.scenePath);
}

void StudioApp::afterLoad(const LoadResult& r) {
  const std::optional<Recovering> recovered = std::exchange(recovering_, std::nullopt);
  if (recovered && r.scenePath == recovered->autosave) {
    // The autosave's edits are this session's, unsaved: it stands for the scene it was made of.
    scene_.scenePath = recovered->scenePath;
    scene_.labelsModified =
        scene_.labelsPath.lexically_normal() == Autosaver::labelsFor(recovered->autosave).lexically_normal();
    autosaver_->adopt(recovered->autosave);  // deleted by a clean exit once saved
    savedChanges_ = kNeverSaved;
    return;
  }
  savedChanges_ = undo_.changes();
  if (const auto autosave = Autosaver::recoverable(scene_)) {
    recoveryPath_ = *autosave;
    dialog_ = Dialog::Recovery;
  }
}

}  // namespace vellum::studio
