// Reading a run's main input and writing a label map output (run_io.hpp).
#include "vellum/app/run_io.hpp"

namespace vellum::app {

io::LoadedVolume loadInput(RunReport& run, const std::filesystem::path& path, io::LoadOptions load, Progress& progress) {
  load.progress = &progress;
  io::LoadedVolume lv = io::loadVolume(path, load);
  run.loaded(path, lv);
  run.mark("load");
  return lv;
}

void saveLabelsOutput(RunOutputs& outputs, const LabelVolume& labels, const std::filesystem::path& path, bool force) {
  ensureParentFolder(path);
  io::SaveOptions so;
  so.force = force;
  io::saveLabels(labels, path, so);
  outputs.wrote(path);
}

}  // namespace vellum::app
