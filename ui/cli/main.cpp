// `vellum`: the headless command line of the Vellum volume workstation.
#include <CLI/CLI.hpp>

#include <iostream>

#include "commands.hpp"
#include "vellum/core/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Vellum: CT volume loading, segmentation, deformation and rendering", "vellum"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "vellum 0.1.0");
  using namespace vellum::cli;
  addInfoCommand(app);
  addPhantomCommand(app);
  addConvertCommand(app);
  addRenderCommand(app);
  addSegmentCommand(app);
  addDeformCommand(app);
  addControlsCommand(app);
  addAnimateCommand(app);
  addDemoCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const vellum::Cancelled&) {
    std::cerr << "vellum: cancelled\n";
    return 130;
  } catch (const std::exception& e) {
    std::cerr << "vellum: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
