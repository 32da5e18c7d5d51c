#include "cli_params.hpp"

#include <cmath>
#include <set>

#include "vellum/core/error.hpp"

namespace vellum::cli {

std::string flagHelp(const params::Info& info, const std::string& range) {
  std::string help = info.label + ": " + info.help;
  if (!info.unit.empty()) help += " [" + info.unit + "]";
  return help + " (" + range + ")";
}

void parseNamingFlag(const std::string& key, const std::string& flag, const std::function<void()>& parse) {
  try {
    parse();
  } catch (const Error& e) {
    // params' messages begin "key: " or "key = " (params.cpp).
    const std::string m = e.what();
    const bool named = m.rfind(key, 0) == 0 && m.size() > key.size() && (m[key.size()] == ':' || m[key.size()] == ' ');
    throw Error(named ? flag + m.substr(key.size()) : flag + ": " + m);
  }
}

std::string joinWords(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : " ") + w;
  return out;
}

// "--flag false" means "--flag=false" for a boolean flag of the chosen subcommand (CLI11
/// takes only the "=" form; a following word that is not a boolean stays a positional).
std::vector<std::string> joinBooleanFlagValues(CLI::App& app, std::vector<std::string> args) {
  CLI::App* sub = nullptr;
  for (size_t i = 0; i + 1 < args.size(); ++i) {
    if (!sub) {
      if (args[i].rfind("-", 0) == 0) continue;
      for (CLI::App* s : app.get_subcommands([](CLI::App*) { return true; }))
        if (s->check_name(args[i])) sub = s;
      continue;
    }
    const std::string& next = args[i + 1];
    static const std::set<std::string> kBooleans{"true", "false", "on", "off", "yes", "no", "1", "0"};
    if (args[i].rfind("--", 0) != 0 || args[i].find('=') != std::string::npos || !kBooleans.count(next)) continue;
    const CLI::Option* o = sub->get_option_no_throw(args[i]);
    if (o && o->get_expected_max() == 0) {
      args[i] += "=" + next;
      args.erase(args.begin() + static_cast<std::ptrdiff_t>(i) + 1);
    }
  }
  return args;
}

std::string listRangeText(ListShape shape, size_t count, const std::string& form, const params::Info& info) {
  std::string each;
  if (std::isfinite(info.min) || std::isfinite(info.max))
    each = ", each " + params::rangeText(params::Kind::Real, info, {});
  switch (shape) {
    case ListShape::Count:
      return std::to_string(count) + " numbers " + form + each;
    case ListShape::Comma:
      return "comma list " + form + each + ", repeatable";
    case ListShape::Repeat:
      break;
  }
  return form + ", repeatable";
}

const params::Table<bool>& forceFlagTable() {
  static const params::Table<bool> t{
      params::flag<bool>("force", [](auto& force) -> auto& { return force; },
                         {"Force", "let an output folder replace a folder Vellum wrote as another kind of output "
                                   "(never a folder Vellum did not write)", ""}),
  };
  return t;
}

}  // namespace vellum::cli
