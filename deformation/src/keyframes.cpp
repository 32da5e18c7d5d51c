#include "vellum/deformation/keyframes.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/error.hpp"

namespace vellum::deformation {

const params::EnumTable<Interpolation>& interpolations() {
  static const params::EnumTable<Interpolation> t{"interpolation", {"linear", "smooth", "eased"}};
  return t;
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

// The field of view is held on its own: cameras without one take the previous camera's that
// has one (leading ones the first such); when no camera has one, none gets one.
void holdFieldOfView(std::vector<KeyframeCamera>& cams) {
  std::optional<double> held;
  for (const auto& c : cams)
    if (c.fieldOfViewDeg) {
      held = c.fieldOfViewDeg;
      break;
    }
  if (!held) return;
  for (auto& c : cams) {
    if (c.fieldOfViewDeg) held = c.fieldOfViewDeg;
    c.fieldOfViewDeg = held;
  }
}

}  // namespace

std::string KeyframeTrack::captionAt(double timeS) const {
  if (keyframes.empty()) return {};
  const int from = segmentAt(timeS).a;
  for (int k = from; k >= 0; --k)
    if (!keyframes[static_cast<size_t>(k)].caption.empty()) return keyframes[static_cast<size_t>(k)].caption;
  return {};
}

KeyframeTrack::Segment KeyframeTrack::segmentAt(double timeS) const {
  const int n = static_cast<int>(keyframes.size());
  Segment g;
  if (n == 1) {
    g.hold = true;
    return g;
  }
  double t = std::clamp(std::isfinite(timeS) ? timeS : 0.0, 0.0, totalDurationS());
  int k = 0;
  while (k < n - 1 && t >= keyframes[static_cast<size_t>(k)].durationS) {
    t -= keyframes[static_cast<size_t>(k)].durationS;
    ++k;
  }
  const int last = n - 1;
  if (k == last && !loop) {  // end hold
    g.p = g.a = g.b = g.q = last;
    g.hold = true;
    return g;
  }
  const double dur = keyframes[static_cast<size_t>(k)].durationS;
  g.s = dur > 0 ? std::clamp(t / dur, 0.0, 1.0) : 1.0;
  if (interpolation == Interpolation::Eased) g.s = g.s * g.s * (3 - 2 * g.s);
  auto index = [&](int i) { return loop ? ((i % n) + n) % n : std::clamp(i, 0, last); };
  g.p = index(k - 1);
  g.a = index(k);
  g.b = index(k + 1);
  g.q = index(k + 2);
  return g;
}

ControlPoints KeyframeTrack::at(double timeS) const {
  validate();
  const Segment g = segmentAt(timeS);
  if (g.hold) return keyframes[static_cast<size_t>(g.a)].points;
  const double s = g.s;
  const auto& a = keyframes[static_cast<size_t>(g.a)].points;
  const auto& b = keyframes[static_cast<size_t>(g.b)].points;
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
  const auto& p = keyframes[static_cast<size_t>(g.p)].points;
  const auto& q = keyframes[static_cast<size_t>(g.q)].points;
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

std::optional<KeyframeCamera> KeyframeTrack::cameraAt(double timeS) const {
  validate();
  // Keyframes without a camera hold the previous one's (leading ones the first camera's).
  std::vector<KeyframeCamera> cams(keyframes.size());
  std::optional<KeyframeCamera> held;
  for (const auto& k : keyframes)
    if (k.camera) {
      held = k.camera;
      break;
    }
  if (!held) return std::nullopt;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    if (keyframes[i].camera) held = keyframes[i].camera;
    cams[i] = *held;
  }
  holdFieldOfView(cams);
  const Segment g = segmentAt(timeS);
  if (g.hold) return cams[static_cast<size_t>(g.a)];
  const auto &p = cams[size_t(g.p)], &a = cams[size_t(g.a)], &b = cams[size_t(g.b)], &q = cams[size_t(g.q)];
  const auto blend = [&](double vp, double va, double vb, double vq) {
    return interpolation == Interpolation::Smooth ? catmullRom(vp, va, vb, vq, g.s) : va + (vb - va) * g.s;
  };
  KeyframeCamera c;
  c.azimuthDeg = blend(p.azimuthDeg, a.azimuthDeg, b.azimuthDeg, q.azimuthDeg);
  c.elevationDeg = std::clamp(blend(p.elevationDeg, a.elevationDeg, b.elevationDeg, q.elevationDeg), -90.0, 90.0);
  c.zoom = std::max(0.05, blend(p.zoom, a.zoom, b.zoom, q.zoom));
  c.panMm = interpolation == Interpolation::Smooth ? catmullRom(p.panMm, a.panMm, b.panMm, q.panMm, g.s)
                                                   : a.panMm + (b.panMm - a.panMm) * g.s;
  if (a.fieldOfViewDeg)  // holdFieldOfView() set it on every camera or on none
    c.fieldOfViewDeg = std::clamp(blend(*p.fieldOfViewDeg, *a.fieldOfViewDeg, *b.fieldOfViewDeg, *q.fieldOfViewDeg),
                                  0.0, kMaxKeyframeFieldOfViewDeg);
  return c;
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
