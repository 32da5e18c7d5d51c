// `vellum labels IN --out OUT [--assign IDS=ID] [--drop IDS] [--keep IDS] [--name ID=NAME]
// [--color ID=R,G,B]`: edits a label map's ids (app::runLabelEdit; this file parses and prints).
#include <cstdio>
#include <iostream>
#include <memory>

#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/label_edit.hpp"
#include "vellum/core/error.hpp"

namespace vellum::cli {
namespace {

struct LabelsArgs {
  app::LabelEditRequest request;
  std::vector<std::string> assign, drop, keep, names;
  std::vector<ColourArg> colours;  ///< --colour ID=R,G,B (0..1) or the old --color (0..255)
};

/// The edits of `labels`, described once (docs/parameters.md); --colour is addColourOption's.
const ListTable<LabelsArgs>& labelsListTable() {
  using A = LabelsArgs;
  static const ListTable<A> t{
      repeated<A>("assign", &A::assign, "IDS=ID",
                  {"Assign", "these ids (comma list or ranges 3-7) become ID (repeatable)", ""}),
      repeated<A>("drop", &A::drop, "IDS", {"Drop", "these ids become background (repeatable)", ""}),
      repeated<A>("keep", &A::keep, "IDS", {"Keep", "every id not listed (and not assigned) becomes background", ""}),
      repeated<A>("name", &A::names, "ID=NAME", {"Name", "the table name of ID in the result (repeatable)", ""}),
  };
  return t;
}

uint16_t parseId(const std::string& text, const std::string& flag) {
  try {
    size_t used = 0;
    const long v = std::stol(text, &used);
    if (used == text.size() && v >= 0 && v <= 65535) return static_cast<uint16_t>(v);
  } catch (const std::exception&) {
  }
  throw Error(flag + ": '" + text + "' is not a label id (0..65535)");
}

std::vector<uint16_t> parseIds(const std::string& text, const std::string& flag) {
  std::vector<uint16_t> ids;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string part = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const size_t dash = part.find('-', 1);
    if (dash != std::string::npos) {  // a range "3-7"
      const uint16_t lo = parseId(part.substr(0, dash), flag), hi = parseId(part.substr(dash + 1), flag);
      if (hi < lo) throw Error(flag + ": range '" + part + "' runs backwards");
      for (uint32_t v = lo; v <= hi; ++v) ids.push_back(static_cast<uint16_t>(v));
    } else {
      ids.push_back(parseId(part, flag));
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return ids;
}

/// "KEY=VALUE" split at the first '='.
std::pair<std::string, std::string> keyValue(const std::string& text, const std::string& flag, const char* form) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    throw Error(flag + ": '" + text + "' is not " + form);
  return {text.substr(0, eq), text.substr(eq + 1)};
}

void print(const char* title, const std::vector<app::LabelEditResult::Entry>& entries) {
  std::printf("%s:\n", title);
  for (const auto& e : entries)
    std::printf("  %5u  %-24s %12lld voxels  %10.2f cm³  centre %7.1f %7.1f %7.1f mm\n", e.id, e.name.c_str(),
                static_cast<long long>(e.voxels), e.volumeMm3 / 1000.0, e.centreMm.x, e.centreMm.y, e.centreMm.z);
}

}  // namespace

std::string labelsFlagsMarkdown() { return listMarkdownTable(labelsListTable()); }

void addLabelsCommand(CLI::App& app) {
  auto a = std::make_shared<LabelsArgs>();
  app::LabelEditRequest& r = a->request;
  auto* cmd = app.add_subcommand("labels", "Edit a label map's ids: merge pieces into one id, drop, keep, rename, recolour");
  addInput(*cmd, "input", r.input, "label map")->required();
  addOutput(*cmd, "--out,-o", r.output, "edited label map (.nrrd keeps the label table)")->required();
  addLists(*cmd, *a, labelsListTable());  // --assign, --drop, --keep, --name
  addColourOption(*cmd, a->colours, "ID=R,G,B", "the table colour of ID in the result (repeatable)");
  addOutput(*cmd, "--report", r.report, "write the ids, voxels and volumes before and after as JSON");
  addForceFlag(*cmd, r.force);
  cmd->footer(
      "Examples (after `vellum segment ... --split`):\n"
      "  vellum labels bones.nrrd --out bones2.nrrd --assign 3,7=3 --name 3=tibia --drop 9-12\n"
      "  vellum labels bones.nrrd --out right-foot.nrrd --keep 1,4,5");
  cmd->callback([a] {
    app::LabelEditRequest r = a->request;
    for (const auto& s : a->assign) {
      const auto [from, to] = keyValue(s, "--assign", "IDS=ID");
      r.assign.push_back({parseIds(from, "--assign"), parseId(to, "--assign")});
    }
    for (const auto& s : a->drop)
      for (uint16_t id : parseIds(s, "--drop")) r.drop.push_back(id);
    for (const auto& s : a->keep)
      for (uint16_t id : parseIds(s, "--keep")) r.keep.push_back(id);
    for (const auto& s : a->names) {
      const auto [id, name] = keyValue(s, "--name", "ID=NAME");
      r.names[parseId(id, "--name")] = name;
    }
    for (const ColourArg& c : a->colours) {
      const char* flag = c.scale == 1.0 ? "--colour" : "--color";
      const auto [id, rgb] = keyValue(c.text, flag, "ID=R,G,B");
      r.colours[parseId(id, flag)] = colourBytes({rgb, c.scale}, flag);
    }
    r.commandLine = commandLine();
    ProgressBar bar;
    const app::LabelEditResult result = app::runLabelEdit(r, bar.progress());
    bar.finish();
    print("before", result.before);
    print((r.output.string() + " after").c_str(), result.after);
  });
}

}  // namespace vellum::cli
