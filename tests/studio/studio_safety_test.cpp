// vellum-studio keeps the user's work safe and its scripts honest: autosaves go to the user's
// state folder (never beside the data), a newer autosave is offered on the next start,
// closing with unsaved edits asks Save / Discard / Cancel, and a script fails loudly, naming
// the action, whenever something it asked for did not happen.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <optional>
#include <set>
#include <string>

#include "autosave.hpp"
#include "label_tools.hpp"
#include "scene_file.hpp"
#include "studio_run.hpp"
#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::test::studio;

/// The names in `dir` (empty when it does not exist).
std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) names.insert(it->path().filename().string());
  return names;
}

/// The autosave scenes (*.autosave.json) in the studio's state folder under `dir`.
std::vector<fs::path> stateAutosaves(const fs::path& dir) {
  std::vector<fs::path> out;
  const fs::path folder = stateHome(dir) / "vellum" / "autosave";
  for (const std::string& n : listing(folder))
    if (n.ends_with(".autosave.json")) out.push_back(folder / n);
  return out;
}

/// The label ids the script's bone threshold into label 1 gives on DIR/data/ct.nrrd.
std::vector<uint16_t> boneThreshold(const fs::path& ct) {
  const VolumeI16 v = toInt16(io::loadVolume(ct).volume);
  LabelVolume expected(v.geometry());
  thresholdInto(expected, v, segmentation::presetInterval(segmentation::Preset::Bone), {1, "bone", {1, 1, 1}});
  return expected.ids().voxels();
}

/// Sets an environment variable for one scope, restoring the old value after.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() { old_ ? (void)::setenv(name_, old_->c_str(), 1) : (void)::unsetenv(name_); }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

/// A scene with a tiny volume at `volumePath` (autosave names need no more).
Scene sceneOf(const fs::path& volumePath) {
  Scene s;
  Geometry g;
  g.dims = {2, 2, 2};
  s.ct = VolumeI16(g);
  s.volumePath = volumePath;
  return s;
}

TEST(StudioAutosave, TargetsLieInTheStateFolderAndDoNotCollide) {
  const fs::path d = test::tempDir("studio-autosave-names");
  const ScopedEnv state("XDG_STATE_HOME", (d / "state").string());
  const fs::path a = Autosaver::targetFor(sceneOf(d / "a" / "ct.nrrd"));
  const fs::path b = Autosaver::targetFor(sceneOf(d / "b" / "ct.nrrd"));
  EXPECT_EQ(a.parent_path(), d / "state" / "vellum" / "autosave");
  EXPECT_EQ(b.parent_path(), a.parent_path());
  EXPECT_NE(a, b) << "two volumes named ct.nrrd in different folders";
  EXPECT_TRUE(a.filename().string().starts_with("ct-")) << a;
  EXPECT_EQ(a, Autosaver::targetFor(sceneOf(d / "a" / ".." / "a" / "ct.nrrd"))) << "the same file, spelled differently";
  Scene dicom = sceneOf(d / "a" / "ct.nrrd");
  dicom.seriesUid = "1.2.3";
  EXPECT_NE(Autosaver::targetFor(dicom), a) << "another series of the same folder";
  Scene saved = sceneOf(d / "a" / "ct.nrrd");
  saved.scenePath = d / "scenes" / "knee.json";
  EXPECT_EQ(Autosaver::targetFor(saved), d / "scenes" / "knee.autosave.json") << "beside the saved scene";
  {
    const ScopedEnv relative("XDG_STATE_HOME", "relative/state");  // the XDG rule: ignored
    const ScopedEnv home("HOME", (d / "home").string());
    EXPECT_EQ(Autosaver::targetFor(sceneOf(d / "a" / "ct.nrrd")).parent_path(),
              d / "home" / ".local" / "state" / "vellum" / "autosave");
  }
}

/// Runs the studio on DIR/data/ct.nrrd with a bone threshold, autosaving every 0.05 s, and
/// quits without saving: what a crash leaves.
StudioRun editAndLeaveAnAutosave(const fs::path& d, const std::string& name) {
  return runStudio(d, name, R"({"actions":[{"threshold":{"preset":"bone","label":1}},{"autosave":"wait"},{"quit":0}]})",
                   q(d / "data" / "ct.nrrd") + " --autosave 0.05");
}

TEST(StudioSafetyScript, AutosaveLandsInTheStateFolderAndIsRecoveredOnTheNextStart) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-autosave");
  fs::create_directories(d / "data");
  vellum::test::studio::writePhantom(d / "data", 48);
  const fs::path ct = d / "data" / "ct.nrrd";
  const std::set<std::string> dataBefore = listing(d / "data");

  const StudioRun edit = editAndLeaveAnAutosave(d, "edit");
  ASSERT_EQ(edit.exitCode, 0) << edit.output;
  EXPECT_EQ(listing(d / "data"), dataBefore) << "nothing new beside the volume";
  const std::vector<fs::path> autosaves = stateAutosaves(d);
  ASSERT_EQ(autosaves.size(), 1u) << edit.output;
  const fs::path autosave = autosaves.front();
  const SceneFile sf = readSceneFile(autosave);
  EXPECT_EQ(sf.volume, ct.lexically_normal());
  ASSERT_EQ(sf.labels, Autosaver::labelsFor(autosave).lexically_normal());
  EXPECT_EQ(io::loadLabels(sf.labels).ids().voxels(), boneThreshold(ct));

  // An action while the recovery dialog is open is refused, loudly.
  const std::string open = q(ct);
  const StudioRun refused = runStudio(d, "refused", R"({"actions":[{"layout":"3d"}]})", open);
  EXPECT_NE(refused.exitCode, 0);
  EXPECT_NE(refused.output.find("script action #0 (layout): refused: the 'Recover autosave?' dialog is open"),
            std::string::npos)
      << refused.output;

  // Later: the autosave stays, untouched even by this session's own edits and autosaves.
  const auto writtenAt = fs::last_write_time(autosave);
  const StudioRun later = runStudio(d, "later", R"({"actions":[{"dialog":"later"},
      {"threshold":{"preset":"soft-tissue","label":2}},{"frames":40},{"quit":0}]})", open + " --autosave 0.05");
  ASSERT_EQ(later.exitCode, 0) << later.output;
  ASSERT_TRUE(fs::exists(autosave));
  EXPECT_EQ(fs::last_write_time(autosave), writtenAt);

  // Recover: the edited labels are back; a clean exit after saving removes the autosave.
  const StudioRun recover = runStudio(d, "recover", R"({"actions":[{"dialog":"recover"},
      {"save_labels":)" + q(d / "recovered.nrrd") + R"(},{"save_scene":)" + q(d / "saved.json") + R"(},{"quit":0}]})",
                                      open);
  ASSERT_EQ(recover.exitCode, 0) << recover.output;
  EXPECT_EQ(io::loadLabels(d / "recovered.nrrd").ids().voxels(), boneThreshold(ct));
  EXPECT_EQ(io::loadLabels(readSceneFile(d / "saved.json").labels).ids().voxels(), boneThreshold(ct));
  EXPECT_TRUE(stateAutosaves(d).empty()) << "saved: the autosave went with the clean exit";
  EXPECT_FALSE(fs::exists(Autosaver::labelsFor(autosave)));

  // Discard deletes the autosave and its label map; the volume opens as it is on disk.
  ASSERT_EQ(editAndLeaveAnAutosave(d, "edit2").exitCode, 0);
  ASSERT_EQ(stateAutosaves(d).size(), 1u);
  const StudioRun discard = runStudio(d, "discard", R"({"actions":[{"dialog":"discard"},
      {"save_labels":)" + q(d / "discarded.nrrd") + R"(},{"quit":0}]})", open);
  ASSERT_EQ(discard.exitCode, 0) << discard.output;
  EXPECT_TRUE(stateAutosaves(d).empty());
  EXPECT_FALSE(fs::exists(Autosaver::labelsFor(autosave)));
  const std::vector<uint16_t> ids = io::loadLabels(d / "discarded.nrrd").ids().voxels();
  EXPECT_TRUE(std::all_of(ids.begin(), ids.end(), [](uint16_t id) { return id == 0; }))
      << "the volume as on disk (opened without labels: an empty map), not the autosave's edits";
  EXPECT_EQ(listing(d / "data"), dataBefore) << "nothing beside the volume after all the runs";
}

TEST(StudioSafetyScript, ClosingWithUnsavedEditsAsksSaveDiscardCancel) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-close");
  vellum::test::studio::writePhantom(d, 48);
  const std::string open = q(d / "ct.nrrd");
  const std::string edit = R"({"threshold":{"preset":"bone","label":1}})";

  // Cancel keeps the window running; Discard (after Ctrl+Q) quits without saving.
  const StudioRun cancel = runStudio(d, "cancel", R"({"actions":[)" + edit + R"(,{"close":true},{"dialog":"cancel"},
      {"log":"still running"},{"key":"ctrl+q"},{"dialog":"discard"},{"log":"after discard"}]})", open);
  EXPECT_EQ(cancel.exitCode, 0) << cancel.output;
  EXPECT_NE(cancel.output.find("still running"), std::string::npos) << cancel.output;
  EXPECT_EQ(cancel.output.find("after discard"), std::string::npos) << "Discard quits: " << cancel.output;

  // Save, never saved before: the Save As browser, answered with a path; the scene is written, then it quits.
  const fs::path scene = d / "closed.json";
  const StudioRun save = runStudio(d, "save", R"({"actions":[)" + edit + R"(,{"close":true},{"dialog":"save"},
      {"dialog":{"path":)" + q(scene) + R"(}},{"log":"after save"}]})", open);
  EXPECT_EQ(save.exitCode, 0) << save.output;
  EXPECT_EQ(save.output.find("after save"), std::string::npos) << "Save quits: " << save.output;
  ASSERT_TRUE(fs::exists(scene)) << save.output;
  EXPECT_EQ(io::loadLabels(readSceneFile(scene).labels).ids().voxels(), boneThreshold(d / "ct.nrrd"));

  // No unsaved edits: closing quits at once; an action refused by the unsaved-changes dialog fails.
  const StudioRun clean = runStudio(d, "clean", R"({"actions":[{"close":true},{"log":"after close"}]})", q(scene));
  EXPECT_EQ(clean.exitCode, 0) << clean.output;
  EXPECT_EQ(clean.output.find("after close"), std::string::npos) << clean.output;
  const StudioRun refused = runStudio(d, "refused", R"({"actions":[)" + edit + R"(,{"close":true},{"click":[500,300]}]})", open);
  EXPECT_NE(refused.exitCode, 0);
  EXPECT_NE(refused.output.find("script action #2 (click): refused: the 'Unsaved changes' dialog is open"), std::string::npos)
      << refused.output;
}

TEST(StudioSafetyScript, ScriptFailuresExitNonZeroNamingTheAction) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-failures");
  vellum::test::studio::writePhantom(d, 48);
  const auto expectFailure = [&](const std::string& name, const std::string& script, const std::string& args,
                                 const std::string& message) {
    const StudioRun r = runStudio(d, name, script, args);
    EXPECT_NE(r.exitCode, 0) << name << ": " << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << name << ": " << r.output;
  };
  expectFailure("cmdline", R"({"actions":[{"log":"ran"}]})", q(d / "missing.nrrd"), "vellum-studio: command line: open failed:");
  expectFailure("cmdscene", R"({"actions":[{"log":"ran"}]})", q(d / "gone.json"), "gone.json");
  expectFailure("drag", R"({"actions":[{"open":)" + q(d / "ct.nrrd") + R"(},{"controls":"default"},
      {"drag_point":{"index":0,"by_px":[0,0]}}]})", "", "script action #2 (drag_point): moved nothing");
  expectFailure("expect", R"({"actions":[{"open":{"path":)" + q(d / "ct.nrrd") + R"(,"expect_error":true}}]})", "",
                "script action #0 (open): expected");
  expectFailure("nodialog", R"({"actions":[{"dialog":"ok"}]})", "", "script action #0 (dialog): no dialog is open");
}

}  // namespace
}  // namespace vellum::studio
