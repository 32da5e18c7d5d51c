#include "vellum/deformation/keyframes.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/error.hpp"

namespace vellum::deformation {

const char* interpolationName(Interpolation i) {
  switch (i) {
    case Interpolation::Linear: return "linear";
    case Interpolation::Smooth: return "smooth";
    case Interpolation::Eased: return "eased";
  }
  return "?";
}

Interpolation parseInterpolation(const std::string& name) {
  if (name == "linear") return Interpolation::Linear;
  if (name == "smooth") return Interpolation::Smooth;
  if (name == "eased") return Interpolation::Eased;
  throw Error("unknown interpolation '" + name + "' (linear, smooth, eased)");
}

void KeyframeTrack::validate() const {
  if (keyframes.empty()) throw Error("keyframe track has no keyframes");
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const auto& kf = keyframes[k];
    if (!(kf.durationS >= 0 && kf.durationS <= kMaxKeyframeDurationS))
      throw Error("keyframe " + std::to_string(k) + ": \"duration\" " + std::to_string(kf.durationS) +
                  " s is outside 0.." + std::to_string(int(kMaxKeyframeDurationS)) + " s");
    if (kf.points.empty()) throw Error("keyframe " + std::to_string(k) + " has no points");
    if (kf.points.size() != keyframes[0].points.size())
      throw Error("keyframe " + std::to_string(k) + " has " + std::to_string(kf.points.size()) +
                  " points; keyframe 0 has " + std::to_string(keyframes[0].points.size()) +
                  " (the point count must be the same in every keyframe)");
  }
}

double KeyframeTrack::totalDurationS() const {
  double t = 0;
  for (const auto& kf : keyframes) t += kf.durationS;
  return t;
}

namespace {

Vec3 catmullRom(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, double s) {
  const double s2 = s * s, s3 = s2 * s;
  return (p1 * 2.0 + (p2 - p0) * s + (p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3) * s2 +
          (p1 * 3.0 - p0 - p2 * 3.0 + p3) * s3) * 0.5;
}
double catmullRom(double p0, double p1, double p2, double p3, double s) {
  return catmullRom(Vec3{p0, 0, 0}, Vec3{p1, 0, 0}, Vec3{p2, 0, 0}, Vec3{p3, 0, 0}, s).x;
}

}  // namespace

ControlPoints KeyframeTrack::at(double timeS) const {
  validate();
  const int n = static_cast<int>(keyframes.size());
  if (n == 1) return keyframes[0].points;
  double t = std::clamp(std::isfinite(timeS) ? timeS : 0.0, 0.0, totalDurationS());
  int k = 0;
  while (k < n - 1 && t >= keyframes[static_cast<size_t>(k)].durationS) {
    t -= keyframes[static_cast<size_t>(k)].durationS;
    ++k;
  }
  const int last = n - 1;
  if (k == last && !loop) return keyframes[static_cast<size_t>(last)].points;  // end hold
  const double dur = keyframes[static_cast<size_t>(k)].durationS;
  double s = dur > 0 ? std::clamp(t / dur, 0.0, 1.0) : 1.0;
  auto index = [&](int i) {
    if (loop) return ((i % n) + n) % n;
    return std::clamp(i, 0, last);
  };
  const auto& a = keyframes[static_cast<size_t>(index(k))].points;
  const auto& b = keyframes[static_cast<size_t>(index(k + 1))].points;
  if (interpolation == Interpolation::Eased) s = s * s * (3 - 2 * s);
  ControlPoints out(a.size());
  if (interpolation != Interpolation::Smooth) {
    for (size_t i = 0; i < a.size(); ++i) {
      out[i].source = a[i].source + (b[i].source - a[i].source) * s;
      out[i].target = a[i].target + (b[i].target - a[i].target) * s;
      const auto va = a[i].attributes.values(), vb = b[i].attributes.values();
      std::array<double, 4> v{};
      for (size_t c = 0; c < 4; ++c) v[c] = va[c] + (vb[c] - va[c]) * s;
      out[i].attributes = {v[0], v[1], v[2], v[3]};
    }
    return out;
  }
  const auto& p = keyframes[static_cast<size_t>(index(k - 1))].points;
  const auto& q = keyframes[static_cast<size_t>(index(k + 2))].points;
  for (size_t i = 0; i < a.size(); ++i) {
    out[i].source = catmullRom(p[i].source, a[i].source, b[i].source, q[i].source, s);
    out[i].target = catmullRom(p[i].target, a[i].target, b[i].target, q[i].target, s);
    const auto vp = p[i].attributes.values(), va = a[i].attributes.values(),
               vb = b[i].attributes.values(), vq = q[i].attributes.values();
    std::array<double, 4> v{};
    for (size_t c = 0; c < 4; ++c) v[c] = catmullRom(vp[c], va[c], vb[c], vq[c], s);
    out[i].attributes = {v[0], v[1], v[2], v[3]};
  }
  return out;
}

int KeyframeTrack::frameCount(double fps) const {
  if (!(fps > 0) || !std::isfinite(fps)) throw Error("frames per second must be > 0");
  const double frames = totalDurationS() * fps;
  if (!(frames <= kMaxFrames))  // also NaN
    throw Error("the track lasts " + std::to_string(totalDurationS()) + " s: " + std::to_string(frames) +
                " frames at " + std::to_string(fps) + " fps is over the limit of " + std::to_string(kMaxFrames));
  const int n = static_cast<int>(std::lround(frames));
  return loop ? std::max(n, 1) : n + 1;
}

double KeyframeTrack::frameTimeS(int frame, double fps) const {
  return std::min(static_cast<double>(frame) / fps, totalDurationS());
}

}  // namespace vellum::deformation
