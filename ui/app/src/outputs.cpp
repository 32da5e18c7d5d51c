// Output rules shared by the pipelines and the commands (see outputs.hpp).
#include "vellum/app/outputs.hpp"

#include <algorithm>

#include "vellum/core/error.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::app {

void ensureParentFolder(const std::filesystem::path& path) {
  const auto parent = path.parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  if (ec) throw FileError(path, "cannot create its folder " + parent.string() + ": " + ec.message());
}

void writeJsonFile(const nlohmann::json& j, const std::filesystem::path& path) {
  ensureParentFolder(path);
  io::writeTextFile(path, j.dump(2) + "\n");
}

RunOutputs::~RunOutputs() {
  std::error_code ec;
  for (const auto& p : written_) std::filesystem::remove_all(p, ec);
}

void RunOutputs::wrote(const std::filesystem::path& path) {
  std::error_code ec;
  const bool folder = std::filesystem::is_directory(path, ec);
  if (folder) return written_.push_back(path);
  for (bool gzip : {true, false})  // a .nhdr's data file is .raw.gz or .raw
    for (const auto& f : io::filesWrittenTo(path, gzip))
      if (std::filesystem::exists(f, ec) && std::find(written_.begin(), written_.end(), f) == written_.end())
        written_.push_back(f);
}

}  // namespace vellum::app
