// Journal of replaced outputs (see replaced_files.hpp).
#include "vellum/io/replaced_files.hpp"

#include "io_detail.hpp"

namespace vellum::io {
namespace fs = std::filesystem;

namespace {
// Per thread: a studio job writes on its worker, a CLI run on the main thread.
thread_local ReplacedFiles* tCurrent = nullptr;
}  // namespace

ReplacedFiles::ReplacedFiles() : outer_(tCurrent) { tCurrent = this; }

ReplacedFiles::~ReplacedFiles() {
  if (!closed_) rollBack();
  if (tCurrent == this) tCurrent = outer_;
}

void ReplacedFiles::commit() {
  if (outer_)
    outer_->kept_.insert(outer_->kept_.end(), kept_.begin(), kept_.end());
  else
    for (const auto& [target, old] : kept_) detail::removeTemporary(old);
  kept_.clear();
  closed_ = true;
}

void ReplacedFiles::rollBack() {
  std::error_code ec;
  for (auto it = kept_.rbegin(); it != kept_.rend(); ++it) {
    const auto& [target, old] = *it;
    if (fs::is_directory(old, ec)) detail::removeTemporary(target);  // a folder cannot be renamed over
    fs::rename(old, target, ec);
    if (ec) detail::removeTemporary(old);  // nothing better to do; never leave hidden copies
  }
  kept_.clear();
  closed_ = true;
}

void ReplacedFiles::keepBeforeReplacing(const fs::path& target) {
  ReplacedFiles* j = tCurrent;
  std::error_code ec;
  if (!j || j->closed_ || !fs::is_regular_file(target, ec)) return;
  for (const auto& kept : j->kept_)
    if (kept.first == target) return;  // the first old version is the one to restore
  const fs::path old = detail::temporarySibling(target, "old");
  fs::create_hard_link(target, old, ec);
  if (ec) {
    ec.clear();
    fs::copy_file(target, old, ec);  // a file system without hard links
    if (ec) return detail::removeTemporary(old);
  }
  j->kept_.emplace_back(target, old);
}

bool ReplacedFiles::adoptOldFolder(const fs::path& target, const fs::path& old) {
  ReplacedFiles* j = tCurrent;
  if (!j || j->closed_) return false;
  for (const auto& kept : j->kept_)
    if (kept.first == target) return false;  // an older version is kept already
  j->kept_.emplace_back(target, old);
  return true;
}

}  // namespace vellum::io
