#pragma once
// Keyframed deformation animation ([HVD 1.5] in docs/references.md). A keyframe holds the full control-point
// set; playback interpolates every point (source, target and attributes) between keyframes.
#include <string>
#include <vector>

#include "vellum/deformation/control_point.hpp"

namespace vellum::deformation {

enum class Interpolation {
  Linear,  ///< paper
  Smooth,  ///< Catmull-Rom through the keyframes (C1)
  Eased,   ///< linear path, smoothstep timing (stops at each keyframe)
};
const char* interpolationName(Interpolation i);
Interpolation parseInterpolation(const std::string& name);  ///< "linear", "smooth", "eased"

/// Sanity limits (a keyframe file asking for more is refused, naming the field).
constexpr double kMaxKeyframeDurationS = 3600;  ///< one hour per keyframe
constexpr size_t kMaxKeyframes = 10000;
constexpr int kMaxFrames = 1000000;             ///< frames of one track at its fps

struct Keyframe {
  /// Seconds spent travelling from this keyframe to the next. For the last keyframe: a hold
  /// at the end, or (loop) the travel back to the first keyframe.
  double durationS = 1.0;
  ControlPoints points;
};

struct KeyframeTrack {
  Interpolation interpolation = Interpolation::Linear;
  /// Seamless loop: the last keyframe travels back to the first and frame times never reach
  /// the total duration, so the movie can repeat without a duplicated frame (turntables).
  bool loop = false;
  std::vector<Keyframe> keyframes;

  /// Throws vellum::Error when empty, a duration is negative, NaN or over
  /// kMaxKeyframeDurationS, or point counts differ.
  void validate() const;
  double totalDurationS() const;
  /// The interpolated control points at time t (s), clamped to [0, total].
  ControlPoints at(double timeS) const;
  /// Frames at `fps`: loop -> round(total*fps) frames at f/fps; otherwise one more (the end).
  /// Throws vellum::Error over kMaxFrames.
  int frameCount(double fps) const;
  double frameTimeS(int frame, double fps) const;
};

}  // namespace vellum::deformation
