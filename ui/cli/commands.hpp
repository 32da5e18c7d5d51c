#pragma once
// Subcommands of the `vellum` command line. Each lives in its own cmd_<name>.cpp and adds
// itself to the app here; main.cpp only wires them up and turns exceptions into one-line
// errors with a non-zero exit code.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>

namespace vellum::cli {

void addInfoCommand(CLI::App& app);
void addPhantomCommand(CLI::App& app);
void addConvertCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addDemoCommand(CLI::App& app);
void addSegmentCommand(CLI::App& app);    // issue 4
void addDeformCommand(CLI::App& app);     // issue 3
void addControlsCommand(CLI::App& app);   // issue 3
void addAnimateCommand(CLI::App& app);    // issue 3
void addShapeCommand(CLI::App& app);      // issue 8
void addIllustrateCommand(CLI::App& app); // issue 8
void addCurveAnalogyCommand(CLI::App& app);  // issue 9
void addLabelsCommand(CLI::App& app);       // issue 23: ids of bones
void addParamsCommand(CLI::App& app);
void addCompareCommand(CLI::App& app);  // issue 25
void addQaCommand(CLI::App& app);       // issue 25
void addPoseCommand(CLI::App& app);     // issue 23: joints and poses
void addSliceCommand(CLI::App& app);    // slices as pictures (QA, docs figures)

/// docs/parameters.md: every parameter table as Markdown (cmd_params.cpp).
std::string parametersMarkdown();
/// The commands' own flag tables as Markdown (each in its cmd_<name>.cpp).
std::string phantomFlagsMarkdown();
std::string demoFlagsMarkdown();
std::string convertFlagsMarkdown();
std::string qaFlagsMarkdown();
std::string curveAnalogyFlagsMarkdown();
std::string segmentLabelFlagsMarkdown();
std::string renderFlagsMarkdown();
std::string illustrateFlagsMarkdown();
std::string animateFlagsMarkdown();
std::string poseFlagsMarkdown();
std::string compareFlagsMarkdown();
std::string labelsFlagsMarkdown();
std::string shapeFlagsMarkdown();
std::string controlsFlagsMarkdown();
std::string infoFlagsMarkdown();
std::string deformListsMarkdown();
std::string sliceFlagsMarkdown();

/// What `vellum demo` hands to the parts that later issues add to it.
struct DemoContext {
  std::filesystem::path outDir;      ///< the demo's output folder (exists)
  std::filesystem::path phantomCt;   ///< the phantom CT it wrote (NRRD)
  std::filesystem::path phantomLabels;  ///< its ground-truth label map (NRRD)
  int size = 128;                    ///< phantom voxels per axis
};
/// Segmentation part of the demo (defined in cmd_segment.cpp).
void demoSegmentation(const DemoContext& ctx);
/// Deformation/animation part of the demo (defined in cmd_animate.cpp).
void demoDeformation(const DemoContext& ctx);
/// Shape folder of the phantom's skin, muscle and bones (defined in cmd_shape.cpp).
void demoShape(const DemoContext& ctx, const std::filesystem::path& dir);
/// Shape-aware illustration part of the demo: the shape folder, a plate in the paper's manner
/// and a labelled textbook figure (defined in cmd_illustrate.cpp).
void demoIllustration(const DemoContext& ctx);
/// Curve-analogy part of the demo (defined in cmd_curve_analogy.cpp).
void demoCurveAnalogy(const DemoContext& ctx);

}  // namespace vellum::cli
