#pragma once
// The studio's tests: running vellum-studio on a script (VELLUM_STUDIO_EXE is the binary), a
// phantom on disk and the script that opens it, waiting for the exact deformation map,
// skipping window tests without an X server.
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "deform_session.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

/// Skips a test that needs the window when there is no X server (ctest runs under xvfb-run -a).
#define REQUIRE_DISPLAY()                                                               \
  do {                                                                                  \
    if (!std::getenv("DISPLAY")) GTEST_SKIP() << "no DISPLAY (run under xvfb-run -a)"; \
  } while (0)

namespace vellum::test::studio {

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A path as a JSON string (built in place: GCC 12 warns falsely on "\"" + s + "\"").
inline std::string q(const std::filesystem::path& p) {
  std::string s = p.generic_string();
  s.insert(s.begin(), '"');
  s.push_back('"');
  return s;
}

struct StudioRun {
  int exitCode = -1;
  std::string output;  ///< stdout + stderr
};

/// The user's state folder the studio gets in runStudio (autosaves): DIR/state, never the
/// real home's.
inline std::filesystem::path stateHome(const std::filesystem::path& dir) { return dir / "state"; }

/// Writes `script` to DIR/NAME.json and runs the studio on it in a 1024x700 window (`args`
/// before the script: a file to open, --autosave, ...) with XDG_STATE_HOME=stateHome(DIR);
/// the output goes to DIR/NAME.log.
inline StudioRun runStudio(const std::filesystem::path& dir, const std::string& name, const std::string& script,
                           const std::string& args = "") {
  const std::filesystem::path scriptPath = dir / (name + ".json"), log = dir / (name + ".log");
  std::ofstream(scriptPath) << script;
  const std::string cmd = "XDG_STATE_HOME=\"" + stateHome(dir).string() + "\" \"" + VELLUM_STUDIO_EXE + "\" " + args +
                          " --size 1024x700 --script \"" + scriptPath.string() + "\" > \"" + log.string() + "\" 2>&1";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(log)};
}

/// The same, returning the exit code and the output in *output.
inline int runStudio(const std::filesystem::path& dir, const std::string& name, const std::string& script,
                     std::string* output) {
  StudioRun r = runStudio(dir, name, script);
  *output = std::move(r.output);
  return r.exitCode;
}

/// The knee phantom at `dims` voxels (its default field of view).
inline phantom::Phantom phantomOf(Dims dims) {
  phantom::PhantomOptions o;
  o.dims = dims;
  return phantom::makePhantom(o);
}

/// An n³ knee phantom written as DIR/ct.nrrd and DIR/labels.nrrd, returned for the checks.
inline phantom::Phantom writePhantom(const std::filesystem::path& dir, int n) {
  phantom::Phantom ph = phantomOf({n, n, n});
  io::saveVolume(AnyVolume(ph.ct), dir / "ct.nrrd");
  io::saveLabels(ph.labels, dir / "labels.nrrd");
  return ph;
}

/// A script's beginning: `{"actions":[` and the action that opens writePhantom's files in DIR
/// with their labels; the test appends its actions and `]}`.
inline std::string scriptOnPhantom(const std::filesystem::path& dir) {
  return "{\"actions\":[{\"open\":{\"path\":" + q(dir / "ct.nrrd") + ",\"labels\":" + q(dir / "labels.nrrd") + "}},";
}

/// Updates `session` for `scene` until the exact map has landed from the worker (at most 30 s).
inline void awaitExactMap(::vellum::studio::DeformSession& session, const ::vellum::studio::Scene& scene) {
  session.update(scene);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while ((session.solving() || session.preview()) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    session.update(scene);
  }
}

}  // namespace vellum::test::studio
