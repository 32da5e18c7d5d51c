// `vellum info IN [--json]`: geometry, type, value range, modality, DICOM series, warnings.
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_util.hpp"
#include "commands.hpp"

namespace vellum::cli {
namespace {

struct InfoArgs {
  std::string input;
  bool json = false;
  InputOptions in;
};

const params::Table<InfoArgs>& infoFlagsTable() {
  static const params::Table<InfoArgs> t{
      params::flag<InfoArgs>("json", &InfoArgs::json, {"JSON", "machine-readable JSON on stdout", ""}),
  };
  return t;
}

nlohmann::json describe(const std::string& input, const io::LoadedVolume& lv) {
  const Geometry& g = geometryOf(lv.volume);
  const auto [lo, hi] = std::visit([](const auto& v) { return v.valueRange(); }, lv.volume);
  nlohmann::json j;
  j["path"] = input;
  j["format"] = lv.format;
  j["modality"] = lv.modality;
  j["dims"] = {g.dims.x, g.dims.y, g.dims.z};
  j["type"] = voxelTypeName(voxelTypeOf(lv.volume));
  j["spacing_mm"] = toJson(g.spacing);
  j["origin_mm"] = toJson(g.origin);
  j["direction"] = toJson(g.direction);
  j["extent_mm"] = toJson(g.extent());
  j["value_range"] = {lo, hi};
  j["background"] = backgroundOf(lv.volume);
  j["warnings"] = lv.warnings;
  if (!lv.seriesUid.empty()) j["series_uid"] = lv.seriesUid;
  nlohmann::json series = nlohmann::json::array();
  for (const auto& s : lv.series)
    series.push_back({{"uid", s.uid},
                      {"modality", s.modality},
                      {"description", s.description},
                      {"sop_class_uid", s.sopClassUid},
                      {"files", s.fileCount},
                      {"rows", s.rows},
                      {"columns", s.columns},
                      {"frames", s.frames},
                      {"loaded", s.uid == lv.seriesUid}});
  j["series"] = series;
  return j;
}

void printHuman(const nlohmann::json& j) {
  auto vec = [](const nlohmann::json& a) {
    std::ostringstream s;
    s << std::setprecision(6);
    for (size_t i = 0; i < a.size(); ++i) s << (i ? " " : "") << a[i].get<double>();
    return s.str();
  };
  std::cout << j["path"].get<std::string>() << "\n"
            << "  format     " << j["format"].get<std::string>() << "\n"
            << "  modality   " << (j["modality"].get<std::string>().empty() ? "-" : j["modality"].get<std::string>()) << "\n"
            << "  dims       " << j["dims"][0] << " x " << j["dims"][1] << " x " << j["dims"][2] << "\n"
            << "  type       " << j["type"].get<std::string>() << "\n"
            << "  spacing    " << vec(j["spacing_mm"]) << " mm\n"
            << "  origin     " << vec(j["origin_mm"]) << " mm\n"
            << "  direction  " << vec(j["direction"][0]) << "\n"
            << "             " << vec(j["direction"][1]) << "\n"
            << "             " << vec(j["direction"][2]) << "\n"
            << "  extent     " << vec(j["extent_mm"]) << " mm\n"
            << "  range      " << vec(j["value_range"]) << "\n";
  if (!j["series"].empty()) {
    std::cout << "  series     " << j["series"].size() << "\n";
    for (const auto& s : j["series"])
      std::cout << "    " << (s["loaded"].get<bool>() ? "* " : "  ") << s["uid"].get<std::string>() << "  "
                << s["modality"].get<std::string>() << "  " << s["columns"] << "x" << s["rows"] << "x"
                << s["frames"] << "  " << s["files"] << " file(s)  " << s["description"].get<std::string>()
                << "\n";
  }
  for (const auto& w : j["warnings"]) std::cout << "  warning    " << w.get<std::string>() << "\n";
}

}  // namespace

std::string infoFlagsMarkdown() { return params::markdown(infoFlagsTable()); }

void addInfoCommand(CLI::App& app) {
  auto args = std::make_shared<InfoArgs>();
  auto* cmd = app.add_subcommand("info", "Print a volume's geometry, type, value range, modality and DICOM series");
  addInput(*cmd, "input", args->input, "volume file or DICOM folder")->required();
  addFlags(*cmd, *args, infoFlagsTable());  // --json
  args->in.addTo(*cmd);
  cmd->footer("Example: vellum info ../shared/data/ct-head-phantom --json");
  cmd->callback([args] {
    const io::LoadedVolume lv = loadWithProgress(args->input, args->in, /*quiet=*/true);
    const nlohmann::json j = describe(args->input, lv);
    if (args->json)
      std::cout << j.dump(2) << "\n";
    else
      printHuman(j);
  });
}

}  // namespace vellum::cli
