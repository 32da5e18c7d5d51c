#include "shape_job.hpp"

#include <set>

#include "loader.hpp"
#include "vellum/core/error.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::studio {

std::vector<illustration::Segment> segmentsFromLabels(const LabelVolume& labels) {
  const auto histogram = labels.histogram();
  std::vector<illustration::Segment> segments;
  std::set<std::string> names;
  for (const Label& l : labels.table()) {
    if (l.id >= histogram.size() || histogram[l.id] == 0) continue;
    std::string name = l.name.empty() ? "label " + std::to_string(l.id) : l.name;
    while (!names.insert(name).second) name += " " + std::to_string(l.id);
    segments.push_back({name, {l.id}, l.rgb});
  }
  if (segments.empty()) throw Error("the label map has no labelled voxels to make shapes from");
  if (segments.size() > 255) throw Error("more than 255 labels: the illustration draws at most 255 segments");
  return segments;
}

ShapeJobResult makeShapes(const ShapeRequest& request, Progress& progress) {
  ShapeJobResult o;
  o.volumeGeneration = request.volumeGeneration;
  o.folder = request.folder;
  if (!request.folder.empty()) {
    o.shapes = std::make_shared<const illustration::ShapeScene>(loadShapes(request.folder, request.ct));
    o.meshes = std::make_shared<const SegmentMeshes>(loadSegmentMeshes(request.folder, o.shapes->segments));
    return o;
  }
  const illustration::ShapeResult r = illustration::runShapePipeline(
      request.labels, segmentsFromLabels(request.labels), {}, {}, illustration::ShapeOptions{}, progress);
  auto scene = std::make_shared<illustration::ShapeScene>();
  scene->distance = r.distance;
  scene->distance.setGeometry(request.ct.geometry());
  scene->segments = r.segmentation;
  scene->fields = r.fields;
  for (auto& f : scene->fields) f.distance.setGeometry(request.ct.geometry());
  scene->ct = AnyVolume(request.ct);
  o.shapes = std::move(scene);
  o.meshes = std::make_shared<const SegmentMeshes>(segmentMeshesOf(r.shapes));
  return o;
}

bool ShapeJob::start(ShapeRequest request) {
  std::string stage = request.folder.empty() ? "making shapes" : "reading shapes";
  return job_.start([request = std::move(request)](Progress& p) { return makeShapes(request, p); }, std::move(stage));
}

}  // namespace vellum::studio
