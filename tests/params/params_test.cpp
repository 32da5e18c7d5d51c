// One description per parameter: the tables drive validation, CLI flags, JSON and the docs.
#include <gtest/gtest.h>

#include <algorithm>

#include <fstream>
#include <set>
#include <sstream>

#include "cli_params.hpp"
#include "commands.hpp"
#include "test_data.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/deformation/mls.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/render_settings.hpp"
#include "vellum/segmentation/threshold.hpp"

using namespace vellum;

namespace {

template <class S>
void expectWellFormed(const params::Table<S>& table) {
  std::set<std::string> keys;
  for (const auto& f : table) {
    EXPECT_TRUE(keys.insert(f.key).second) << "duplicate key " << f.key;
    EXPECT_FALSE(f.info.label.empty()) << f.key;
    EXPECT_FALSE(f.info.help.empty()) << f.key;
    EXPECT_LE(f.info.min, f.info.max) << f.key;
    if (f.kind == params::Kind::Choice) {
      EXPECT_GE(f.choices.size(), 2u) << f.key;
    }
  }
  EXPECT_NO_THROW(params::validate(table, S{}));  // the struct's defaults are in range
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

void parseArgs(CLI::App& app, std::vector<std::string> args) {
  std::vector<const char*> argv{"vellum"};
  for (auto& a : args) argv.push_back(a.c_str());
  app.parse(static_cast<int>(argv.size()), argv.data());
}

}  // namespace

TEST(Params, TablesAreWellFormedAndDefaultsValid) {
  expectWellFormed(deformation::deformParamsTable());
  expectWellFormed(render::renderSettingsTable());
  expectWellFormed(segmentation::hysteresisParamsTable());
}

TEST(Params, ControlScaleAndHysteresisDefaultsComeFromTheStructs) {
  const auto& t = deformation::deformParamsTable();
  const auto cs = std::find_if(t.begin(), t.end(), [](const auto& f) { return f.key == "control_scale"; });
  ASSERT_NE(cs, t.end());
  EXPECT_EQ(params::format(*cs, deformation::DeformParams{}), "2");
  EXPECT_EQ(cs->info.min, 1);
  EXPECT_EQ(cs->info.max, 16);
  const std::string md = params::markdown(segmentation::hysteresisParamsTable());
  EXPECT_NE(md.find("| `strong_lower` | 1000 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `weak_lower` | 400 |"), std::string::npos) << md;
}

TEST(Params, ParseFormatAndRangeErrorsNameTheKey) {
  const auto& t = deformation::deformParamsTable();
  deformation::DeformParams p;
  for (const auto& f : t) {
    const std::string text = params::format(f, p);
    deformation::DeformParams q;
    params::parse(f, q, text);
    EXPECT_EQ(params::format(f, q), text) << f.key;
  }
  EXPECT_EQ(errorOf([&] { deformation::DeformParams q; q.controlScale = 0; deformation::validate(q); }),
            "control_scale = 0 is outside 1..16");
  const auto method = std::find_if(t.begin(), t.end(), [](const auto& f) { return f.key == "method"; });
  EXPECT_EQ(errorOf([&] { params::parse(*method, p, "bogus"); }),
            "method: 'bogus' is not one of affine, similarity, rigid");
  params::parse(*method, p, "rigid");
  EXPECT_EQ(p.mls.method, deformation::MlsMethod::Rigid);
  // The library refuses what the table refuses, whoever calls it.
  deformation::DeformParams bad;
  bad.controlScale = 17;
  Geometry g;
  g.dims = {8, 8, 8};
  EXPECT_THROW(deformation::Deformer(VolumeI16(g, -1000), bad), Error);
}

TEST(Params, EnumTablesRoundTripNameTheChoicesAndKeepOneRange) {
  for (const auto m : deformation::mlsMethods().all())
    EXPECT_EQ(deformation::parseMlsMethod(deformation::mlsMethodName(m)), m);
  for (const auto p : segmentation::presets().all())
    EXPECT_EQ(segmentation::parsePreset(segmentation::presetName(p)), p);
  EXPECT_EQ(segmentation::presets().all().size(), segmentation::allPresets().size());
  // An older spelling still reads; the name written is the table's.
  EXPECT_EQ(segmentation::parsePreset("soft"), segmentation::Preset::SoftTissue);
  EXPECT_STREQ(segmentation::presetName(segmentation::Preset::SoftTissue), "soft-tissue");
  EXPECT_EQ(errorOf([] { segmentation::parsePreset("bogus"); }),
            "preset: 'bogus' is not one of bone, soft-tissue, skin-air, fat, lung, whole-bone");
  EXPECT_EQ(errorOf([] { render::parsePreset("bone-ish"); }),
            "render preset: 'bone-ish' is not one of bone, soft-tissue, skin, mip");
  // The parameter table's choices are the enum table's names.
  EXPECT_EQ(params::findField(deformation::deformParamsTable(), "method")->choices, deformation::mlsMethods().names);
  EXPECT_EQ(params::findField(render::renderSettingsTable(), "preset")->choices, render::presets().names);
  // One range per parameter: the MLS evaluator refuses what the table refuses, in its words.
  deformation::MlsParams low;
  low.power = 0.4;
  EXPECT_EQ(errorOf([&] { deformation::evaluateMls({{{0, 0, 0}, {1, 0, 0}, {}}}, low, {{0, 0, 0}}); }),
            "power = 0.4 is outside 0.5..8");
}

TEST(Params, GeneratedCliFlagsWriteTheStructAndCheckRanges) {
  {
    CLI::App app;
    deformation::DeformParams p;
    const auto options = cli::addFlags(app, p, deformation::deformParamsTable());
    parseArgs(app, {"--control-scale", "4", "--density-aware", "--phi", "mean", "--single-precision-grid=false",
                    "--power", "3.5"});
    EXPECT_EQ(p.controlScale, 4);
    EXPECT_TRUE(p.density.enabled);
    EXPECT_EQ(p.density.phi, deformation::PhiRule::Mean);
    EXPECT_FALSE(p.singlePrecisionGrid);
    EXPECT_EQ(p.mls.power, 3.5);
    EXPECT_EQ(p.density.iterations, deformation::DeformParams{}.density.iterations);  // not given: default
    EXPECT_EQ(options.at("power")->count(), 1u);
    EXPECT_EQ(options.at("iterations")->count(), 0u);
  }
  {
    CLI::App app;
    deformation::DeformParams p;
    cli::addFlags(app, p, deformation::deformParamsTable());
    // The CLI's errors name the flag typed, not the JSON key.
    EXPECT_EQ(errorOf([&] { parseArgs(app, {"--control-scale", "0"}); }), "--control-scale = 0 is outside 1..16");
    EXPECT_EQ(errorOf([&] { parseArgs(app, {"--control-scale", "two"}); }), "--control-scale: 'two' is not a number");
  }
  {
    CLI::App app;
    render::RenderSettings s;
    cli::addFlags(app, s, render::renderSettingsTable(), {"width", "height"});
    parseArgs(app, {"--azimuth", "-45", "--preset", "mip", "--shading=false"});
    EXPECT_EQ(s.camera.azimuthDeg, -45);
    EXPECT_EQ(s.preset, render::Preset::Mip);
    EXPECT_FALSE(s.shading);
    EXPECT_EQ(errorOf([&] { CLI::App a2; render::RenderSettings t; cli::addFlags(a2, t, render::renderSettingsTable());
                            parseArgs(a2, {"--elevation", "91"}); }),
              "--elevation = 91 is outside -90..90");
  }
}

TEST(Params, ABooleanFlagTakesItsValueAfterASpace) {
  CLI::App app;
  render::RenderSettings s;
  auto* sub = app.add_subcommand("render");
  std::string input;
  sub->add_option("input", input);
  cli::addFlags(*sub, s, render::renderSettingsTable(), {"width", "height"});
  const std::vector<std::string> joined =
      cli::joinBooleanFlagValues(app, {"render", "--shading", "false", "in.nrrd", "--azimuth", "0"});
  EXPECT_EQ(joined, (std::vector<std::string>{"render", "--shading=false", "in.nrrd", "--azimuth", "0"}));
  // A positional after a flag stays a positional; a number after a valued option is its value.
  EXPECT_EQ(cli::joinBooleanFlagValues(app, {"render", "--shading", "in.nrrd"}),
            (std::vector<std::string>{"render", "--shading", "in.nrrd"}));
  EXPECT_EQ(cli::joinBooleanFlagValues(app, {"render", "--azimuth", "1"}),
            (std::vector<std::string>{"render", "--azimuth", "1"}));
  std::vector<std::string> args = joined;
  std::reverse(args.begin(), args.end());
  app.parse(args);
  EXPECT_FALSE(s.shading);
  EXPECT_EQ(input, "in.nrrd");
}

// The list rows of ui/cli's tables: a repeatable value appends, a comma list splits and
// appends, a count row takes exactly its numbers, each number inside the row's range.
TEST(Params, ListRowsAppendRepeatsAndTakeTheirCountOfNumbers) {
  struct Lists {
    std::vector<std::string> names;
    std::vector<uint16_t> ids;
    std::vector<double> box;
  };
  static const cli::ListTable<Lists> table{
      cli::repeated<Lists>("name", &Lists::names, "TEXT", {"Name", "a name", ""}),
      cli::commaList<Lists>("ids", &Lists::ids, "ID,ID..", {"Ids", "some ids", "", 0, 100}),
      cli::numbers<Lists>("box", &Lists::box, 3, "X Y Z", {"Box", "a corner", "mm"}),
  };
  Lists l;
  {
    CLI::App app;
    cli::addLists(app, l, table);
    parseArgs(app, {"--name", "a", "--ids", "1,3", "--name", "b c", "--ids", "4", "--box", "1", "2.5", "3"});
  }
  EXPECT_EQ(l.names, (std::vector<std::string>{"a", "b c"}));
  EXPECT_EQ(l.ids, (std::vector<uint16_t>{1, 3, 4}));
  EXPECT_EQ(l.box, (std::vector<double>{1, 2.5, 3}));
  for (const std::vector<std::string>& bad : {std::vector<std::string>{"--ids", "1,101"}, {"--box", "1", "2"}}) {
    CLI::App app;
    Lists m;
    cli::addLists(app, m, table);
    EXPECT_THROW(parseArgs(app, bad), CLI::ParseError) << bad[0];
  }
  const std::string docs = cli::listMarkdownTable(table, l);
  EXPECT_NE(docs.find("| `ids` | 1,3,4 | comma list ID,ID.., each 0..100, repeatable |  | Ids: some ids |"),
            std::string::npos) << docs;
  EXPECT_NE(docs.find("| `box` | 1 2.5 3 | 3 numbers X Y Z | mm |"), std::string::npos) << docs;
}

TEST(Params, JsonRoundTripAndClearErrors) {
  deformation::DeformParams p;
  p.controlScale = 4;
  p.density.enabled = true;
  p.density.rays = deformation::RayMode::Linear;
  const nlohmann::json j = params::toJson(deformation::deformParamsTable(), p);
  EXPECT_EQ(j["control_scale"], 4);
  EXPECT_EQ(j["density_aware"], true);
  EXPECT_EQ(j["rays"], "linear");
  deformation::DeformParams q;
  params::fromJson(deformation::deformParamsTable(), j, q, "scene.json");
  EXPECT_EQ(params::toJson(deformation::deformParamsTable(), q), j);
  EXPECT_EQ(errorOf([&] { params::fromJson(deformation::deformParamsTable(), nlohmann::json{{"contrl_scale", 2}}, q, "s.json"); }),
            "s.json: unknown parameter 'contrl_scale'");
  EXPECT_EQ(errorOf([&] { params::fromJson(deformation::deformParamsTable(), nlohmann::json{{"power", "high"}}, q, "s.json"); }),
            "s.json: power: wrong type (string)");
  EXPECT_EQ(errorOf([&] { params::fromJson(deformation::deformParamsTable(), nlohmann::json{{"power", 99}}, q, "s.json"); }),
            "s.json: power = 99 is outside 0.5..8");
}

// docs/parameters.md is `vellum params --markdown`: regenerate it when a table changes.
TEST(Params, DocsPageMatchesTheTables) {
  std::ifstream in(std::string(VELLUM_DOCS_DIR) + "/parameters.md");
  ASSERT_TRUE(in) << "docs/parameters.md missing";
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), cli::parametersMarkdown())
      << "docs/parameters.md drifted: run `vellum params --markdown > docs/parameters.md`";
}

// The CLI's hysteresis defaults are the library's (they had drifted: 700/1100 vs 400/1000).
TEST(Params, SegmentHysteresisUsesTheLibraryDefaults) {
  const auto dir = test::tempDir("params-hysteresis");
  phantom::PhantomOptions o;
  o.dims = {24, 24, 24};
  io::saveVolume(phantom::makePhantom(o).ct, dir / "ct.nrrd");
  CLI::App app;
  cli::addSegmentCommand(app);
  parseArgs(app, {"segment", (dir / "ct.nrrd").string(), "--method", "hysteresis", "--out", (dir / "m.nrrd").string(),
                  "--report", (dir / "r.json").string()});
  const auto r = nlohmann::json::parse(std::ifstream(dir / "r.json"));
  const segmentation::HysteresisParams d;
  EXPECT_EQ(r["weak_hu"][0].get<double>(), d.weak.lower);
  EXPECT_EQ(r["strong_hu"][0].get<double>(), d.strong.lower);
}
