#include "file_browser.hpp"

#include <imgui.h>

#include <algorithm>
#include <cstring>
#include <utility>

namespace vellum::studio {
namespace fs = std::filesystem;

void FileBrowser::open(Mode mode, const std::string& title, Callback onChoose) {
  mode_ = mode;
  title_ = title;
  onChoose_ = std::move(onChoose);
  open_ = popupRequested_ = true;
  cancelRequested_ = false;
  answer_.clear();
  pathField_[0] = '\0';
  list(dir_.empty() ? fs::current_path() : dir_);
}

void FileBrowser::list(const fs::path& dir) {
  std::error_code ec;
  std::vector<fs::directory_entry> entries;
  for (fs::directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec), end;
       !ec && it != end; it.increment(ec))
    if (it->path().filename().string().rfind('.', 0) != 0) entries.push_back(*it);  // hide dotfiles
  if (ec) {
    listError_ = dir.string() + ": " + ec.message();
    return;
  }
  listError_.clear();
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
    std::error_code e1, e2;
    const bool da = a.is_directory(e1), db = b.is_directory(e2);
    return da != db ? da : a.path().filename() < b.path().filename();
  });
  dir_ = dir;
  entries_ = std::move(entries);
}

void FileBrowser::draw() {
  if (!open_) return;
  if (popupRequested_) {
    ImGui::OpenPopup(title_.c_str());
    popupRequested_ = false;
  }
  ImGui::SetNextWindowSize({620, 440}, ImGuiCond_Appearing);
  if (!ImGui::BeginPopupModal(title_.c_str(), &open_)) return;
  ImGui::TextUnformatted(dir_.string().c_str());
  if (!listError_.empty()) ImGui::TextColored({1, 0.4f, 0.4f, 1}, "%s", listError_.c_str());
  fs::path chosen;
  ImGui::BeginChild("entries", {0, -ImGui::GetFrameHeightWithSpacing() * 2}, true);
  if (ImGui::Selectable("[..]")) list(dir_.parent_path());
  for (size_t n = 0; n < entries_.size(); ++n) {
    const auto& e = entries_[n];
    std::error_code ec;
    const bool isDir = e.is_directory(ec);
    std::string name = e.path().filename().string();
    if (isDir) {  // folders in brackets (built in place: GCC 12 warns falsely on "[" + s + "]")
      name.insert(name.begin(), '[');
      name.push_back(']');
    }
    ImGui::PushID(static_cast<int>(n));
    if (ImGui::Selectable(name.c_str(), false, ImGuiSelectableFlags_AllowDoubleClick)) {
      if (isDir && ImGui::IsMouseDoubleClicked(0)) {
        list(e.path());  // double-click enters; a single click selects (DICOM folders)
        ImGui::PopID();
        break;
      }
      std::strncpy(pathField_, e.path().string().c_str(), sizeof pathField_ - 1);
      if (!isDir && ImGui::IsMouseDoubleClicked(0)) chosen = e.path();
    }
    ImGui::PopID();
  }
  ImGui::EndChild();
  ImGui::SetNextItemWidth(-140);
  ImGui::InputText("##path", pathField_, sizeof pathField_);
  ImGui::SameLine();
  if (ImGui::Button(mode_ == Mode::Open ? "Open" : "Save") && pathField_[0]) {
    fs::path p(pathField_);
    chosen = p.is_absolute() ? p : dir_ / p;
  }
  ImGui::SameLine();
  if (ImGui::Button("Cancel") || std::exchange(cancelRequested_, false)) open_ = false;
  if (!answer_.empty()) chosen = std::exchange(answer_, {});
  if (!chosen.empty()) {
    open_ = false;
    if (onChoose_) onChoose_(chosen);
  }
  if (!open_) ImGui::CloseCurrentPopup();
  ImGui::EndPopup();
}

}  // namespace vellum::studio
