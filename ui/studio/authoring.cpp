#include "authoring.hpp"

#include <algorithm>
#include <cctype>

#include "vellum/core/error.hpp"

namespace vellum::studio {
using deformation::DeformParams;

DeformParams studioDeformParams() {
  // The interactive setting: s = 4 with density-aware weights (tissue-aware motion).
  // The export's `vellum animate` command passes these explicitly, so the frames still match.
  DeformParams p;
  p.controlScale = 4;
  p.density.enabled = true;
  return p;
}

using deformation::ControlPoint;
using deformation::ControlPoints;

ControlPoints Authoring::currentPoints() const {
  if (!active()) return {};
  if (timeS) return track.at(*timeS);
  return track.keyframes[static_cast<size_t>(std::clamp(keyframe, 0, int(track.keyframes.size()) - 1))].points;
}

ControlPoints& Authoring::editablePoints() {
  if (!active()) throw Error("no control points: place them first");
  keyframe = std::clamp(keyframe, 0, int(track.keyframes.size()) - 1);
  return track.keyframes[static_cast<size_t>(keyframe)].points;
}

double keyframeStartS(const deformation::KeyframeTrack& t, int k) {
  double s = 0;
  for (int i = 0; i < k && i < int(t.keyframes.size()); ++i) s += t.keyframes[size_t(i)].durationS;
  return s;
}

void placePoints(Authoring& a, ControlPoints points) {
  a.track.keyframes = {deformation::Keyframe{1.0, std::move(points)}};
  a.keyframe = 0;
  a.selected = -1;
  a.timeS.reset();
  a.playing = false;
  a.touch();
}

void addKeyframe(Authoring& a) {
  if (!a.active()) throw Error("no keyframe to copy: place control points first");
  const ControlPoints copy = a.currentPoints();  // while scrubbing: the in-between pose
  const double duration = a.track.keyframes[static_cast<size_t>(a.keyframe)].durationS;
  a.track.keyframes.insert(a.track.keyframes.begin() + a.keyframe + 1, deformation::Keyframe{duration, copy});
  ++a.keyframe;
  a.timeS.reset();
  a.touch();
}

void deleteKeyframe(Authoring& a, int index) {
  if (index < 0 || index >= int(a.track.keyframes.size())) throw Error("no keyframe " + std::to_string(index));
  a.track.keyframes.erase(a.track.keyframes.begin() + index);
  a.keyframe = std::clamp(a.keyframe, 0, std::max(0, int(a.track.keyframes.size()) - 1));
  a.timeS.reset();
  a.touch();
}

void moveKeyframe(Authoring& a, int index, int offset) {
  const int n = int(a.track.keyframes.size());
  if (index < 0 || index >= n) throw Error("no keyframe " + std::to_string(index));
  const int to = index + offset;
  if (to < 0 || to >= n) throw Error("keyframe " + std::to_string(index) + " cannot move " +
                                     (offset < 0 ? "earlier" : "later"));
  moveKeyframeTo(a, index, to);
}

void moveKeyframeTo(Authoring& a, int from, int to) {
  const int n = int(a.track.keyframes.size());
  if (from < 0 || from >= n) throw Error("no keyframe " + std::to_string(from));
  if (to < 0 || to >= n) throw Error("no place " + std::to_string(to) + " for keyframe " + std::to_string(from));
  // The poses move; each place keeps its duration, so the timing of the movie stays as it was.
  auto& k = a.track.keyframes;
  for (int i = from; i < to; ++i) std::swap(k[size_t(i)].points, k[size_t(i + 1)].points);
  for (int i = from; i > to; --i) std::swap(k[size_t(i)].points, k[size_t(i - 1)].points);
  a.keyframe = to;
  a.timeS.reset();
  a.touch();
}

deformation::KeyframeCamera keyframeCameraOf(const render::Camera& c) {
  return {c.azimuthDeg, c.elevationDeg, c.zoom, c.panMm, c.fieldOfViewDeg};
}

void addPoint(Authoring& a, const Vec3& mm) {
  if (!a.active()) a.track.keyframes = {deformation::Keyframe{1.0, {}, {}, {}}};
  for (auto& k : a.track.keyframes) k.points.push_back(ControlPoint{mm, mm, {}});
  a.selected = int(a.track.keyframes.front().points.size()) - 1;
  a.touch();
}

void deletePoint(Authoring& a, int index) {
  if (!a.active() || index < 0 || index >= int(a.track.keyframes.front().points.size()))
    throw Error("no control point " + std::to_string(index));
  for (auto& k : a.track.keyframes) k.points.erase(k.points.begin() + index);
  a.selected = -1;
  a.touch();
}

std::vector<uint16_t> boneLikeLabels(const LabelVolume& labels) {
  static const char* kWords[] = {"bone", "femur", "tibia", "fibula", "patella", "cortical", "cancellous",
                                 "skull", "vertebra", "rib", "pelvis", "humerus"};
  std::vector<uint16_t> ids;
  for (const Label& l : labels.table()) {
    std::string n = l.name;
    std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    for (const char* w : kWords)
      if (n.find(w) != std::string::npos) {
        ids.push_back(l.id);
        break;
      }
  }
  return ids;
}

bool samePoints(const deformation::KeyframeTrack& a, const deformation::KeyframeTrack& b) {
  return a.keyframes.size() == b.keyframes.size() &&
         std::equal(a.keyframes.begin(), a.keyframes.end(), b.keyframes.begin(),
                    [](const auto& x, const auto& y) { return x.points == y.points; });
}

bool sameJoints(const deformation::Pose& a, const deformation::Pose& b) {
  if (a.joints.size() != b.joints.size() || a.fixed.ids != b.fixed.ids || a.fixed.boxesMm != b.fixed.boxesMm) return false;
  for (size_t j = 0; j < a.joints.size(); ++j) {
    const deformation::Joint &x = a.joints[j], &y = b.joints[j];
    if (x.name != y.name || x.parent != y.parent || x.child != y.child || x.estimateAxis != y.estimateAxis) return false;
    if (!x.estimateAxis && (x.axisA != y.axisA || x.axisB != y.axisB)) return false;
    if (x.hasAxisHint != y.hasAxisHint) return false;
    if (x.hasAxisHint && (x.hintA != y.hintA || x.hintB != y.hintB || x.hintConeDeg != y.hintConeDeg)) return false;
  }
  return true;
}

bool samePose(const deformation::Pose& a, const deformation::Pose& b) {
  const deformation::KeyframeTrack &s = a.angles, &t = b.angles;
  if (!sameJoints(a, b) || s.interpolation != t.interpolation || s.loop != t.loop ||
      s.keyframes.size() != t.keyframes.size() || !samePoints(s, t))
    return false;
  for (size_t k = 0; k < s.keyframes.size(); ++k)
    if (s.keyframes[k].durationS != t.keyframes[k].durationS) return false;
  return true;
}

}  // namespace vellum::studio
