#include "script.hpp"

#include <GLFW/glfw3.h>

#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>

#include "app.hpp"
#include "joint_tool.hpp"
#include "studio_tools.hpp"
#include "raw_dialog.hpp"
#include "vellum/deformation/keyframes.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/render/render_settings.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

int parseButton(const std::string& b) {
  if (b == "left") return GLFW_MOUSE_BUTTON_LEFT;
  if (b == "right") return GLFW_MOUSE_BUTTON_RIGHT;
  if (b == "middle") return GLFW_MOUSE_BUTTON_MIDDLE;
  throw Error("unknown mouse button '" + b + "' (left, right, middle)");
}

int parseMods(const json& mods) {
  int m = 0;
  for (const auto& j : mods) {
    const std::string s = j.get<std::string>();
    if (s == "shift") m |= GLFW_MOD_SHIFT;
    else if (s == "ctrl") m |= GLFW_MOD_CONTROL;
    else if (s == "alt") m |= GLFW_MOD_ALT;
    else throw Error("unknown modifier '" + s + "' (shift, ctrl, alt)");
  }
  return m;
}

/// "ctrl+shift+z" -> (GLFW_KEY_Z, ctrl|shift).
std::pair<int, int> parseKey(const std::string& text) {
  int mods = 0;
  std::string rest = text;
  for (size_t plus; (plus = rest.find('+')) != std::string::npos && plus + 1 < rest.size();) {
    const std::string m = rest.substr(0, plus);
    rest = rest.substr(plus + 1);
    mods |= parseMods(json::array({m}));
  }
  if (rest.size() == 1 && std::isalpha(static_cast<unsigned char>(rest[0])))
    return {GLFW_KEY_A + (std::tolower(static_cast<unsigned char>(rest[0])) - 'a'), mods};
  if (rest.size() == 1 && std::isdigit(static_cast<unsigned char>(rest[0]))) return {GLFW_KEY_0 + (rest[0] - '0'), mods};
  static const std::map<std::string, int> named = {
      {"escape", GLFW_KEY_ESCAPE}, {"enter", GLFW_KEY_ENTER}, {"tab", GLFW_KEY_TAB},
      {"space", GLFW_KEY_SPACE},   {"delete", GLFW_KEY_DELETE}, {"backspace", GLFW_KEY_BACKSPACE},
      {"left", GLFW_KEY_LEFT},     {"right", GLFW_KEY_RIGHT},   {"up", GLFW_KEY_UP}, {"down", GLFW_KEY_DOWN}};
  if (auto it = named.find(rest); it != named.end()) return {it->second, mods};
  throw Error("unknown key '" + text + "'");
}

std::pair<double, double> point(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>()}; }

/// The steps one action expands to, played one per frame (a step returns true when done,
/// false to run again next frame).
struct Steps {
  const std::string& name;  ///< the action's name (one expander serves click and drag)
  std::deque<std::function<bool(StudioApp&)>>& list;
  std::optional<int>& quit;
  void once(std::function<void(StudioApp&)> f) {
    list.push_back([f = std::move(f)](StudioApp& a) {
      f(a);
      return true;
    });
  }
  void until(std::function<bool(StudioApp&)> f) { list.push_back(std::move(f)); }
  void frames(int n) {
    for (int i = 0; i < n; ++i) list.push_back([](StudioApp&) { return true; });
  }
  void waitIdle() { list.push_back([](StudioApp& a) { return a.idle(); }); }
  /// Waits until the queued tasks (label edits, files) are done; their error fails the step.
  void waitTasks() {
    once([](StudioApp& a) { a.clearTaskError(); });
    until([](StudioApp& a) { return !a.tasks().busy(); });
    once([](StudioApp& a) {
      if (!a.lastTaskError().empty()) throw Error(a.lastTaskError());
    });
  }
};

using Expander = void (*)(Steps&, const json& value);

void expandOpen(Steps& s, const json& v) {
  const std::string path = v.is_string() ? v.get<std::string>() : v.at("path").get<std::string>();
  const std::string labels = v.is_object() ? v.value("labels", "") : "";
  const std::string series = v.is_object() ? v.value("series", "") : "";
  const bool expectError = v.is_object() && v.value("expect_error", false);
  auto before = std::make_shared<fs::path>();
  s.once([=](StudioApp& a) {
    *before = a.scene().volumePath;
    a.requestOpen(path, labels, series);
  });
  s.until([](StudioApp& a) { return !a.loading(); });
  s.frames(1);  // the frame after the worker finished adopts the result
  s.once([=](StudioApp& a) {
    const std::string& err = a.lastLoadError();
    if (expectError) {
      if (err.empty()) throw Error("expected '" + path + "' to fail, but it opened");
      if (a.scene().volumePath != *before) throw Error("a failed open changed the scene");
      std::cout << "expected error: " << err << std::endl;
      if (a.errorBoxOpen()) a.answerDialog("ok");  // the box the script expected
    } else if (!err.empty()) {
      throw Error("open failed: " + err);
    }
  });
}

void expandLayout(Steps& s, const json& v) {
  const Layout l = parseLayout(v.get<std::string>());
  s.once([l](StudioApp& a) { a.setLayout(l); });
  s.frames(1);
}

void expandPreset(Steps& s, const json& v) {
  const render::Preset p = render::parsePreset(v.get<std::string>());
  s.once([p](StudioApp& a) { a.setPreset(p); });
}

void expandClickOrDrag(Steps& s, const json& v) {
  const json& spec = v;
  const bool isClick = s.name == "click";
  const auto from = point(isClick ? (spec.is_array() ? spec : spec.at("at")) : spec.at("from"));
  const auto to = isClick ? from : point(spec.at("to"));
  const int button = parseButton(spec.is_object() ? spec.value("button", "left") : "left");
  const int mods = spec.is_object() && spec.contains("mods") ? parseMods(spec["mods"]) : 0;
  const int moves = isClick ? 0 : (spec.is_object() ? spec.value("steps", 8) : 8);
  s.once([=](StudioApp& a) { a.injectCursorPos(from.first, from.second); });
  s.once([=](StudioApp& a) { a.injectMouseButton(button, GLFW_PRESS, mods); });
  for (int i = 1; i <= moves; ++i) {
    const double t = double(i) / moves;
    s.once([=](StudioApp& a) {
      a.injectCursorPos(from.first + (to.first - from.first) * t, from.second + (to.second - from.second) * t);
    });
  }
  s.once([=](StudioApp& a) { a.injectMouseButton(button, GLFW_RELEASE, mods); });
}

void expandScroll(Steps& s, const json& v) {
  const auto at = point(v.at("at"));
  const double dy = v.value("dy", 1.0);
  // Modifiers are held as keys around the notch (scroll events carry none).
  const bool ctrl = v.contains("mods") && (parseMods(v["mods"]) & GLFW_MOD_CONTROL);
  s.once([=](StudioApp& a) { a.injectCursorPos(at.first, at.second); });
  if (ctrl) s.once([](StudioApp& a) { a.injectKey(GLFW_KEY_LEFT_CONTROL, GLFW_PRESS, GLFW_MOD_CONTROL); });
  s.once([=](StudioApp& a) { a.injectScroll(0, dy); });
  if (ctrl) s.once([](StudioApp& a) { a.injectKey(GLFW_KEY_LEFT_CONTROL, GLFW_RELEASE, 0); });
}

SliceAxis parseAxis(const std::string& view) {
  if (view == "axial") return SliceAxis::Axial;
  if (view == "coronal") return SliceAxis::Coronal;
  if (view == "sagittal") return SliceAxis::Sagittal;
  throw Error("slice view must be \"axial\", \"coronal\" or \"sagittal\"");
}

void expandSliceView(Steps& s, const json& v) {
  // "axial": prints "slice_view axial zoom Z pan U V mm_per_pixel M"; {"fit": "axial"}: fits it.
  if (v.is_object() && v.contains("fit")) {
    const SliceAxis axis = parseAxis(v["fit"].get<std::string>());
    s.once([axis](StudioApp& a) { a.fitSliceView(axis); });
    s.frames(1);
    return;
  }
  const std::string name = v.get<std::string>();
  const SliceAxis axis = parseAxis(name);
  s.frames(1);  // panes laid out
  s.once([axis, name](StudioApp& a) {
    const SliceNavigation& n = a.sliceNavigation(axis);
    for (const Pane& p : a.panes())
      if (p.slice == axis) {
        std::printf("slice_view %s zoom %.6f pan %.4f %.4f mm_per_pixel %.6f\n", name.c_str(), n.zoom, n.panU, n.panV,
                    a.planeOf(p).mmPerPixel);
        std::fflush(stdout);
        return;
      }
    throw Error("the " + name + " slice is not shown");
  });
}

void expandWindowPreset(Steps& s, const json& v) {
  const std::string name = v.get<std::string>();
  s.once([name](StudioApp& a) { a.setWindowPreset(name); });
  s.frames(1);
}

void expandKey(Steps& s, const json& v) {
  const auto [key, mods] = parseKey(v.get<std::string>());
  // Init-captures: clang before 16 cannot capture structured bindings (the fuzz build).
  s.once([key = key, mods = mods](StudioApp& a) { a.injectKey(key, GLFW_PRESS, mods); });
  s.once([key = key, mods = mods](StudioApp& a) { a.injectKey(key, GLFW_RELEASE, mods); });
}

void expandFrames(Steps& s, const json& v) {
  s.frames(v.get<int>());
}

void expandWaitIdle(Steps& s, const json&) {
  s.waitIdle();
}

void expandScreenshot(Steps& s, const json& v) {
  const std::string path = v.is_string() ? v.get<std::string>() : v.at("path").get<std::string>();
  const std::string view = v.is_object() ? v.value("view", "window") : "window";
  int w = 0, h = 0;
  if (v.is_object() && v.contains("size")) w = v["size"].at(0).get<int>(), h = v["size"].at(1).get<int>();
  s.waitIdle();
  if (view == "3d") {
    s.once([=](StudioApp& a) { a.save3dScreenshot(path, w, h); });
  } else if (view == "window") {
    s.frames(2);  // ImGui settles hover and auto-sized windows over a couple of frames
    s.once([=](StudioApp& a) { a.requestWindowScreenshot(path); });
    s.until([](StudioApp& a) {
      if (a.screenshotPending()) return false;
      if (auto err = a.takeScreenshotError()) throw Error(*err);
      return true;
    });
  } else if (view == "axial" || view == "coronal" || view == "sagittal") {  // the slice image alone
    const SliceAxis axis = parseAxis(view);
    s.frames(1);  // the slices are re-rendered at the start of a frame
    s.once([=](StudioApp& a) { a.saveSliceScreenshot(path, axis); });
  } else {
    throw Error("screenshot view must be \"window\", \"3d\", \"axial\", \"coronal\" or \"sagittal\"");
  }
}

void expandSaveScene(Steps& s, const json& v) {
  const std::string path = v.get<std::string>();
  s.once([=](StudioApp& a) { a.saveScene(path); });
  s.waitTasks();
}

void expandSaveLabels(Steps& s, const json& v) {
  const std::string path = v.get<std::string>();
  s.once([=](StudioApp& a) { a.saveLabels(path); });
  s.waitTasks();
}

void expandThreshold(Steps& s, const json& v) {
  const json spec = v;
  s.once([spec](StudioApp& a) {
    ToolState& t = a.segmentation().tools();
    if (spec.contains("preset")) t.threshold = segmentation::presetInterval(segmentation::parsePreset(spec["preset"]));
    t.threshold.lower = spec.value("lower", t.threshold.lower);
    t.threshold.upper = spec.value("upper", t.threshold.upper);
    if (spec.contains("label")) t.activeLabel = spec["label"].get<uint16_t>();
    t.thresholdPreview = spec.value("preview", false);
    if (spec.value("apply", true)) a.segmentation().applyThreshold();
  });
  if (v.value("wait", true)) s.waitTasks();  // "wait": false leaves it queued (the next edits queue behind it)
}

void expandTool(Steps& s, const json& v) {
  const std::string t = v.get<std::string>();
  const Tool tool = t == "paint"      ? Tool::Paint
                    : t == "erase"    ? Tool::Erase
                    : t == "grow"     ? Tool::Grow
                    : t == "snake"    ? Tool::Snake
                    : t == "navigate" ? Tool::Navigate
                                      : throw Error("unknown tool '" + t + "'");
  s.once([tool](StudioApp& a) { a.segmentation().tools().tool = tool; });
}

void expandBrushRadius(Steps& s, const json& v) {
  const double r = v.get<double>();
  s.once([r](StudioApp& a) { a.segmentation().tools().brushRadiusMm = static_cast<float>(r); });
}

void expandActiveLabel(Steps& s, const json& v) {
  const auto id = v.get<uint16_t>();
  s.once([id](StudioApp& a) { a.segmentation().tools().activeLabel = id; });
}

void expandKeepLargest(Steps& s, const json&) {
  s.once([](StudioApp& a) { a.segmentation().keepLargestOfActive(); });
  s.waitTasks();
}

void expandFillHoles(Steps& s, const json& v) {
  s.once([](StudioApp& a) { a.segmentation().fillHolesOfActive(); });
  if (!(v.is_boolean() && !v.get<bool>())) s.waitTasks();  // false: queued, not waited for
}

void expandMorphology(Steps& s, const json& v) {
  const std::string op = v.get<std::string>();
  const Morphology m = op == "dilate" ? Morphology::Dilate
                       : op == "erode" ? Morphology::Erode
                       : op == "open"  ? Morphology::Open
                       : op == "close" ? Morphology::Close
                                       : throw Error("unknown morphology '" + op + "'");
  s.once([m](StudioApp& a) { a.segmentation().morphologyOfActive(m); });
  s.waitTasks();
}

void expandLockLabel(Steps& s, const json& v) {
  const auto id = v.at("id").get<uint16_t>();
  const bool on = v.value("locked", true);
  s.once([id, on](StudioApp& a) { on ? (void)a.scene().lockedLabels.insert(id) : (void)a.scene().lockedLabels.erase(id); });
}

void expandCamera(Steps& s, const json& v) {
  const json spec = v;
  s.once([spec](StudioApp& a) {
    render::Camera& c = a.scene().render.camera;
    c.azimuthDeg = spec.value("azimuth", c.azimuthDeg);
    c.elevationDeg = spec.value("elevation", c.elevationDeg);
    c.zoom = spec.value("zoom", c.zoom);
    c.fieldOfViewDeg = spec.value("fov", c.fieldOfViewDeg);
    if (spec.contains("pan")) c.panMm = {spec["pan"].at(0).get<double>(), spec["pan"].at(1).get<double>(), spec["pan"].at(2).get<double>()};
  });
}

void expandSet(Steps& s, const json& v) {
  // {"set": {"KEY": value, ...}}: view parameters by their table keys (the View panel's and
  // `vellum render`'s), each one undo step, through the same call as the panel.
  if (!v.is_object()) throw Error("\"set\" takes an object of view parameters");
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string key = it.key();
    const std::string value = it.value().is_string() ? it.value().get<std::string>() : it.value().dump();
    s.once([key, value](StudioApp& a) { a.setViewParameter(key, value); });
  }
  s.frames(1);
}

void expandShapes(Steps& s, const json& v) {
  // "labels": make shapes from the label map; otherwise a `vellum shape` folder. Waits.
  const std::string what = v.get<std::string>();
  s.once([what](StudioApp& a) { a.makeShapes(what == "labels" ? fs::path() : fs::path(what)); });
  s.waitTasks();  // the copies for the job
  s.until([](StudioApp& a) { return !a.shapeJob().pending(); });
  s.frames(2);
  s.once([](StudioApp& a) {
    if (!a.scene().shapes) throw Error("no shapes were made (see the message above)");
  });
}

void expandIllustrate(Steps& s, const json& v) {
  const bool on = v.get<bool>();
  s.once([on](StudioApp& a) { a.setIllustration(on); });
  s.frames(1);
}

void expandStyle(Steps& s, const json& v) {
  const std::string preset = v.get<std::string>();
  s.once([preset](StudioApp& a) { a.setStylePreset(preset); });
  s.frames(1);
}

void expandStyleSet(Steps& s, const json& v) {
  // {"style_set": {"segment": NAME | "default" | "unclassified" | "" (whole style), "KEY": value, ...}}
  if (!v.is_object()) throw Error("\"style_set\" takes an object");
  const std::string segment = v.value("segment", "");
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (it.key() == "segment") continue;
    const std::string key = it.key();
    const json& val = it.value();
    const std::string text = val.is_string() ? val.get<std::string>()
                             : val.is_array() && val.size() == 3 ? val[0].dump() + " " + val[1].dump() + " " + val[2].dump()
                                                                : val.dump();
    s.once([segment, key, text](StudioApp& a) { a.setStyleField(segment, key, text); });
  }
  s.frames(1);
}

void expandBookmark(Steps& s, const json& v) {
  // {"bookmark": {"add": NAME}} | {"bookmark": {"go": NAME}} | {"bookmark": {"delete": NAME}}
  const auto index = [](StudioApp& a, const std::string& n) {
    const auto& b = a.scene().bookmarks;
    for (size_t i = 0; i < b.size(); ++i)
      if (b[i].name == n) return i;
    throw Error("no camera bookmark named '" + n + "'");
  };
  if (v.contains("add")) {
    const std::string n = v["add"].get<std::string>();
    s.once([n](StudioApp& a) { a.addBookmark(n); });
  } else if (v.contains("go")) {
    const std::string n = v["go"].get<std::string>();
    s.once([n, index](StudioApp& a) { a.goToBookmark(index(a, n)); });
  } else if (v.contains("delete")) {
    const std::string n = v["delete"].get<std::string>();
    s.once([n, index](StudioApp& a) { a.deleteBookmark(index(a, n)); });
  } else {
    throw Error("\"bookmark\" takes {\"add\"|\"go\"|\"delete\": NAME}");
  }
  s.frames(1);
}

void expandRemoveIslands(Steps& s, const json& v) {
  // mm³, or {"mm3": mm³, "wait": false} (queued, not waited for).
  const double mm3 = v.is_object() ? v.at("mm3").get<double>() : v.get<double>();
  s.once([mm3](StudioApp& a) {
    a.segmentation().tools().minIslandMm3 = static_cast<float>(mm3);
    a.segmentation().removeIslandsOfActive();
  });
  if (!v.is_object() || v.value("wait", true)) s.waitTasks();
}

void expandHoldTasks(Steps& s, const json& v) {
  const bool on = v.get<bool>();
  s.once([on](StudioApp& a) { a.holdTasks(on); });
  if (on) s.until([](StudioApp& a) { return a.tasks().running() == "held task"; });
}

void expandOtsu(Steps& s, const json&) {
  s.once([](StudioApp& a) { a.segmentation().otsuThreshold(); });
}

void expandExportCommand(Steps& s, const json& v) {
  const std::string path = v.at("path").get<std::string>();
  const std::string out = v.at("figure").get<std::string>();
  s.once([=](StudioApp& a) {
    std::ofstream f(path);
    f << a.cliCommand(out) << "\n";
    if (!f) throw Error("cannot write " + path);
  });
}

/// The Export figure dialog's options from an action: "size" [w, h], "scale_bar",
/// "orientation", "labels" (booleans).
void setFigureOptions(StudioApp& a, const json& v) {
  FigureOptions& o = a.studioTools().figure.options;
  o = FigureOptions{};
  if (v.contains("size")) o.width = v["size"].at(0).get<int>(), o.height = v["size"].at(1).get<int>();
  o.scaleBar = v.value("scale_bar", false);
  o.orientation = v.value("orientation", false);
  o.labels = v.value("labels", false);
}

void expandExportFigure(Steps& s, const json& v) {
  // {"path": P, "size": [w, h], "scale_bar": b, "orientation": b, "labels": b}: Export figure,
  // waited for; its error fails the action.
  const std::string path = v.at("path").get<std::string>();
  s.waitIdle();
  s.once([=](StudioApp& a) {
    setFigureOptions(a, v);
    startFigureExport(a, path);
  });
  s.until([](StudioApp& a) { return !a.studioTools().figure.job.busy(); });
  s.frames(1);  // the frame adopts the outcome
  s.once([](StudioApp& a) {
    const FigureExportState& f = a.studioTools().figure;
    if (!f.lastError.empty()) throw Error("export figure failed: " + f.lastError);
    if (f.lastWritten.empty()) throw Error("export figure wrote nothing");
    if (a.errorBoxOpen()) a.answerDialog("ok");
  });
}

void expandCopyCommand(Steps& s, const json& v) {
  // {"figure": P, "path": FILE, options as export_figure}: Copy CLI command for a figure at P;
  // FILE gets what the clipboard holds.
  const std::string figure = v.at("figure").get<std::string>(), path = v.at("path").get<std::string>();
  s.once([=](StudioApp& a) {
    setFigureOptions(a, v);
    copyFigureCommand(a, figure);
    const char* clip = glfwGetClipboardString(nullptr);
    std::ofstream f(path);
    f << (clip ? clip : "") << "\n";
    if (!f) throw Error("cannot write " + path);
  });
}

void expandMeasure(Steps& s, const json& v) {
  // {"tool": "ruler" | "angle", "view": AXIS, "points_voxel": [[i, j, k], ...]}: clicks at those
  // voxel positions (projected onto the view's slice) with the tool, as a user does;
  // {"delete": n}: deletes measurement n (from 1). Then prints "measurement N: TEXT" for each.
  if (v.contains("delete")) {
    const int n = v["delete"].get<int>();
    s.once([n](StudioApp& a) { a.studioTools().measure.remove(size_t(n - 1)); });
  } else {
    const std::string tool = v.at("tool").get<std::string>();
    if (tool != "ruler" && tool != "angle") throw Error("measure tool must be \"ruler\" or \"angle\"");
    const SliceAxis axis = parseAxis(v.at("view").get<std::string>());
    const json points = v.at("points_voxel");
    s.frames(1);  // panes laid out
    s.once([=](StudioApp& a) { a.studioTools().measure.mode = tool == "ruler" ? MeasureMode::Ruler : MeasureMode::Angle; });
    for (const json& p : points) {
      auto at = std::make_shared<std::pair<double, double>>();
      s.once([=](StudioApp& a) {
        const Vec3 mm = a.scene().ct.geometry().indexToPhysical(Vec3{p.at(0).get<double>(), p.at(1).get<double>(), p.at(2).get<double>()});
        for (const Pane& pane : a.panes())
          if (pane.slice == axis) {
            const auto [x, y] = a.planeOf(pane).toPixel(mm);
            *at = {pane.rect.x + x, pane.rect.y + y};
            a.injectCursorPos(at->first, at->second);
            return;
          }
        throw Error(std::string("the ") + sliceAxisName(axis) + " slice is not shown");
      });
      s.once([](StudioApp& a) { a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0); });
      s.once([](StudioApp& a) { a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0); });
    }
    s.once([](StudioApp& a) { a.studioTools().measure.mode = MeasureMode::Off; });
  }
  s.once([](StudioApp& a) {
    const auto& items = a.studioTools().measure.items();
    for (size_t i = 0; i < items.size(); ++i)
      std::printf("measurement %zu: %s %.6f\n", i + 1, items[i].text().c_str(), items[i].value());
    std::fflush(stdout);
  });
}

void expandOpenRaw(Steps& s, const json& v) {
  // {"path": RAW, "dims": [x, y, z], "type": "int16", "spacing": [sx, sy, sz], "endian":
  // "little" | "big", "header": bytes}: the Open RAW dialog's answers; waits for the load.
  RawDialogState d;
  d.data = v.at("path").get<std::string>();
  for (int a = 0; a < 3; ++a) d.dims[a] = v.at("dims").at(a).get<int>();
  d.type = static_cast<int>(parseVoxelType(v.value("type", "int16")));
  if (v.contains("spacing"))
    for (int a = 0; a < 3; ++a) d.spacing[a] = v["spacing"].at(a).get<float>();
  d.bigEndian = v.value("endian", "little") == "big";
  d.headerBytes = v.value("header", 0);
  s.once([d](StudioApp& a) { openRawAs(a, d); });
  s.once([](StudioApp& a) {
    if (a.errorBoxOpen()) throw Error("open raw failed (see the message above)");
  });
  s.until([](StudioApp& a) { return !a.loading(); });
  s.frames(1);
  s.once([](StudioApp& a) {
    if (!a.lastLoadError().empty()) throw Error("open failed: " + a.lastLoadError());
  });
}

void expandHud(Steps& s, const json& v) {
  const bool on = v.get<bool>();
  s.once([on](StudioApp& a) { a.hudVisible = on; });
}

void expandLog(Steps& s, const json& v) {
  const std::string text = v.get<std::string>();
  s.once([text](StudioApp&) { std::cout << text << std::endl; });
}

void expandControls(Steps& s, const json& v) {
  const std::string which = v.get<std::string>();
  if (which != "default" && which != "labels") throw Error("controls must be \"default\" or \"labels\"");
  s.once([which](StudioApp& a) { a.points().placeControls(which == "labels"); });
  if (which == "labels") s.waitTasks();  // made on the task queue's worker
  s.frames(1);
}

void expandSnakeControl(Steps& s, const json& v) {
  // {"snake_control": "pause" | "resume" | "accept" | "cancel" | "wait"}: the snake panel's
  // buttons. "pause" waits for the first live contour, then until the worker has stopped, and
  // prints the iteration it stopped at; "accept", "cancel" and "wait" wait until what they keep
  // is applied. {"snake_control": {"seed_mm": [x, y, z]}} starts a snake there (as a click in a
  // slice at that point does; benchmarks).
  if (v.is_object()) {
    const auto& p = v.at("seed_mm");
    const Vec3 seed{p.at(0).get<double>(), p.at(1).get<double>(), p.at(2).get<double>()};
    s.once([seed](StudioApp& a) { a.segmentation().startSnake(seed); });
    s.frames(1);
    return;
  }
  const std::string what = v.get<std::string>();
  if (what == "wait") {
    s.until([](StudioApp& a) { return !a.segmentation().snake().pending(); });
    s.waitTasks();
  } else if (what == "pause") {
    s.until([](StudioApp& a) { return a.segmentation().snake().live().first != nullptr || !a.segmentation().snake().busy(); });
    s.once([](StudioApp& a) { a.segmentation().snake().setPaused(true); });
    s.until([](StudioApp& a) { return a.segmentation().snake().parked() || !a.segmentation().snake().busy(); });
    s.once([](StudioApp& a) {
      const auto [iteration, factor] = a.segmentation().snake().liveIteration();
      const auto live = a.segmentation().snake().live().first;
      std::cout << "snake paused at iteration " << iteration << " (1/" << factor << " resolution) ("
                << (live ? segmentation::countVoxels(*live) : 0) << " voxels)" << std::endl;
    });
  } else if (what == "resume") {
    s.once([](StudioApp& a) { a.segmentation().snake().setPaused(false); });
  } else if (what == "accept" || what == "cancel") {
    if (what == "accept") s.once([](StudioApp& a) { a.segmentation().snake().acceptCurrent(); });
    else s.once([](StudioApp& a) { a.segmentation().snake().cancel(); });
    s.until([](StudioApp& a) { return !a.segmentation().snake().pending(); });
    s.waitTasks();
  } else {
    throw Error("snake_control must be pause, resume, accept or cancel");
  }
  s.frames(1);
}

void expandPointDrag(Steps& s, const json& v) {
  // Finds where the point's end is drawn (3D view first), then drags from there through the
  // real mouse path: press, `steps` moves, release.
  const int index = v.at("index").get<int>();
  const std::string endName = v.value("end", "target");
  const bool attribute = s.name == "attribute_drag";
  PointTool tool = PointTool::Move;
  if (attribute) {
    const std::string t = v.at("tool").get<std::string>();
    tool = t == "lightness" ? PointTool::Lightness
           : t == "hue"     ? PointTool::Hue
           : t == "density" ? PointTool::Density
                            : throw Error("attribute_drag tool must be lightness, hue or density");
  }
  if (endName != "source" && endName != "target") throw Error("end must be \"source\" or \"target\"");
  const PointEnd end = endName == "source" ? PointEnd::Source : PointEnd::Target;
  const auto by = point(v.at("by_px"));
  const int mods = v.contains("mods") ? parseMods(v["mods"]) : 0;
  const int moves = std::max(1, v.value("steps", 8));
  const std::string view = v.value("view", "");
  auto from = std::make_shared<std::pair<double, double>>();
  s.frames(1);  // panes laid out
  auto previousTool = std::make_shared<PointTool>();
  auto trackBefore = std::make_shared<deformation::KeyframeTrack>();
  s.once([=](StudioApp& a) {
    *trackBefore = a.scene().authoring.track;
    *previousTool = a.points().tool();
    a.points().tool() = tool;  // the panel's Drag radio buttons
    const auto p = a.points().pointOnScreen(index, end, view);
    if (!p)
      throw Error("control point " + std::to_string(index) + " is not on screen" + (view.empty() ? "" : " in " + view));
    *from = *p;
    a.injectCursorPos(p->first, p->second);
  });
  s.once([=](StudioApp& a) { a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, mods); });
  for (int i = 1; i <= moves; ++i) {
    const double t = double(i) / moves;
    s.once([=](StudioApp& a) { a.injectCursorPos(from->first + by.first * t, from->second + by.second * t); });
  }
  s.once([=](StudioApp& a) {
    a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, mods);
    a.points().tool() = *previousTool;
    // The press landed elsewhere (another dot, a panel), or the drag was clamped away.
    if (samePoints(*trackBefore, a.scene().authoring.track)) throw Error(attribute ? "changed nothing" : "moved nothing");
  });
}

void expandKeyframe(Steps& s, const json& v) {
  // "add" | "delete" | "earlier" | "later" | {"select": k, "duration": s, "interpolation": "smooth", "loop": true}
  const json spec = v;
  s.once([spec](StudioApp& a) {
    if (spec.is_string()) {
      const std::string op = spec.get<std::string>();
      if (op == "add") a.points().editTrack("add keyframe", addKeyframe);
      else if (op == "delete") {
        const int k = a.scene().authoring.keyframe;
        a.points().editTrack("delete keyframe", [k](Authoring& x) { deleteKeyframe(x, k); });
      } else if (op == "camera") {  // the view's camera into the edited keyframe
        const int k = a.scene().authoring.keyframe;
        const render::Camera c = a.scene().render.camera;
        a.points().editTrack("keyframe camera", [k, c](Authoring& x) {
          x.track.keyframes[size_t(k)].camera = keyframeCameraOf(c);
        });
      } else if (op == "earlier" || op == "later") {
        const int k = a.scene().authoring.keyframe, by = op == "earlier" ? -1 : 1;
        a.points().editTrack("move keyframe", [k, by](Authoring& x) { moveKeyframe(x, k, by); });
      } else throw Error("keyframe must be \"add\", \"delete\", \"camera\", \"earlier\", \"later\" or an object");
      return;
    }
    Authoring& au = a.scene().authoring;
    if (!au.active()) throw Error("no keyframes: place control points first");
    if (spec.contains("select")) {
      const int k = spec["select"].get<int>();
      if (k < 0 || k >= int(au.track.keyframes.size())) throw Error("no keyframe " + std::to_string(k));
      au.keyframe = k;
      au.timeS.reset();
      au.touch();
    }
    a.points().editTrack("keyframe settings", [&spec](Authoring& x) {
      if (spec.contains("duration")) x.track.keyframes[size_t(x.keyframe)].durationS = spec["duration"].get<double>();
      if (spec.contains("interpolation"))
        x.track.interpolation = deformation::parseInterpolation(spec["interpolation"].get<std::string>());
      if (spec.contains("loop")) x.track.loop = spec["loop"].get<bool>();
    });
  });
  s.frames(1);
}

void expandKeyframeDrag(Steps& s, const json& v) {
  // {"from": k, "to": j}: drags block k onto block j (moves its pose); {"index": k, "by_px": dx}:
  // drags block k's duration handle. Through the real mouse path, from where the timeline drew
  // the blocks in the last frame.
  const bool move = v.contains("from");
  const int index = move ? v.at("from").get<int>() : v.at("index").get<int>();
  const int to = move ? v.at("to").get<int>() : index;
  const double byPx = move ? 0.0 : v.at("by_px").get<double>();
  const int moves = std::max(2, v.value("steps", 8));
  auto path = std::make_shared<std::array<double, 4>>();  // from x, y, to x, y
  s.frames(1);  // the timeline drawn
  // Scroll the tool panel with the wheel until the blocks are inside the window.
  auto tries = std::make_shared<int>(0);
  s.until([tries](StudioApp& a) {
    const auto& blocks = a.keyframeBlocks();
    if (blocks.empty()) return true;  // reported below
    const double top = blocks.front()[1], bottom = top + blocks.front()[3];
    const int height = a.windowSize().second;
    if (top >= 0 && bottom <= height) return true;
    if (++*tries > 200) throw Error("the keyframe timeline cannot be scrolled into the window");
    a.injectCursorPos(0.5 * blocks.front()[2] + blocks.front()[0], 0.5 * height);
    a.injectScroll(0, bottom > height ? -1 : 1);
    return false;
  });
  s.once([=](StudioApp& a) {
    const auto& blocks = a.keyframeBlocks();
    const int n = int(blocks.size());
    if (n == 0) throw Error("the keyframe timeline is not on screen");
    if (index < 0 || index >= n || to < 0 || to >= n)
      throw Error("no keyframe block " + std::to_string(index < 0 || index >= n ? index : to));
    const auto& b = blocks[size_t(index)];
    const double y = b[1] + 0.5 * b[3];
    if (move) {
      const auto& t = blocks[size_t(to)];
      const double body = StudioApp::kKeyframeHandlePx;
      *path = {b[0] + 0.5 * (b[2] - body), y, t[0] + 0.5 * (t[2] - body), t[1] + 0.5 * t[3]};
    } else {
      const double hx = b[0] + b[2] - 0.5 * StudioApp::kKeyframeHandlePx;
      *path = {hx, y, hx + byPx, y};
    }
    a.injectCursorPos((*path)[0], (*path)[1]);
  });
  s.once([](StudioApp& a) { a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0); });
  for (int i = 1; i <= moves; ++i) {
    const double t = double(i) / moves;
    s.once([=](StudioApp& a) {
      const auto& p = *path;
      a.injectCursorPos(p[0] + (p[2] - p[0]) * t, p[1] + (p[3] - p[1]) * t);
    });
  }
  s.once([](StudioApp& a) { a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0); });
  s.frames(1);
}

void expandPlay(Steps& s, const json& v) {
  const double seconds = v.at("seconds").get<double>();
  auto until = std::make_shared<double>();
  s.once([=](StudioApp& a) {
    a.deform().play(true);
    *until = glfwGetTime() + seconds;
  });
  s.until([=](StudioApp& a) { return glfwGetTime() >= *until || !a.scene().authoring.playing; });
  s.once([](StudioApp& a) { a.deform().play(false); });
}

void expandExportMovie(Steps& s, const json& v) {
  const std::string out = v.at("out").get<std::string>();
  const double fps = v.value("fps", 30.0);
  int w = 512, h = 512;
  if (v.contains("size") && std::sscanf(v["size"].get<std::string>().c_str(), "%dx%d", &w, &h) != 2)
    throw Error("size must be WxH");
  const std::string command = v.value("command", "");
  const double orbit = v.value("orbit", 0.0);
  const double padMm = v.value("pad_mm", -1.0);  // --pad-mm: automatic unless asked
  s.once([=](StudioApp& a) { a.deform().startExport(out, fps, w, h, orbit, padMm); });
  if (!v.value("wait", true)) return;  // e.g. to press Escape while it runs
  s.until([](StudioApp& a) { return !a.deform().exporting(); });
  s.once([=](StudioApp& a) {
    if (!a.deform().lastExportError().empty()) throw Error("export failed: " + a.deform().lastExportError());
    if (!command.empty()) {
      std::ofstream f(command);
      f << a.deform().lastExportCommand() << "\n";
      if (!f) throw Error("cannot write " + command);
    }
  });
}

void expandRigidLabels(Steps& s, const json& v) {
  const std::vector<uint16_t> ids = v.get<std::vector<uint16_t>>();
  s.once([ids](StudioApp& a) { a.deform().setRigid(ids, a.scene().authoring.falloffMm, "rigid labels"); });
}

void expandJoint(Steps& s, const json& v) {
  // The joint tool (joint_tool.hpp: jointScriptAction's keys), then waits for its worker;
  // {"save_volume": PATH} waits for the exact map and writes the volume the studio shows.
  if (v.is_object() && v.contains("save_volume")) {
    const std::string path = v["save_volume"].get<std::string>();
    s.frames(2);  // the session has seen the last change
    s.waitIdle();
    s.once([path](StudioApp& a) { saveShownVolume(a, path); });
    return;
  }
  s.once([v](StudioApp& a) { jointScriptAction(a, v); });
  s.until([](StudioApp& a) { return !a.deform().joints().busy(); });
  s.once([](StudioApp& a) {
    if (!a.deform().joints().error().empty()) throw Error("joint tool: " + a.deform().joints().error());
  });
}

void expandDialog(Steps& s, const json& v) {
  // "recover" | "discard" | "later" | "save" | "cancel" | "ok": the open dialog's button;
  // {"path": P}: the file browser's answer. Waits a few frames for the dialog to open.
  if (!v.is_string() && !(v.is_object() && v.contains("path")))
    throw Error("\"dialog\" takes a button name or {\"path\": P}");
  auto waited = std::make_shared<int>(0);
  s.until([waited](StudioApp& a) {
    if (!a.openDialog().empty()) return true;
    if (++*waited > 30) throw Error("no dialog is open");
    return false;
  });
  if (v.is_string()) s.once([answer = v.get<std::string>()](StudioApp& a) { a.answerDialog(answer); });
  else s.once([path = v["path"].get<std::string>()](StudioApp& a) { a.answerFileBrowser(path); });
  s.frames(2);  // ImGui closes the popup and the next dialog (if any) opens
  // A Save writes the label map on a worker and quits when done; a Recover opens the autosave
  // on the loader: the script waits for both, so the next action sees their result.
  s.until([](StudioApp& a) { return !a.tasks().busy() && !a.loading(); });
  s.frames(1);  // the frame after the loader finished adopts the recovered scene
}

void expandAutosave(Steps& s, const json& v) {
  // "wait": until the autosave holds the session as it is (its copy of the labels made and
  // the files written); the autosave's own state, not a count of frames.
  if (v != "wait") throw Error("\"autosave\" takes \"wait\"");
  s.until([](StudioApp& a) { return a.autosaveSettled(); });
}

void expandClose(Steps& s, const json&) {
  s.once([](StudioApp& a) { a.requestClose(); });
  s.frames(2);  // the frame loop sees the close flag: quits, or asks about unsaved changes
}

void expandQuit(Steps& s, const json& v) {
  const int code = v.is_number_integer() ? v.get<int>() : 0;
  s.once([&quit = s.quit, code](StudioApp&) { quit = code; });
}

void expandCurveAnalogy(Steps& s, const json& v) {
  // {"curve_analogy": {"segment": NAME, "trace": [[x, y], ...] (window pixels, dragged through
  // the real mouse path with Trace on) | "drawing": PNG, "transfer": [NAME, ...], "apply": true}}:
  // applies (unless "apply" is false) and waits until the bent shapes are the scene's.
  const std::string segment = v.at("segment").get<std::string>();
  const std::vector<std::string> transfer = v.value("transfer", std::vector<std::string>{});
  if (v.contains("trace")) {
    std::vector<std::pair<double, double>> trace;
    for (const auto& p : v["trace"]) trace.push_back(point(p));
    if (trace.size() < 3) throw Error("\"trace\" needs at least 3 points");
    s.once([](StudioApp& a) { a.curves().setTracing(true); });
    s.frames(2);
    s.once([p = trace.front()](StudioApp& a) { a.injectCursorPos(p.first, p.second); });
    s.once([](StudioApp& a) { a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0); });
    for (size_t i = 1; i < trace.size(); ++i)
      s.once([p = trace[i]](StudioApp& a) { a.injectCursorPos(p.first, p.second); });
    s.once([](StudioApp& a) {
      a.injectMouseButton(GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
      a.curves().setTracing(false);
    });
  } else {
    const std::string drawing = v.at("drawing").get<std::string>();
    s.once([drawing](StudioApp& a) { a.curves().loadDrawing(drawing); });
  }
  const bool apply = v.value("apply", true);
  s.once([segment, transfer, apply](StudioApp& a) {
    a.curves().state().segment = segment;
    a.curves().state().transfer = {transfer.begin(), transfer.end()};
    if (apply) a.curves().apply();
  });
  if (!apply) return;  // C0 and the structure are set; the panel's Apply (or another action) runs it
  s.until([](StudioApp& a) { return !a.curves().state().busy(); });
  s.frames(1);  // the frame that adopts the result starts loading the new folder
  s.until([](StudioApp& a) { return !a.tasks().busy() && !a.shapeJob().pending(); });
  s.frames(2);
  s.once([](StudioApp& a) {
    if (!a.curves().state().lastError.empty()) throw Error("curve analogy failed: " + a.curves().state().lastError);
    if (a.scene().shapesPath != a.curves().state().jobOut) throw Error("the bent shapes were not loaded");
  });
}

/// Every action by name (docs/studio.md, "Scripts").
const std::map<std::string, Expander>& expanders() {
  static const std::map<std::string, Expander> table = {
      {"open", expandOpen},
      {"layout", expandLayout},
      {"preset", expandPreset},
      {"click", expandClickOrDrag},
      {"drag", expandClickOrDrag},
      {"scroll", expandScroll},
      {"key", expandKey},
      {"frames", expandFrames},
      {"wait_idle", expandWaitIdle},
      {"screenshot", expandScreenshot},
      {"save_scene", expandSaveScene},
      {"save_labels", expandSaveLabels},
      {"threshold", expandThreshold},
      {"tool", expandTool},
      {"brush_radius", expandBrushRadius},
      {"active_label", expandActiveLabel},
      {"keep_largest", expandKeepLargest},
      {"fill_holes", expandFillHoles},
      {"morphology", expandMorphology},
      {"lock_label", expandLockLabel},
      {"camera", expandCamera},
      {"set", expandSet},
      {"shapes", expandShapes},
      {"illustrate", expandIllustrate},
      {"style", expandStyle},
      {"style_set", expandStyleSet},
      {"bookmark", expandBookmark},
      {"remove_islands", expandRemoveIslands},
      {"otsu", expandOtsu},
      {"snake_control", expandSnakeControl},
      {"export_command", expandExportCommand},
      {"export_figure", expandExportFigure},
      {"copy_command", expandCopyCommand},
      {"measure", expandMeasure},
      {"open_raw", expandOpenRaw},
      {"hud", expandHud},
      {"log", expandLog},
      {"controls", expandControls},
      {"curve_analogy", expandCurveAnalogy},
      {"drag_point", expandPointDrag},
      {"attribute_drag", expandPointDrag},
      {"keyframe", expandKeyframe},
      {"keyframe_drag", expandKeyframeDrag},
      {"play", expandPlay},
      {"export_movie", expandExportMovie},
      {"rigid_labels", expandRigidLabels},
      {"joint", expandJoint},
      {"slice_view", expandSliceView},
      {"hold_tasks", expandHoldTasks},
      {"window_preset", expandWindowPreset},
      {"dialog", expandDialog},
      {"autosave", expandAutosave},
      {"close", expandClose},
      {"quit", expandQuit},
  };
  return table;
}

}  // namespace

std::unique_ptr<ScriptRunner> ScriptRunner::load(const fs::path& path) {
  auto r = std::unique_ptr<ScriptRunner>(new ScriptRunner);
  const json j = readJsonFile(path, 16u << 20, "studio script");  // scripts are hand-written: KBs
  try {
    r->actions_ = j.at("actions");
  } catch (const json::exception& e) {
    throw FileError(path, std::string("bad script: ") + e.what());
  }
  if (!r->actions_.is_array()) throw FileError(path, "\"actions\" must be a list");
  for (size_t n = 0; n < r->actions_.size(); ++n) {
    const json& a = r->actions_[n];
    if (!a.is_object() || a.size() != 1)
      throw FileError(path, "script action #" + std::to_string(n) + ": must be an object with one key");
    if (!expanders().count(a.begin().key()))
      throw FileError(path, "script action #" + std::to_string(n) + ": unknown action '" + a.begin().key() + "'");
  }
  return r;
}

namespace {
/// Actions a script may run while a modal dialog is open (they do not go through the UI).
bool runsBesideADialog(const std::string& name) {
  return name == "dialog" || name == "frames" || name == "wait_idle" || name == "log" || name == "screenshot" ||
         name == "quit";
}
}  // namespace

void ScriptRunner::openFirst(const fs::path& path, const fs::path& labels) {
  where_ = "command line";
  Steps steps{"open", steps_, quitCode_};
  expandOpen(steps, json{{"path", path.string()}, {"labels", labels.string()}});
}

std::optional<int> ScriptRunner::step(StudioApp& app) {
  if (quitCode_) return quitCode_;
  try {
    while (steps_.empty()) {
      // The end of the list quits successfully, once the queued edits and files are done.
      if (next_ >= actions_.size()) return app.tasks().busy() ? std::nullopt : std::optional<int>(0);
      const size_t n = next_++;
      const std::string name = actions_[n].begin().key();
      where_ = "script action #" + std::to_string(n) + " (" + name + ")";
      // A user's click would land on the dialog, not on the panel or view the action means.
      if (const std::string dialog = app.openDialog(); !dialog.empty() && !runsBesideADialog(name))
        throw Error("refused: the '" + dialog + "' dialog is open (answer it with a \"dialog\" action)");
      expand(actions_[n], app);
    }
    if (steps_.front()(app)) {
      steps_.pop_front();
      waitedFrames_ = 0;
    } else if (++waitedFrames_ > 20000) {
      const std::string pending = app.pendingWork();
      throw Error("timed out waiting" + (pending.empty() ? std::string() : " (still pending: " + pending + ")"));
    }
  } catch (const std::exception& e) {
    std::cerr << "vellum-studio: " << where_ << ": " << e.what() << "\n";
    return 3;
  }
  return quitCode_;
}

void ScriptRunner::expand(const json& action, StudioApp&) {
  const std::string name = action.begin().key();
  Steps steps{name, steps_, quitCode_};
  expanders().at(name)(steps, action.begin().value());
}

}  // namespace vellum::studio
