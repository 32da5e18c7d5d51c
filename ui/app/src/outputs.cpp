// Output rules shared by the pipelines and the commands (see outputs.hpp).
#include "vellum/app/outputs.hpp"

#include "vellum/core/error.hpp"
#include "vellum/io/nrrd_writer.hpp"

namespace vellum::app {

void refuseOverwritingInput(const std::filesystem::path& in, const std::filesystem::path& out) {
  std::error_code ec;
  const bool same = std::filesystem::exists(out, ec) && std::filesystem::equivalent(in, out, ec);
  if (same || std::filesystem::weakly_canonical(in, ec) == std::filesystem::weakly_canonical(out, ec))
    throw Error(out.string() + ": refusing to overwrite the input");
}

void ensureParentFolder(const std::filesystem::path& path) {
  const auto parent = path.parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
}

void writeJsonFile(const nlohmann::json& j, const std::filesystem::path& path) {
  ensureParentFolder(path);
  io::writeTextFile(path, j.dump(2) + "\n");
}

}  // namespace vellum::app
