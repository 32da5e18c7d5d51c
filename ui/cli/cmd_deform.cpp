// `vellum deform`, `vellum controls`, `vellum animate` — placeholders until issue 3 lands.
#include "commands.hpp"

namespace vellum::cli {
void addDeformCommand(CLI::App&) {}
void addControlsCommand(CLI::App&) {}
void addAnimateCommand(CLI::App&) {}
void demoDeformation(const DemoContext&) {}
}  // namespace vellum::cli
