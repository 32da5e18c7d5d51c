#pragma once
// CLI11 flags generated from a parameter table (vellum/core/params.hpp): one flag per field,
// --key with '_' -> '-', its help from the table, its default shown from the struct's own
// initialisers, its value parsed and range-checked by the table.
#include <CLI/CLI.hpp>

#include <map>
#include <set>
#include <string>
#include <vector>

#include "vellum/core/params.hpp"

namespace vellum::cli {

/// "Control scale: the map is ... [voxels] (1..16)".
std::string flagHelp(const params::Info& info, const std::string& range);

/// The words joined by spaces.
std::string joinWords(const std::vector<std::string>& words);

/// The command line (without the program name) with "--flag false" (true/false, on/off,
/// yes/no, 1/0) joined into "--flag=false" for every boolean flag of the subcommand named in
/// it: CLI11 parses only the "=" form, and a boolean word after a flag is never a positional.
std::vector<std::string> joinBooleanFlagValues(CLI::App& app, std::vector<std::string> args);

/// Adds the flags of `table` (except the keys in `skip`) to `cmd`, each named
/// params::cliFlag(prefix + key); parsing writes into `target`, which must outlive the parse.
/// Returns the options by key, so that a caller can ask whether a flag was given
/// (`->count()`), e.g. to let a file's value stand otherwise.
template <class S>
std::map<std::string, CLI::Option*> addFlags(CLI::App& cmd, S& target, const params::Table<S>& table,
                                             const std::set<std::string>& skip = {},
                                             const std::string& prefix = "") {
  std::map<std::string, CLI::Option*> options;
  for (const auto& field : table) {
    if (skip.count(field.key)) continue;
    const auto* f = &field;  // tables are static: the pointer outlives the parse
    const std::string help = flagHelp(f->info, params::rangeText(f->kind, f->info, f->choices));
    CLI::Option* o = nullptr;
    if (f->kind == params::Kind::Flag) {
      // --flag sets true, --flag=false sets false.
      o = cmd.add_flag_function(params::cliFlag(prefix + f->key) + "{true}",
                                [&target, f](std::int64_t n) { f->set(target, n > 0 ? 1.0 : 0.0); }, help);
    } else if (f->kind == params::Kind::Vector) {
      o = cmd.add_option_function<std::vector<std::string>>(
          params::cliFlag(prefix + f->key),
          [&target, f](const std::vector<std::string>& v) { params::parse(*f, target, joinWords(v)); }, help);
      // One syntax for three numbers: "X,Y,Z" (one word) or "X Y Z" (three).
      o->expected(1, 3)->type_name("X,Y,Z");
    } else {
      o = cmd.add_option_function<std::string>(
          params::cliFlag(prefix + f->key), [&target, f](const std::string& v) { params::parse(*f, target, v); }, help);
      o->type_name(f->kind == params::Kind::Choice ? "NAME" : f->kind == params::Kind::Text ? "TEXT" : "NUMBER");
    }
    const std::string d = params::format(*f, target);
    if (!d.empty()) o->default_str(d);
    options[f->key] = o;
  }
  return options;
}

}  // namespace vellum::cli
