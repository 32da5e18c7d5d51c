#include "cli_params.hpp"

namespace vellum::cli {

std::string flagHelp(const params::Info& info, const std::string& range) {
  std::string help = info.label + ": " + info.help;
  if (!info.unit.empty()) help += " [" + info.unit + "]";
  return help + " (" + range + ")";
}

}  // namespace vellum::cli
