#pragma once
// Keyframed deformation animation ([HVD 1.5] in docs/references.md). A keyframe holds the full control-point
// set; playback interpolates every point (source, target and attributes) between keyframes.
#include <optional>
#include <string>
#include <vector>

#include "vellum/core/enum_table.hpp"
#include "vellum/deformation/control_point.hpp"

namespace vellum::deformation {

enum class Interpolation {
  Linear,  ///< paper
  Smooth,  ///< Catmull-Rom through the keyframes (C1)
  Eased,   ///< linear path, smoothstep timing (stops at each keyframe)
};
const params::EnumTable<Interpolation>& interpolations();  ///< "linear", "smooth", "eased"
inline const char* interpolationName(Interpolation i) { return interpolations().name(i); }
inline Interpolation parseInterpolation(const std::string& name) { return interpolations().parse(name); }

/// Sanity limits (a keyframe file asking for more is refused, naming the field).
constexpr double kMaxKeyframeDurationS = 3600;  ///< one hour per keyframe
constexpr size_t kMaxKeyframes = 10000;
constexpr int kMaxFrames = 1000000;             ///< frames of one track at its fps
constexpr double kMaxKeyframeFieldOfViewDeg = 120;  ///< as `vellum render --fov`

/// A keyframed camera (the renderer's orbit camera: turn about the superior axis, tilt
/// towards superior, zoom, pan in mm, vertical field of view), for turntables, fly-arounds and
/// dolly-zooms in movies. Azimuths are not wrapped: 0 then 360 is a whole turn.
struct KeyframeCamera {
  double azimuthDeg = 30, elevationDeg = 15, zoom = 1;
  Vec3 panMm{0, 0, 0};
  /// Vertical field of view in degrees, 0 = orthographic (render::Camera::fieldOfViewDeg).
  /// None: held from the previous keyframe that has one; none anywhere: the render settings'.
  /// Blending towards 0 approaches the orthographic view continuously (the perspective camera
  /// backs away so the volume keeps its size), so a perspective <-> orthographic change glides.
  std::optional<double> fieldOfViewDeg;
  bool operator==(const KeyframeCamera&) const = default;
};

struct Keyframe {
  /// Seconds spent travelling from this keyframe to the next. For the last keyframe: a hold
  /// at the end, or (loop) the travel back to the first keyframe.
  double durationS = 1.0;
  ControlPoints points;
  /// The camera at this keyframe; none: the previous keyframe's (the first: the next one's).
  std::optional<KeyframeCamera> camera;
  /// Text a movie shows from this keyframe until the next one ("Flexion 20°"); empty: the
  /// previous keyframe's caption (the first: none). At most kMaxCaptionLength bytes.
  std::string caption;
};
inline constexpr size_t kMaxCaptionLength = 200;

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
  /// The camera at time t, interpolated like the points; nullopt when no keyframe has one.
  /// Its field of view is set when some keyframe's camera has one.
  std::optional<KeyframeCamera> cameraAt(double timeS) const;
  /// The caption shown at time t: that of the keyframe the segment starts from, held
  /// forward over keyframes without one; empty when none has one so far.
  std::string captionAt(double timeS) const;
  /// Frames at `fps`: loop -> round(total*fps) frames at f/fps; otherwise one more (the end).
  /// Throws vellum::Error over kMaxFrames.
  int frameCount(double fps) const;
  double frameTimeS(int frame, double fps) const;

 private:
  /// Where time t falls: keyframes p, a, b, q around the segment a -> b and the fraction s
  /// (eased already); hold = the end hold of a non-looping track (a == b).
  struct Segment {
    int p = 0, a = 0, b = 0, q = 0;
    double s = 0;
    bool hold = false;
  };
  Segment segmentAt(double timeS) const;
};

}  // namespace vellum::deformation
