#pragma once
// CLI11 flags generated from a parameter table (vellum/core/params.hpp): one flag per field,
// --key with '_' -> '-', its help from the table, its default shown from the struct's own
// initialisers, its value parsed and range-checked by the table.
#include <CLI/CLI.hpp>

#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "vellum/core/params.hpp"

namespace vellum::cli {

/// "Control scale: the map is ... [voxels] (1..16)".
std::string flagHelp(const params::Info& info, const std::string& range);

/// Runs `parse` (a params::parse of flag `flag`'s value); its error names the flag the user
/// typed ("--zoom: 'abc' is not a number") rather than the table key JSON files use.
void parseNamingFlag(const std::string& key, const std::string& flag, const std::function<void()>& parse);

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
/// `shortNames` gives a key a short form besides --key ({"quiet", "-q"}).
template <class S>
std::map<std::string, CLI::Option*> addFlags(CLI::App& cmd, S& target, const params::Table<S>& table,
                                             const std::set<std::string>& skip = {},
                                             const std::string& prefix = "",
                                             const std::map<std::string, std::string>& shortNames = {}) {
  std::map<std::string, CLI::Option*> options;
  for (const auto& field : table) {
    if (skip.count(field.key)) continue;
    const auto* f = &field;  // tables are static: the pointer outlives the parse
    const std::string help = flagHelp(f->info, params::rangeText(f->kind, f->info, f->choices));
    const auto shortName = shortNames.find(f->key);
    const std::string name =
        params::cliFlag(prefix + f->key) + (shortName == shortNames.end() ? "" : "," + shortName->second);
    CLI::Option* o = nullptr;
    if (f->kind == params::Kind::Flag) {
      // --flag sets true, --flag=false sets false.
      // A short form gets the same default value ("-q{true}").
      o = cmd.add_flag_function(params::cliFlag(prefix + f->key) + "{true}" +
                                    (shortName == shortNames.end() ? "" : "," + shortName->second + "{true}"),
                                [&target, f](std::int64_t n) { f->set(target, n > 0 ? 1.0 : 0.0); }, help);
    } else if (f->kind == params::Kind::Vector) {
      o = cmd.add_option_function<std::vector<std::string>>(
          name,
          [&target, f, flag = params::cliFlag(prefix + f->key)](const std::vector<std::string>& v) {
            parseNamingFlag(f->key, flag, [&] { params::parse(*f, target, joinWords(v)); });
          },
          help);
      // One syntax for three numbers: "X,Y,Z" (one word) or "X Y Z" (three).
      o->expected(1, 3)->type_name("X,Y,Z");
    } else {
      o = cmd.add_option_function<std::string>(
          name,
          [&target, f, flag = params::cliFlag(prefix + f->key)](const std::string& v) {
            parseNamingFlag(f->key, flag, [&] { params::parse(*f, target, v); });
          },
          help);
      o->type_name(f->kind == params::Kind::Choice ? "NAME" : f->kind == params::Kind::Text ? "TEXT" : "NUMBER");
    }
    const std::string d = params::format(*f, target);
    if (!d.empty()) o->default_str(d);
    options[f->key] = o;
  }
  return options;
}

// ---- Lists: the flags a params::Field (one value) cannot hold --------------------------------

/// How a list flag takes its values.
enum class ListShape {
  Count,   ///< exactly `count` numbers after the flag: --raw-dims X Y Z (unset when absent)
  Comma,   ///< a comma list; repeating the flag appends: --ids 1,3 --ids 4
  Repeat,  ///< one value per flag, repeatable: --seed 0,0,0 --seed 5,5,5
};

/// A flag whose value is a list (a std::vector member): described once like a params::Field
/// (key, label, help, unit, each number's range), bound by addLists(), listed in
/// docs/parameters.md by listMarkdown(). The CLI binding is CLI11's own for a vector, so a row
/// parses exactly as the option it replaced.
template <class S>
struct ListRow {
  std::string key;          ///< --key with '_' -> '-'
  params::Info info;        ///< min/max: each number's range (numbers only)
  ListShape shape = ListShape::Repeat;
  size_t count = 0;         ///< ListShape::Count
  std::string form;         ///< what a value looks like: "X Y Z", "ID,ID..", "NAME:MM"
  std::string shortName;    ///< a short form besides --key ("-s"), or ""
  bool required = false;
  std::function<CLI::Option*(CLI::App&, S&, const std::string& name, const std::string& help)> bind;
  std::function<std::string(const S&)> format;  ///< the values as typed ("" when none: "unset" in the docs)

  ListRow& withShortName(std::string name) {
    shortName = std::move(name);
    return *this;
  }
  ListRow& makeRequired() {
    required = true;
    return *this;
  }
};

template <class S>
using ListTable = std::vector<ListRow<S>>;

/// "3 numbers X Y Z, each 1..16", "comma list ID,ID.., repeatable", "X,Y,Z, repeatable".
std::string listRangeText(ListShape shape, size_t count, const std::string& form, const params::Info& info);

/// A list row bound to the std::vector member `ref` (pointer to member or callable, as for a
/// params::Field).
template <class S, class Ref>
ListRow<S> list(std::string key, Ref ref, ListShape shape, std::string form, params::Info info, size_t count = 0) {
  ListRow<S> row;
  row.key = std::move(key);
  row.info = std::move(info);
  row.shape = shape;
  row.count = count;
  row.form = std::move(form);
  row.bind = [ref, shape, count](CLI::App& cmd, S& s, const std::string& name, const std::string& help) {
    auto& member = params::detail::member(ref, s);
    CLI::Option* o = cmd.add_option(name, member, help);
    if (shape == ListShape::Count) o->expected(static_cast<int>(count));
    if (shape == ListShape::Comma) o->delimiter(',');
    return o;
  };
  row.format = [ref, shape](const S& s) {
    std::ostringstream out;
    for (const auto& v : params::detail::member(ref, s))
      out << (out.tellp() > 0 ? (shape == ListShape::Count ? " " : ",") : "") << v;
    return out.str();
  };
  return row;
}
/// Exactly `count` numbers: --raw-dims X Y Z.
template <class S, class Ref>
ListRow<S> numbers(std::string key, Ref ref, size_t count, std::string form, params::Info info) {
  return list<S>(std::move(key), ref, ListShape::Count, std::move(form), std::move(info), count);
}
/// A comma list, repeatable: --ids 1,3.
template <class S, class Ref>
ListRow<S> commaList(std::string key, Ref ref, std::string form, params::Info info) {
  return list<S>(std::move(key), ref, ListShape::Comma, std::move(form), std::move(info));
}
/// One value per flag, repeatable: --seed X,Y,Z --seed X,Y,Z.
template <class S, class Ref>
ListRow<S> repeated(std::string key, Ref ref, std::string form, params::Info info) {
  return list<S>(std::move(key), ref, ListShape::Repeat, std::move(form), std::move(info));
}

/// Adds the list flags of `table` (except the keys in `skip`) to `cmd`; parsing writes into
/// `target`, which must outlive the parse. Returns the options by key.
template <class S>
std::map<std::string, CLI::Option*> addLists(CLI::App& cmd, S& target, const ListTable<S>& table,
                                             const std::set<std::string>& skip = {}) {
  std::map<std::string, CLI::Option*> options;
  for (const auto& row : table) {
    if (skip.count(row.key)) continue;
    const std::string name = params::cliFlag(row.key) + (row.shortName.empty() ? "" : "," + row.shortName);
    CLI::Option* o = row.bind(cmd, target, name, flagHelp(row.info, listRangeText(row.shape, row.count, row.form, row.info)));
    o->type_name(row.form);
    if (std::isfinite(row.info.min) || std::isfinite(row.info.max))
      o->check(CLI::Range(row.info.min, row.info.max));
    if (row.required) o->required();
    options[row.key] = o;
  }
  return options;
}

/// The rows of `table` in params::markdown's format (no header: they follow a params::markdown
/// table, or listMarkdownTable() gives them one).
template <class S>
std::string listMarkdownRows(const ListTable<S>& table, const S& defaults = S{}) {
  std::string out;
  for (const auto& row : table) {
    const std::string d = row.format(defaults);
    out += params::markdownRow(row.key, d.empty() ? "unset" : d,
                               listRangeText(row.shape, row.count, row.form, row.info), row.info);
  }
  return out;
}
template <class S>
std::string listMarkdownTable(const ListTable<S>& table, const S& defaults = S{}) {
  return params::markdownHeader() + listMarkdownRows(table, defaults);
}

/// One switch bound to a bool: the --force of every command that writes (forceFlagTable()).
const params::Table<bool>& forceFlagTable();

}  // namespace vellum::cli
