#pragma once
// The GL side of the cinematic path tracer: an RGBA32F accumulation target that sample passes
// add into (additive blending: the sum of N passes, order-independent and deterministic), the
// progressive loop (samples, time limit) and the shader's light uniforms. Include only from
// .cpp files of modules/render (GL headers).
#include <functional>

#include "gl_util.hpp"
#include "path_tracer.hpp"

namespace vellum::render::detail {

class AccumulationTarget {
 public:
  AccumulationTarget() = default;
  ~AccumulationTarget();
  AccumulationTarget(const AccumulationTarget&) = delete;
  AccumulationTarget& operator=(const AccumulationTarget&) = delete;
  /// Makes it w x h (if needed), binds it and clears it to zero.
  void bindCleared(int w, int h);
  /// Binds it as it is (more passes add into the sums).
  void bind() const;
  /// The sums (row 0 = top) after `samples` paths per pixel.
  PathSums read(int samples) const;

 private:
  GLuint fbo_ = 0, colour_ = 0;
  int width_ = 0, height_ = 0;
};

/// The light, seed and bounce uniforms of the path-trace program `p` (in use).
/// The scene lights' uniforms of lights.glsl (the ray caster's TONE_MAP and the path tracer).
void setSceneLightUniforms(GLuint p, const SceneLights& lights);
void setPathTraceUniforms(GLuint p, const PathLights& lights, int seed);

/// Runs sample passes into the bound target: drawPass(first sample, count) until `samples`
/// are done or, with a time limit, the next pass (predicted to take as long as the last) would
/// end past it. Returns the samples done (at least one pass).
int runSamplePasses(const Cinematic& c, const std::function<void(int first, int count)>& drawPass);

}  // namespace vellum::render::detail
