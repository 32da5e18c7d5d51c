// `vellum segment` — placeholder until issue 4 lands.
#include "commands.hpp"

namespace vellum::cli {
void addSegmentCommand(CLI::App&) {}
void demoSegmentation(const DemoContext&) {}
}  // namespace vellum::cli
