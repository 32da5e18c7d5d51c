#include "recent_files.hpp"

#include <algorithm>
#include <fstream>
#include <string>
#include <system_error>

#include "user_dirs.hpp"
#include "vellum/io/atomic_file.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

fs::path RecentFiles::defaultStorage() {
  const fs::path folder = userFolder("XDG_CONFIG_HOME", ".config");
  return folder.empty() ? folder : folder / "studio-recent.txt";
}

RecentFiles::RecentFiles(fs::path storage) : storage_(std::move(storage)) {
  if (storage_.empty()) return;
  std::ifstream in(storage_);
  for (std::string line; std::getline(in, line) && paths_.size() < kMax;)
    if (!line.empty()) paths_.emplace_back(line);
}

void RecentFiles::add(const fs::path& path) {
  const fs::path p = fs::absolute(path).lexically_normal();
  std::erase(paths_, p);
  paths_.insert(paths_.begin(), p);
  if (paths_.size() > kMax) paths_.resize(kMax);
  if (storage_.empty()) return;
  try {  // best effort: a read-only home must not disturb the session
    std::error_code ec;
    fs::create_directories(storage_.parent_path(), ec);
    io::writeAtomically(storage_, [&](const fs::path& tmp) {
      std::ofstream out(tmp);
      for (const auto& r : paths_) out << r.string() << "\n";
    });
  } catch (const std::exception&) {
  }
}

}  // namespace vellum::studio
