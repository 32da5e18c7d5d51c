#pragma once
// The studio's tests: running vellum-studio on a script (VELLUM_STUDIO_EXE is the binary), a
// phantom on disk and the script that opens it, waiting for the exact deformation map,
// skipping window tests without an X server.
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "deform_session.hpp"
#include "test_data.hpp"
#include "vellum/io/image_io.hpp"
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
/// The PNG frames in `studioDir` against the same names in `cliDir`, pixel for pixel (a test
/// failure per frame that differs); how many frames there were.
inline int expectSameFrames(const std::filesystem::path& studioDir, const std::filesystem::path& cliDir) {
  int frames = 0;
  for (const auto& e : std::filesystem::directory_iterator(studioDir)) {
    if (e.path().extension() != ".png") continue;
    ++frames;
    EXPECT_EQ(io::loadImage(e.path()).pixels, io::loadImage(cliDir / e.path().filename()).pixels)
        << e.path().filename();
  }
  return frames;
}

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

/// A small knee phantom as a scene: the bone preset and the default view.
inline ::vellum::studio::Scene boneScene(Dims dims = {40, 40, 44}) {
  ::vellum::studio::Scene scene;
  scene.ct = phantomOf(dims).ct;
  scene.resetView();
  scene.render.preset = ::vellum::render::Preset::Bone;
  return scene;
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

/// The joint tests' limb: 40³ voxels of 2 mm, as the pose tests use. Parent bone 1 (z 40..74
/// mm), child bone 2 (z 12..38 mm): elliptic cylinders (x half-width 10 mm, y 5 mm) touching
/// across one voxel gap, so the contact zone's widest direction is x; soft tissue (radius
/// 16 mm) around, a fixed block aside. Written as DIR/ct.nrrd and DIR/labels.nrrd (what
/// scriptOnPhantom opens).
inline constexpr int kLimbN = 40;
inline constexpr uint16_t kLimbSoft = 100, kLimbFixed = 50;
/// The limb's grid: kLimbN³ voxels of 2 mm.
inline Geometry limbGeometry() {
  Geometry g;
  g.dims = {kLimbN, kLimbN, kLimbN};
  g.spacing = {2, 2, 2};
  return g;
}
inline void writeLimb(const std::filesystem::path& dir, VolumeI16& ct, LabelVolume& labels) {
  const Geometry g = limbGeometry();
  ct = VolumeI16(g, -1000);
  labels = LabelVolume(g);
  for (int k = 0; k < kLimbN; ++k)
    for (int j = 0; j < kLimbN; ++j)
      for (int i = 0; i < kLimbN; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        uint16_t id = 0;
        int16_t hu = -1000;
        if (std::hypot(p.x - 40, p.y - 40) <= 16 && p.z >= 4 && p.z <= 76) id = kLimbSoft, hu = 40;
        if (std::hypot((p.x - 40) / 10, (p.y - 40) / 5) <= 1) {
          if (p.z >= 40 && p.z <= 74) id = 1, hu = 1000;
          if (p.z >= 12 && p.z <= 38) id = 2, hu = 1000;
        }
        if (p.x >= 2 && p.x <= 10 && p.y >= 2 && p.y <= 10 && p.z >= 2 && p.z <= 30) id = kLimbFixed, hu = 600;
        ct(i, j, k) = hu;
        labels(i, j, k) = id;
      }
  io::saveVolume(AnyVolume(ct), dir / "ct.nrrd");
  io::saveLabels(labels, dir / "labels.nrrd");
}

/// writeLimb into a new test::tempDir(name) (removed after the test); returns the folder.
inline std::filesystem::path limbDir(const std::string& name) {
  const std::filesystem::path dir = test::tempDir(name);
  VolumeI16 ct;
  LabelVolume labels;
  writeLimb(dir, ct, labels);
  return dir;
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
