// docs/architecture.md against CMake: the module dependency table is generated from the
// vellum_module(NAME ... PUBLIC_DEPS ... PRIVATE_DEPS ...) calls of every CMakeLists.txt
// (VELLUM_REGEN_DOCS=1 rewrites it); a drift names the module and the difference.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kSource = VELLUM_SOURCE_DIR;
const std::string kBegin = "<!-- BEGIN module-dependencies (generated from CMake; do not edit) -->";
const std::string kEnd = "<!-- END module-dependencies -->";

struct Module {
  std::string file;  ///< the CMakeLists.txt that defines it, relative to the source folder
  std::set<std::string> publicDeps, privateDeps;  ///< vellum::* targets only
};
using Modules = std::map<std::string, Module>;  ///< by target, "vellum::core"

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string withoutComments(const std::string& text) {
  std::string out;
  bool comment = false;
  for (char c : text) {
    if (c == '#') comment = true;
    if (c == '\n') comment = false;
    if (!comment) out += c;
  }
  return out;
}

/// The vellum_module(...) calls of one CMakeLists.txt.
void readModules(const fs::path& file, Modules& modules) {
  const std::string text = withoutComments(slurp(file));
  const std::string call = "vellum_module(";
  for (size_t at = text.find(call); at != std::string::npos; at = text.find(call, at + 1)) {
    if (at > 0 && (std::isalnum(static_cast<unsigned char>(text[at - 1])) || text[at - 1] == '_')) continue;
    const size_t close = text.find(')', at);  // arguments hold ${VAR}s, never parentheses
    std::istringstream args(text.substr(at + call.size(), close - at - call.size()));
    std::string name, token, section;
    args >> name;
    if (name == "name") continue;  // the function's own definition
    Module& m = modules["vellum::" + name];
    m.file = fs::relative(file, kSource).string();
    while (args >> token) {
      if (token == "SOURCES" || token == "PUBLIC_DEPS" || token == "PRIVATE_DEPS") section = token;
      else if (token.rfind("vellum::", 0) == 0)
        (section == "PRIVATE_DEPS" ? m.privateDeps : m.publicDeps).insert(token);
    }
  }
}

Modules modulesFromCMake() {
  Modules modules;
  for (auto it = fs::recursive_directory_iterator(kSource); it != fs::recursive_directory_iterator(); ++it) {
    const std::string name = it->path().filename().string();
    if (it->is_directory() && (name == "build" || name.rfind("build-", 0) == 0 || name[0] == '.')) {
      it.disable_recursion_pending();
      continue;
    }
    if (name == "CMakeLists.txt") readModules(it->path(), modules);
  }
  return modules;
}

std::string code(const std::string& s) { return "`" + s + "`"; }

std::string joined(const std::set<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + code(n);
  return out;
}

/// Modules in dependency order: each after everything it depends on (ties by name). Fails
/// the test on a cycle (dependencies must point downwards only).
std::vector<std::string> dependencyOrder(const Modules& modules) {
  std::vector<std::string> order;
  std::set<std::string> placed;
  while (order.size() < modules.size()) {
    bool progress = false;
    for (const auto& [name, m] : modules) {
      if (placed.count(name)) continue;
      bool ready = true;
      for (const auto* deps : {&m.publicDeps, &m.privateDeps})
        for (const auto& d : *deps) ready = ready && (placed.count(d) || !modules.count(d));
      if (!ready) continue;
      order.push_back(name);
      placed.insert(name);
      progress = true;
      break;  // restart: the order is the same whatever the map order
    }
    if (!progress) {
      ADD_FAILURE() << "the vellum_module() dependencies have a cycle";
      break;
    }
  }
  return order;
}

std::string dependencyTable(const Modules& modules) {
  std::string out = kBegin + "\n| module | depends on |\n| --- | --- |\n";
  for (const auto& name : dependencyOrder(modules)) {
    const Module& m = modules.at(name);
    std::string deps = joined(m.publicDeps);
    if (!m.privateDeps.empty()) deps += (deps.empty() ? "privately " : "; privately ") + joined(m.privateDeps);
    out += "| " + code(name) + " | " + deps + " |\n";
  }
  return out + kEnd;
}

/// The table in the doc, read back: module -> {public deps, private deps}.
Modules modulesFromTable(const std::string& table) {
  Modules modules;
  std::istringstream lines(table);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("| `vellum::", 0) != 0) continue;
    const size_t split = line.find(" | ", 2);
    std::string name = line.substr(3, split - 4);
    Module& m = modules[name];
    const std::string deps = line.substr(split + 3);
    const size_t priv = deps.find("privately");
    for (size_t at = deps.find('`'); at != std::string::npos; at = deps.find('`', deps.find('`', at + 1) + 1)) {
      const std::string dep = deps.substr(at + 1, deps.find('`', at + 1) - at - 1);
      (priv != std::string::npos && at > priv ? m.privateDeps : m.publicDeps).insert(dep);
    }
  }
  return modules;
}

/// "vellum::app: CMake (ui/app/CMakeLists.txt) has public vellum::io, the table does not", one line each.
std::string differences(const Modules& cmake, const Modules& doc) {
  std::string out;
  for (const auto& [name, m] : cmake) {
    if (!doc.count(name)) {
      out += name + ": defined in " + m.file + ", missing from the table\n";
      continue;
    }
    const Module& d = doc.at(name);
    const auto compare = [&](const std::set<std::string>& a, const std::set<std::string>& b, const char* kind) {
      for (const auto& dep : a)
        if (!b.count(dep)) out += name + ": CMake (" + m.file + ") has " + kind + " " + dep + ", the table does not\n";
      for (const auto& dep : b)
        if (!a.count(dep)) out += name + ": the table has " + kind + " " + dep + ", CMake (" + m.file + ") does not\n";
    };
    compare(m.publicDeps, d.publicDeps, "public");
    compare(m.privateDeps, d.privateDeps, "private");
  }
  for (const auto& [name, d] : doc)
    if (!cmake.count(name)) out += name + ": in the table, but no vellum_module(" + name.substr(8) + " ...) defines it\n";
  return out;
}

}  // namespace

TEST(ArchitectureDoc, DependencyTableMatchesCMake) {
  const Modules cmake = modulesFromCMake();
  ASSERT_TRUE(cmake.count("vellum::core") && cmake.count("vellum::app")) << "no vellum_module() calls found under " << kSource;
  const fs::path doc = kSource / "docs" / "architecture.md";
  const std::string expected = dependencyTable(cmake);
  const auto generatedPart = [&](std::string& text, size_t& begin, size_t& length) {
    text = slurp(doc);
    begin = text.find(kBegin);
    const size_t end = text.find(kEnd);
    if (begin == std::string::npos || end == std::string::npos || end < begin) return false;
    length = end + kEnd.size() - begin;
    return true;
  };
  std::string text;
  size_t begin = 0, length = 0;
  ASSERT_TRUE(generatedPart(text, begin, length)) << "docs/architecture.md: the generated dependency table's markers are missing";
  if (const char* regen = std::getenv("VELLUM_REGEN_DOCS"); regen && std::string(regen) == "1") {
    text.replace(begin, length, expected);
    std::ofstream(doc, std::ios::binary) << text;
    ASSERT_TRUE(generatedPart(text, begin, length));
  }
  const std::string actual = text.substr(begin, length);
  EXPECT_EQ(differences(cmake, modulesFromTable(actual)), "")
      << "docs/architecture.md's dependency table drifted from CMake (VELLUM_REGEN_DOCS=1 rewrites it)";
  EXPECT_EQ(actual, expected) << "docs/architecture.md's dependency table is not in the generated form "
                                 "(VELLUM_REGEN_DOCS=1 rewrites it)";
}

// Every module has a row in the prose table ("Folders and targets") too.
TEST(ArchitectureDoc, EveryModuleIsDescribed) {
  const std::string text = slurp(kSource / "docs" / "architecture.md");
  const size_t table = text.find("## Folders and targets");
  ASSERT_NE(table, std::string::npos);
  const std::string prose = text.substr(table, text.find("\n## ", table + 1) - table);
  for (const auto& [name, m] : modulesFromCMake())
    EXPECT_NE(prose.find(code(name)), std::string::npos) << name << " (" << m.file << ") has no row in \"Folders and targets\"";
}

// The reader of the table reads what the writer writes (so that a drift is reported per module).
TEST(ArchitectureDoc, TableReadsBackAsWritten) {
  Modules m;
  m["vellum::core"].file = "core";
  m["vellum::io"] = {"io", {"vellum::core"}, {}};
  m["vellum::deformation"] = {"d", {"vellum::core"}, {"vellum::io"}};
  m["vellum::only_private"] = {"p", {}, {"vellum::core"}};
  const Modules back = modulesFromTable(dependencyTable(m));
  ASSERT_EQ(back.size(), m.size());
  for (const auto& [name, mod] : m) {
    EXPECT_EQ(back.at(name).publicDeps, mod.publicDeps) << name;
    EXPECT_EQ(back.at(name).privateDeps, mod.privateDeps) << name;
  }
  Modules drifted = m;
  drifted["vellum::deformation"].privateDeps.clear();
  EXPECT_EQ(differences(drifted, back), "vellum::deformation: the table has private vellum::io, CMake (d) does not\n");
  // Dependencies first: core, then io, then deformation.
  const auto order = dependencyOrder(m);
  EXPECT_LT(std::find(order.begin(), order.end(), "vellum::io") - order.begin(),
            std::find(order.begin(), order.end(), "vellum::deformation") - order.begin());
}
