// `vellum pose`: joints and poses (issue 23 §3). A pose file names joints and their angles over
// keyframes; the control points are generated from the label map; the run is app::runPose.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "deform_cli.hpp"
#include "vellum/app/pose_pipeline.hpp"
#include "vellum/core/error.hpp"

namespace vellum::cli {

namespace {

struct PoseArgs {
  app::PoseRequest request;  ///< the flags write here
  std::string size = "512x512";
  InputOptions in;
};

/// `pose`'s own flags besides the request's tables, described once (docs/parameters.md).
const params::Table<PoseArgs>& poseFlagsTable() {
  using A = PoseArgs;
  static const params::Table<A> t{
      params::text<A>("size", &A::size, {"Size", "movie frame size WxH", "px"}),
      params::vector<A>("pan", params::nested(&A::request, &app::PoseRequest::movieSettings, &app::AnimateRequest::settings,
                                              &render::RenderSettings::camera, &render::Camera::panMm),
                        {"Pan", "shift of the movie's look-at point (x y z, or x,y,z; as `vellum animate --pan`)", "mm"}),
  };
  return t;
}

std::string mm(const nlohmann::json& v, const char* unit = " mm") {
  if (v.is_null()) return "not measured";
  std::ostringstream o;
  o.precision(3);
  o << v.get<double>() << unit;
  return o.str();
}

void printSummary(const app::PoseRequest& request, const app::PoseResult& r) {
  const nlohmann::json& rep = r.report;
  std::cout << "pose at " << rep["time_s"].get<double>() << " s: " << rep["points"]["total"].get<int>()
            << " generated points (" << rep["points"]["bones"].get<int>() << " on bones, "
            << rep["points"]["fixed"].get<int>() << " fixed, " << rep["points"]["anchors"].get<int>() << " anchors)\n";
  for (const auto& j : rep["joints"]) {
    std::cout << "  joint " << j["name"].get<std::string>() << ": requested " << j["requested_deg"].get<double>()
              << " deg";
    if (j.contains("achieved_deg"))
      std::cout << ", achieved " << mm(j["achieved_deg"], " deg") << "; child bone off its requested pose by "
                << mm(j["child_rotation_error_deg"], " deg") << ", " << mm(j["child_position_error_mm"]);
    std::cout << "\n";
    if (j.contains("axis_fit")) {  // an estimated axis: where it is and how well the surface fits
      const nlohmann::json& f = j["axis_fit"];
      const auto& a = j["axis_mm"];
      std::ostringstream line;
      line.setf(std::ios::fixed);
      line.precision(1);
      if (f.contains("motion")) {
        const nlohmann::json& m = f["motion"];
        line << "    axis placed by the motion search from the hint (score RMS " << std::setprecision(2)
             << m["score_rms_mm"]["hint"].get<double>() << " -> " << m["score_rms_mm"]["found"].get<double>()
             << " mm; near voxels turned into the parent " << std::setprecision(1)
             << 100 * m["inside_fraction"]["hint"].get<double>() << " -> " << 100 * m["inside_fraction"]["found"].get<double>()
             << " %; moved " << m["shift_mm"].get<double>() << " mm, turned " << m["turn_deg"].get<double>() << " deg";
      } else {
        line << "    axis estimated from bone " << f["partner"].get<int>() << "'s contact ("
             << (f["method"] == "contact" ? "NOT fitted: the contact zone's widest direction, a hint only"
                                          : f["method"].get<std::string>());
      }
      if (f.contains("surface") && !f.contains("motion"))
        line << (f["surface"] == "both" ? " on both bones' surfaces" : " on the " + f["surface"].get<std::string>() + "'s surface")
             << ", radius " << f["radius_mm"].get<double>()
             << " mm, RMS " << f["rms_mm"].get<double>() << " mm, " << 100 * f["inlier_fraction"].get<double>()
             << " % of " << f["surface_voxels"].get<int64_t>() << " voxels, confidence "
             << std::setprecision(2) << f["confidence"].get<double>() << std::setprecision(1);
      line << "): (" << a[0][0].get<double>() << ", " << a[0][1].get<double>() << ", " << a[0][2].get<double>()
           << ") -> (" << a[1][0].get<double>() << ", " << a[1][1].get<double>() << ", " << a[1][2].get<double>()
           << ") mm";
      std::cout << line.str() << "\n";
      if (!f["warning"].is_null())
        std::cerr << "warning: " << request.pose.string() << ": joint \"" << j["name"].get<std::string>()
                  << "\": " << f["warning"].get<std::string>() << "\n";
    }
  }
  for (const auto& c : rep["fixed_box_cuts"])
    std::cerr << "warning: " << request.pose.string() << ": fixed box " << c["box"].get<size_t>() + 1 << " holds "
              << c["voxels"].get<int64_t>() << " voxels of bone " << c["id"].get<int>()
              << (c["name"].get<std::string>().empty() ? "" : " (" + c["name"].get<std::string>() + ")")
              << " that a joint turns: they stay put, so the bone is cut at the box's face and its rim there gives"
                 " (move the box off the bone)\n";
  if (rep.contains("deform")) {
    const nlohmann::json& after = rep["deform"]["rigidity"]["after"];
    std::cout << request.output.string() << ": bone RMS residual " << mm(after["bone_rms_residual_mm"])
              << " (max " << mm(after["bone_max_residual_mm"]) << ")";
    if (!after["fixed"].is_null())
      std::cout << ", fixed regions moved max " << mm(after["fixed"]["max_displacement_mm"]);
    if (!after["fold_fraction"].is_null())
      std::cout << ", folds in tissue " << 100.0 * after["fold_fraction"].get<double>() << " %"
                << (after["fold_fraction"].get<double>() > 0 ? " (" + worstJacobianText(after) + ")" : std::string());
    std::cout << " (" << rep["map"].get<std::string>() << " map)\n";
    if (rep["deform"].contains("twist"))  // the twist map's collisions: still and moving bones too close in arc
      for (const auto& t : rep["deform"]["twist"]["joints"]) {
        if (const int64_t soft = t.value("softened_bone_voxels", int64_t{0}); soft > 0)
          std::cout << "  joint " << t["name"].get<std::string>() << ": " << soft
                    << " bone rim voxels gave where a still and a turning bone touch along the turn (not rigid there)\n";
        if (t["collision_voxels"].get<int64_t>() > 0)
          std::cerr << "warning: " << request.pose.string() << ": joint \"" << t["name"].get<std::string>() << "\": "
                    << t["collision_voxels"].get<int64_t>()
                    << " voxels where a still and a turning bone meet within the angle's arc (det J <= 0 there)\n";
      }
  }
  if (rep.contains("movie")) {
    const nlohmann::json& grid = rep["movie"]["box"]["grid"];
    std::cout << request.movie.string() << ": " << rep["movie"]["frames"].get<int>() << " frames from "
              << rep["movie_keyframes"].get<size_t>() << " generated keyframes, on a " << grid["dims"][0] << " x "
              << grid["dims"][1] << " x " << grid["dims"][2] << " grid (--pad-mm " << request.padMm << ")\n";
  }
  std::cout << "total " << rep["timings_ms"]["total"].get<double>() / 1000.0 << " s\n";
}

}  // namespace

std::string poseFlagsMarkdown() { return params::markdown(poseFlagsTable()); }

void addPoseCommand(CLI::App& app) {
  auto a = std::make_shared<PoseArgs>();
  app::PoseRequest& r = a->request;
  auto* cmd = app.add_subcommand(
      "pose", "Pose bones at joints (pose file: joints, angles over keyframes, fixed regions; points generated)");
  addInput(*cmd, "input", r.input, "volume file or DICOM folder")->required();
  addInput(*cmd, "--labels", r.labels, "label map on the volume's grid: the bones' ids (one id = one rigid body)")
      ->required();
  addInput(*cmd, "--pose", r.pose, "pose file (JSON; see docs/deformation.md, \"Pose file\")")->required();
  addOutput(*cmd, "--out,-o", r.output, "the deformed volume at the pose (--frame-time; default the last keyframe)");
  addOutput(*cmd, "--movie", r.movie, "a movie over all keyframes: movie.mp4, or a folder (ending in /) for PNG frames");
  addOutput(*cmd, "--report", r.report, "JSON report: per joint the achieved angle, per bone RMS/max, fixed regions, folds");
  addOutput(*cmd, "--points-out", r.pointsOut, "write the generated control points at the pose (vellum deform --points)");
  addOutput(*cmd, "--keyframes-out", r.keyframesOut,
                  "write the generated keyframe track (vellum animate --keyframes)");
  addFlags(*cmd, r, app::poseRequestTable());
  addFlags(*cmd, r.options, deformation::poseOptionsTable());
  addOutput(*cmd, "--gltf", r.gltf,
                  "the posed bones (rigid nodes) and skin (morph targets) as an animated glTF 2.0 file (.glb) over the "
                  "keyframes, for slides, web and AR viewers");
  addFlags(*cmd, r.gltfOptions, app::poseGltfOptionsTable());
  addFlags(*cmd, r.engine.params, deformation::deformParamsTable());
  addFlags(*cmd, r.engine, app::deformEngineTable(), {"labels"});
  addFlags(*cmd, *a, poseFlagsTable());  // --size, --pan
  addFlags(*cmd, r.movieSettings.settings, render::renderSettingsTable(), {"width", "height"});
  // --fps, --camera-orbit, titles; the movie's --pad-mm is the request's (one flag for --out and --movie)
  addFlags(*cmd, r.movieSettings, app::animateRequestTable(), {"loop", "pad_mm"});
  addForceFlag(*cmd, r.force);
  a->in.addTo(*cmd);
  cmd->footer("Example: vellum pose feet.nrrd --labels bones.nrrd --pose flex.json --out flexed.nrrd "
              "--report flexed.json --movie flex.mp4 --preset bone");
  cmd->callback([a] {
    app::PoseRequest request = a->request;
    std::tie(request.movieSettings.settings.width, request.movieSettings.settings.height) = parseSize(a->size);
    setVolumeInput(request, a->in);
    // A bad pose file, label map or request: one line, exit 2 (main.cpp).
    printSummary(request, runPipeline(request, app::runPose));
  });
}

}  // namespace vellum::cli
