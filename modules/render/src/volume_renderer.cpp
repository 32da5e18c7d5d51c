// GL ray caster: volume uploaded once (normals computed in the shader), one specialised program per mode.
#include "vellum/render/volume_renderer.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <functional>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <optional>

#include "empty_space.hpp"
#include "gl_util.hpp"
#include "light_volume.hpp"
#include "map_layout.hpp"
#include "map_sampling.hpp"
#include "normal_volume.hpp"
#include "path_tracer_gl.hpp"
#include "render_common.hpp"
#include "shader_source.hpp"
#include "vellum/core/error.hpp"

namespace vellum::render {

using namespace detail;

namespace {

enum TextureUnit : GLint {
  kUnitVolume = 0, kUnitTf, kUnitMap, kUnitAttr, kUnitOccupancy, kUnitBlockMax, kUnitClasses,
  kUnitLabels, kUnitLabelColours, kUnitOpaqueDepth, kUnitLight, kUnitMajorant, kUnitCoarseOccupancy
};

struct VoxelFormat {
  GLenum internal, type;
  double scale;  ///< normalised texel -> voxel value
};

template <class T> VoxelFormat voxelFormat();
// int16 as SNORM: texel * 32767 is the stored value exactly.
template <> VoxelFormat voxelFormat<int16_t>() { return {GL_R16_SNORM, GL_SHORT, 32767.0}; }
template <> VoxelFormat voxelFormat<uint8_t>() { return {GL_R8, GL_UNSIGNED_BYTE, 255.0}; }
template <> VoxelFormat voxelFormat<uint16_t>() { return {GL_R16, GL_UNSIGNED_SHORT, 65535.0}; }
template <> VoxelFormat voxelFormat<float>() { return {GL_R32F, GL_FLOAT, 1.0}; }

void setSampling(GLenum target, GLint filter, GLint wrap, const float* border) {
  glTexParameteri(target, GL_TEXTURE_MIN_FILTER, filter);
  glTexParameteri(target, GL_TEXTURE_MAG_FILTER, filter);
  glTexParameteri(target, GL_TEXTURE_WRAP_S, wrap);
  glTexParameteri(target, GL_TEXTURE_WRAP_T, wrap);
  glTexParameteri(target, GL_TEXTURE_WRAP_R, wrap);
  if (border) glTexParameterfv(target, GL_TEXTURE_BORDER_COLOR, border);
}

void deleteTexture(GLuint& t) {
  if (t) glDeleteTextures(1, &t);
  t = 0;
}

void uniform3(GLuint p, const char* name, const Vec3& v) {
  glUniform3f(glGetUniformLocation(p, name), float(v.x), float(v.y), float(v.z));
}
void uniform1(GLuint p, const char* name, double v) {
  glUniform1f(glGetUniformLocation(p, name), float(v));
}
void uniformMat3(GLuint p, const char* name, const Mat3& m) {
  float rows[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) rows[r * 3 + c] = float(m(r, c));
  glUniformMatrix3fv(glGetUniformLocation(p, name), 1, GL_TRUE, rows);
}

/// Textures for skipping over a coarse grid (source blocks, or map cells): an R8 occupancy
/// (rewritten per render from the transfer function) and R32F maxima (for MIP).
struct SkipGrid {
  GLuint occupancyTex = 0, maxTex = 0;
  GLuint coarseTex = 0;  ///< R8: per kCoarseSkip^3 blocks, any occupied (coarseOccupancy)
  Dims dims, coarseDims;
  /// The source blocks' occupancy the occupancy texture was made from: a draw with the same
  /// transfer function re-uploads nothing (the map cells' occupancy costs tens of ms at 512^3).
  std::vector<uint8_t> madeFrom;
  uint8_t madeFromBackground = 0;
  bool occupancySet = false;
  bool maxSet = false;  ///< maxTex filled (map cells: when a MIP is first drawn, fillSkipMax)
};

void fillSkipMax(SkipGrid& g, const std::vector<float>& maxValues) {
  glBindTexture(GL_TEXTURE_3D, g.maxTex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(g.dims.x), GLsizei(g.dims.y), GLsizei(g.dims.z), GL_RED, GL_FLOAT,
                  maxValues.data());
  g.maxSet = true;
}

/// A 3D texture of `dims` and `format`, nearest and clamped (the skip grids').
GLuint skipTexture(const Dims& dims, GLenum format) {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_3D, t);
  glTexStorage3D(GL_TEXTURE_3D, 1, format, GLsizei(dims.x), GLsizei(dims.y), GLsizei(dims.z));
  setSampling(GL_TEXTURE_3D, GL_NEAREST, GL_CLAMP_TO_EDGE, nullptr);
  return t;
}

/// The grid's textures for `dims` (kept when the dims are the same: a movie's maps all have
/// one grid, and llvmpipe clears a new texture's storage), their contents to be set.
/// `maxValues`: the grid's maxima now, or null (fillSkipMax when needed).
void makeSkipTextures(SkipGrid& g, const Dims& dims, const std::vector<float>* maxValues) {
  const Dims coarse{(dims.x + kCoarseSkip - 1) / kCoarseSkip, (dims.y + kCoarseSkip - 1) / kCoarseSkip,
                    (dims.z + kCoarseSkip - 1) / kCoarseSkip};
  if (!g.occupancyTex || !(g.dims == dims)) {
    for (GLuint* t : {&g.occupancyTex, &g.maxTex, &g.coarseTex}) deleteTexture(*t);
    g.occupancyTex = skipTexture(dims, GL_R8);
    g.maxTex = skipTexture(dims, GL_R32F);
    g.coarseTex = skipTexture(coarse, GL_R8);
  }
  g.dims = dims;
  g.coarseDims = coarse;
  g.maxSet = false;
  if (maxValues) fillSkipMax(g, *maxValues);
  g.occupancySet = false;
  checkGlError("skip textures");
}

void uploadOccupancy(const SkipGrid& g, const std::vector<uint8_t>& occ) {
  glBindTexture(GL_TEXTURE_3D, g.occupancyTex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(g.dims.x), GLsizei(g.dims.y),
                  GLsizei(g.dims.z), GL_RED, GL_UNSIGNED_BYTE, occ.data());
  Dims coarse;
  const std::vector<uint8_t> coarseOcc = coarseOccupancy(occ, g.dims, coarse);
  glBindTexture(GL_TEXTURE_3D, g.coarseTex);
  glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(coarse.x), GLsizei(coarse.y), GLsizei(coarse.z), GL_RED,
                  GL_UNSIGNED_BYTE, coarseOcc.data());
}

}  // namespace

// What setBackwardMap() does before GL, kept for the upload: the texels as uploaded (positions
// as RGBA, w unused: llvmpipe filters 16-byte texels faster than 12-byte ones; a one-joint twist
// kernel's weights as R, straight from the kernel, a quarter of the bytes to upload and to
// filter) and what the draws need.
struct VolumeRenderer::PreparedBackwardMap {
  std::shared_ptr<const BackwardMap> map;
  Geometry source;
  Dims texDims;
  int channels = 4;               ///< floats per texel: 4 (RGBA) or 1 (R)
  std::unique_ptr<float[]> rgba;  ///< `channels` floats per texel of texDims, unless in place
  size_t rgbaFloats = 0;
  const float* texels = nullptr;  ///< what is uploaded: `rgba`, or a one-stage kernel's weights (`map` keeps them)
  MapCells cells;
  std::optional<SnapFrame> snap;
  std::optional<TwistUniforms> twist;
  std::optional<PreparedMap::OutputAxes> output;
  Mat3 normalToSourceIndex, nodeIndexToNormal;
};

namespace {
/// The texel and cell buffers of a prepared map no longer drawn, for the next map of the same
/// grid: a movie prepares a map every frame (~320 MB at 512^2 x 350), and fresh memory is
/// zeroed page by page by the kernel.
struct MapBuffers {
  std::unique_ptr<float[]> rgba;
  size_t rgbaFloats = 0;
  std::vector<std::array<int16_t, 6>> boxes;
};
}  // namespace

struct VolumeRenderer::Impl {
  GlContext& context;
  GLuint volumeTex = 0, tfTex = 0, mapTex = 0, attrTex = 0, classTex = 0;
  /// The class voxels in classTex (re-uploaded only when another class volume arrives; held,
  /// so that no other volume can take the same address).
  const std::vector<uint16_t>* uploadedClasses = nullptr;
  std::shared_ptr<const std::vector<uint16_t>> heldClasses;
  std::optional<SnapFrame> snap;
  std::optional<TwistUniforms> twist;  ///< the drawn map's twist kernel
  std::optional<PreparedMap::OutputAxes> output;
  Mat3 normalToSourceIndex, nodeIndexToNormal;  ///< PreparedMap's, for TURN_NORMALS
  BlockRanges blocks;      ///< per source block value ranges (empty-space skipping)
  SkipGrid blockSkip, cellSkip;
  GLuint vao = 0;
  OffscreenTarget target;  ///< destroyed after the body of ~Impl, context still current
  bool hasVolume = false;
  bool hasLabels = false;
  GLuint labelTex = 0, labelColourTex = 0;  ///< LabelTint: ids (R16UI) and colours by id (RGBA8)
  Geometry source;
  double valueScale = 1;
  GradientNormals gradients;  ///< the shader's gradientNormal() constants for the volume
  std::shared_ptr<const BackwardMap> map;
  bool mapUploaded = false;
  /// The prepared map being drawn (its cells), and one being uploaded in steps into textures
  /// not drawn yet (VolumeRenderer::uploadBackwardMapStep).
  std::shared_ptr<const PreparedBackwardMap> drawnMap;
  struct MapStep {
    std::shared_ptr<const PreparedBackwardMap> prepared;
    GLuint mapTex = 0, attrTex = 0, classTex = 0;
    int64_t mapZ = 0, attrZ = 0, classZ = 0;
    bool newClasses = false;
  };
  std::optional<MapStep> mapStep;
  /// The map and attribute textures the previous map used, kept for the next map of the same
  /// node grid: a drag alternates between two grids, and llvmpipe's allocation of a 3D texture
  /// is not free.
  struct SpareTexture {
    GLuint tex = 0;
    Dims dims;
    GLenum format = GL_RGBA32F;
  };
  SpareTexture spareMap, spareAttr;
  Dims mapTexDims, attrTexDims;
  GLenum mapTexFormat = GL_RGBA32F;
  std::map<int, GLuint> programs;
  double lastMs = 0;
  int lastSamples = 0;  ///< cinematic: samples per pixel of the last render()
  GpuTimer timer;  ///< renderInto: GPU time without a stall
  /// Cinematic lighting: the values the light volume is made from, and the light volume in
  /// lightTex for the transfer function's opacity, light direction and radius it was made for.
  std::shared_ptr<const LightSource> lightSource;
  GLuint lightTex = 0;
  LightVolume light;
  std::vector<float> lightAlpha;
  Vec3 lightDir;
  double lightRadius = -1;
  double lightSize = -1;
  /// The map it was made through (lightDeformed; not held: a map is replaced each frame of a drag).
  std::weak_ptr<const PreparedBackwardMap> lightMap;
  bool lightDeformed = false;
  /// Cinematic quality (path_tracer_gl.hpp): extinction majorants per skip block.
  GLuint majorantTex = 0;
  Dims majorantDims;
  /// A path-traced picture in progress: its settings (full size), the denoise guide, the
  /// samples per pixel summed so far into its float target.
  struct Progressive {
    RenderSettings settings;
    RgbaImage guide;
    std::vector<uint8_t> guideRowDone;  ///< per image row: drawn into the guide (1)
    int guideRowsLeft = 0;
    int samples = 0;
    bool begun = false;
    AccumulationTarget accumulation;
  };
  Progressive oneShot, progressive;

  explicit Impl(GlContext& c) : context(c) {
    context.makeCurrent();
    glGenVertexArrays(1, &vao);
    glGenTextures(1, &tfTex);
    glBindTexture(GL_TEXTURE_1D, tfTex);
    glTexStorage1D(GL_TEXTURE_1D, 1, GL_RGBA32F, kTfTableSize);
    glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    checkGlError("renderer set-up");
  }

  ~Impl() {
    context.makeCurrent();
    for (auto& [key, p] : programs) glDeleteProgram(p);
    dropMapStep();
    for (GLuint* t : {&volumeTex, &tfTex, &mapTex, &attrTex, &classTex, &labelTex, &labelColourTex, &lightTex, &majorantTex, &blockSkip.occupancyTex,
                      &blockSkip.maxTex, &blockSkip.coarseTex, &cellSkip.occupancyTex, &cellSkip.maxTex, &cellSkip.coarseTex,
                      &spareMap.tex, &spareAttr.tex})
      deleteTexture(*t);
    glDeleteVertexArrays(1, &vao);
  }

  GLuint program(const ShaderVariant& v) {
    auto it = programs.find(v.key());
    if (it != programs.end()) return it->second;
    const GLuint p = buildProgram(vertexShaderSource(), fragmentShaderSource(v));
    glUseProgram(p);
    glUniform1i(glGetUniformLocation(p, "uVolume"), kUnitVolume);
    glUniform1i(glGetUniformLocation(p, "uTf"), kUnitTf);
    glUniform1i(glGetUniformLocation(p, "uMap"), kUnitMap);
    glUniform1i(glGetUniformLocation(p, "uAttr"), kUnitAttr);
    glUniform1i(glGetUniformLocation(p, "uOccupancy"), kUnitOccupancy);
    glUniform1i(glGetUniformLocation(p, "uBlockMax"), kUnitBlockMax);
    glUniform1i(glGetUniformLocation(p, snap_uniform::kClasses), kUnitClasses);
    glUniform1i(glGetUniformLocation(p, "uLabels"), kUnitLabels);
    glUniform1i(glGetUniformLocation(p, "uLabelColours"), kUnitLabelColours);
    glUniform1i(glGetUniformLocation(p, "uOpaqueDepth"), kUnitOpaqueDepth);
    glUniform1i(glGetUniformLocation(p, "uLight"), kUnitLight);
    glUniform1i(glGetUniformLocation(p, "uMajorant"), kUnitMajorant);
    glUniform1i(glGetUniformLocation(p, "uCoarseOccupancy"), kUnitCoarseOccupancy);
    programs[v.key()] = p;
    return p;
  }

  static void checkTextureSize(const Dims& d, const char* what) {
    GLint max3d = 0;
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
    if (d.x > max3d || d.y > max3d || d.z > max3d)
      throw Error(std::string("render: ") + what + " of " + d.str() +
                  " exceeds the GL 3D texture limit of " + std::to_string(max3d) + " per axis");
  }

  template <class T>
  void uploadVolume(const Volume<T>& vol) {
    allocVolume(vol);
    uploadVolumeSlab(vol, 0, vol.dims().z);
  }
  /// The volume texture's storage and sampling, without its texels (uploadVolumeSlab).
  template <class T>
  void allocVolume(const Volume<T>& vol) {
    deleteTexture(volumeTex);
    volumeTex = newVolumeTexture(vol);
    valueScale = voxelFormat<T>().scale;
  }
  /// A new texture for `vol` on the current context (any thread's), storage and sampling only.
  template <class T>
  static GLuint newVolumeTexture(const Volume<T>& vol) {
    const Dims& d = vol.dims();
    checkTextureSize(d, "volume");
    const VoxelFormat fmt = voxelFormat<T>();
    GLuint tex = 0;
    glGenTextures(1, &tex);
    glBindTexture(GL_TEXTURE_3D, tex);
    glTexStorage3D(GL_TEXTURE_3D, 1, fmt.internal, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z));
    // Border = background, so that sampling outside matches Volume::sampleLinear.
    const float bg = static_cast<float>(vol.background() / fmt.scale);
    const float border[4] = {bg, bg, bg, bg};
    setSampling(GL_TEXTURE_3D, GL_LINEAR, GL_CLAMP_TO_BORDER, border);
    checkGlError("volume allocation");
    return tex;
  }
  /// Slices [z0, z1) of the volume into its texture.
  template <class T>
  void uploadVolumeSlab(const Volume<T>& vol, int64_t z0, int64_t z1) {
    fillVolumeSlab(volumeTex, vol, z0, z1);
  }
  template <class T>
  static void fillVolumeSlab(GLuint tex, const Volume<T>& vol, int64_t z0, int64_t z1) {
    const Dims& d = vol.dims();
    glBindTexture(GL_TEXTURE_3D, tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, GLint(z0), GLsizei(d.x), GLsizei(d.y), GLsizei(z1 - z0), GL_RED,
                    voxelFormat<T>().type, vol.data() + static_cast<size_t>(z0 * d.x * d.y));
    checkGlError("volume upload");
  }

  /// An upload in steps (VolumeRenderer::uploadVolumeStep): the volume, its prepared part and
  /// the slices uploaded so far.
  struct StepUpload {
    std::shared_ptr<const AnyVolume> volume;
    std::shared_ptr<const Prepared> prepared;
    int64_t z = 0;
  };
  std::optional<StepUpload> stepUpload;

  /// The map (set by setBackwardMap, or kept across a new volume) prepared for the current
  /// volume and uploaded at once.
  void uploadMap() {
    if (!map || mapUploaded || !hasVolume) return;
    startMapStep(prepareFor(map, source, blocks, &spareBuffers));
    continueMapStep(std::numeric_limits<size_t>::max());
  }

  /// `reuse` (optional): buffers to fill if they have the size (taken from it).
  static std::shared_ptr<const PreparedBackwardMap> prepareFor(std::shared_ptr<const BackwardMap> map,
                                                               const Geometry& source, const BlockRanges& blocks,
                                                               MapBuffers* reuse = nullptr);
  MapBuffers spareBuffers;
  /// The drawn map's buffers kept for the next map when nothing else holds it (it is about to go).
  void recycleDrawnMap() {
    if (!drawnMap || drawnMap.use_count() != 1) return;
    auto& p = const_cast<PreparedBackwardMap&>(*drawnMap);  // made non-const by prepareFor
    spareBuffers = {std::move(p.rgba), p.rgbaFloats, std::move(p.cells.box)};
  }

  void dropMapStep() {
    if (!mapStep) return;
    for (GLuint* t : {&mapStep->mapTex, &mapStep->attrTex, &mapStep->classTex}) deleteTexture(*t);
    mapStep.reset();
  }

  /// A 3D float texture of `d` (RGBA32F or R32F) with linear clamped sampling: the spare one
  /// when it fits.
  static GLuint mapTexture(SpareTexture& spare, const Dims& d, GLenum format = GL_RGBA32F) {
    GLuint t = 0;
    if (spare.tex && spare.dims == d && spare.format == format) {
      std::swap(t, spare.tex);
    } else {
      deleteTexture(spare.tex);
      glGenTextures(1, &t);
      glBindTexture(GL_TEXTURE_3D, t);
      glTexStorage3D(GL_TEXTURE_3D, 1, format, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z));
    }
    glBindTexture(GL_TEXTURE_3D, t);
    // The map extends its outermost nodes (rays only sample inside its grid box).
    setSampling(GL_TEXTURE_3D, GL_LINEAR, GL_CLAMP_TO_EDGE, nullptr);
    return t;
  }
  static void retire(SpareTexture& spare, GLuint& tex, const Dims& d, GLenum format = GL_RGBA32F) {
    if (!tex) return;
    deleteTexture(spare.tex);
    spare = {tex, d, format};
    tex = 0;
  }

  /// Textures for `p`, allocated but not filled (continueMapStep fills them).
  void startMapStep(std::shared_ptr<const PreparedBackwardMap> p);
  /// Fills whole z slabs of the pending textures, about `maxBytes` (at least one slab); once
  /// all are full they replace the drawn map's. True when done.
  bool continueMapStep(size_t maxBytes);

  /// The light volume for this transfer function, light and radius (recomputed only when one
  /// of them changed), bound with its uniforms.
  /// `deformed`: the drawn map, whose output space the light volume then lies in.
  void useLight(GLuint p, const RenderSettings& s, const TfTable& tf, const Frame& f,
                const std::shared_ptr<const PreparedBackwardMap>& deformed) {
    const Vec3 dir = keyLightDirection(f, s.lighting);
    std::vector<float> alpha(tf.rgba.size() / 4);
    for (size_t i = 0; i < alpha.size(); ++i) alpha[i] = tf.rgba[4 * i + 3];
    const bool soft = s.lighting.toneMap || s.quality == Quality::Cinematic;  // the scene lights' disc
    const double size = soft ? s.cinematic.lightSizeDeg : 0.0;
    const bool same = lightTex && alpha == lightAlpha && norm(dir - lightDir) < 1e-9 &&
                      lightRadius == s.lighting.occlusionRadiusMm && lightSize == size &&
                      lightDeformed == (deformed != nullptr) && (!deformed || lightMap.lock() == deformed);
    if (!same) {
      if (deformed) {  // the deformed anatomy's shadows: the density resampled through the map
        const PreparedMap pm = prepareMap(*deformed->map, source);
        light = computeLightVolume(deformedLightSource(*lightSource, pm, *deformed->map), tf, f.stepMm, dir,
                                   s.lighting, size);
      } else {
        light = computeLightVolume(*lightSource, tf, f.stepMm, dir, s.lighting, size);
      }
      lightMap = deformed;
      lightDeformed = deformed != nullptr;
      deleteTexture(lightTex);
      glActiveTexture(GL_TEXTURE0 + kUnitLight);  // not the unit bound last (the skip grid's)
      glGenTextures(1, &lightTex);
      glBindTexture(GL_TEXTURE_3D, lightTex);
      const Dims& d = light.dims;
      // RGBA8 (b, a unused): llvmpipe filters 4-byte texels on its fast path, RG8 not.
      std::vector<uint8_t> rgba(light.rg.size() * 2, 0);
      for (size_t i = 0, n = light.rg.size() / 2; i < n; ++i) {
        rgba[4 * i] = light.rg[2 * i];
        rgba[4 * i + 1] = light.rg[2 * i + 1];
      }
      glTexStorage3D(GL_TEXTURE_3D, 1, GL_RGBA8, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z));
      glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
      glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z), GL_RGBA, GL_UNSIGNED_BYTE,
                      rgba.data());
      setSampling(GL_TEXTURE_3D, GL_LINEAR, GL_CLAMP_TO_EDGE, nullptr);
      checkGlError("light volume upload");
      lightAlpha = std::move(alpha);
      lightDir = dir;
      lightRadius = s.lighting.occlusionRadiusMm;
      lightSize = size;
    }
    glActiveTexture(GL_TEXTURE0 + kUnitLight);
    glBindTexture(GL_TEXTURE_3D, lightTex);
    const Dims& d = light.dims;
    const Vec3& r = light.boxToSource;
    uniform3(p, "uLightScale", {r.x / (light.factor * d.x), r.y / (light.factor * d.y), r.z / (light.factor * d.z)});
    uniform3(p, "uLightOffset", light.towardsLight);
    uniform3(p, "uLightDir", dir);
    uniform1(p, "uShadowAmount", s.lighting.shadows);
    uniform1(p, "uOcclusionAmount", s.lighting.occlusion);
    uniform1(p, "uExposure", std::exp2(s.lighting.exposure));
    if (s.lighting.toneMap) setSceneLightUniforms(p, makeSceneLights(f, s));
  }

  /// Ray casts rows [rowBegin, rowEnd) (row 0 = top) of the image `s` describes into the bound
  /// framebuffer `fbo` (viewport = the whole image, the rest scissored away); with an opaque
  /// depth texture, rays stop at it and the result is blended over the colour there.
  void draw(const RenderSettings& s, GLuint fbo, int rowBegin, int rowEnd, GLuint opaqueDepth, int colBegin = 0,
            int colEnd = -1);
  /// The program of this frame's variant, in use, with its textures bound and the transfer
  /// function (or MIP window) and skip grid set.
  GLuint useProgram(const RenderSettings& s, const Frame& f, const BackwardMap* deform, bool opaqueDepth,
                    bool pathTrace = false);
  /// Quality::Cinematic, as steps (render() runs all three on `oneShot`, the public
  /// begin/add/resolve API on `progressive`, so a one-shot render leaves a progressive one
  /// intact): the denoise guide and a cleared float target; sample passes added into it;
  /// the picture of the sums so far, tone mapped and denoised.
  void beginCinematic(Progressive& pr, const RenderSettings& s, bool guideInBands = false);
  /// Rows [rowBegin, rowEnd) of the denoise guide ray cast and read back into pr.guide.
  void drawGuideRows(Progressive& pr, int rowBegin, int rowEnd);
  /// Passes over the whole picture, or (rowBegin < rowEnd, image rows, row 0 = top) one
  /// uncounted pass over those rows only (the caller counts the sample once all rows have it).
  int addCinematicPasses(Progressive& pr, const Cinematic& budget, int rowBegin = 0, int rowEnd = 0);
  RgbaImage resolveCinematic(const Progressive& pr) const;
  /// The path tracer's majorant texture for this frame's table (per source block, or map cell).
  void useMajorants(const TfTable& tf, const Frame& f, const BackwardMap* deform, const Dims& dims);
  /// Camera, box, step, background and value-scale uniforms.
  void setFrameUniforms(GLuint p, const RenderSettings& s, const Frame& f) const;

  void setTwistUniforms(GLuint p) const {
    const TwistUniforms& t = *twist;
    namespace u = twist_uniform;
    std::array<float, 3 * TwistKernel::kMaxStages> point{}, axis{};
    std::array<float, TwistKernel::kMaxStages> angle{};
    for (int s = 0; s < TwistKernel::kMaxStages; ++s) {
      for (int a = 0; a < 3; ++a) {
        point[size_t(3 * s + a)] = float(t.point[size_t(s)][a]);
        axis[size_t(3 * s + a)] = float(t.axis[size_t(s)][a]);
      }
      angle[size_t(s)] = float(t.angle[size_t(s)]);
    }
    glUniform3fv(glGetUniformLocation(p, u::kTwistPoint), TwistKernel::kMaxStages, point.data());
    glUniform3fv(glGetUniformLocation(p, u::kTwistAxis), TwistKernel::kMaxStages, axis.data());
    glUniform1fv(glGetUniformLocation(p, u::kTwistAngle), TwistKernel::kMaxStages, angle.data());
    uniformMat3(p, u::kNodeToMm, t.nodeToMm);
    uniform3(p, u::kNodeToMmOffset, t.nodeToMmOffset);
    uniformMat3(p, u::kMmToNode, t.mmToNode);
    uniform3(p, u::kMmToNodeOffset, t.mmToNodeOffset);
    uniformMat3(p, u::kMmToSrc, t.mmToSrc);
    uniform3(p, u::kMmToSrcOffset, t.mmToSrcOffset);
  }

  void setSnapUniforms(GLuint p) const {
    const SnapFrame& ps = *snap;
    glActiveTexture(GL_TEXTURE0 + kUnitClasses);
    glBindTexture(GL_TEXTURE_3D, classTex);
    namespace u = snap_uniform;
    glUniformMatrix3fv(glGetUniformLocation(p, u::kSrcToClass), 1, GL_TRUE, ps.toClass.data());
    glUniform3f(glGetUniformLocation(p, u::kSrcToClassOffset), ps.toClass[9], ps.toClass[10], ps.toClass[11]);
    glUniformMatrix3fv(glGetUniformLocation(p, u::kSrcDeltaToMm), 1, GL_TRUE, ps.deltaToMm.data());
    std::vector<float> rows;
    uint32_t valid[(kMaxSnapBodies + 31) / 32] = {}, held[(kMaxSnapBodies + 31) / 32] = {};
    for (size_t c = 0; c < ps.body.size(); ++c) {
      const auto& m = ps.body[c];
      for (int r = 0; r < kSnapBodyRows; ++r) rows.insert(rows.end(), {m[3 * r], m[3 * r + 1], m[3 * r + 2], m[9 + r]});
      if (ps.valid[c]) valid[c / 32] |= 1u << (c % 32);
      if (c < ps.held.size() && ps.held[c]) held[c / 32] |= 1u << (c % 32);
    }
    if (!rows.empty())
      glUniform4fv(glGetUniformLocation(p, u::kBodyRows), GLsizei(rows.size() / 4), rows.data());
    glUniform1uiv(glGetUniformLocation(p, u::kBodyValid), GLsizei(std::size(valid)), valid);
    glUniform1uiv(glGetUniformLocation(p, u::kBodyHeld), GLsizei(std::size(held)), held);
    glUniformMatrix3fv(glGetUniformLocation(p, u::kPointToClass), 1, GL_TRUE, ps.pointToClass.data());
    glUniform3f(glGetUniformLocation(p, u::kPointToClassOffset), ps.pointToClass[9], ps.pointToClass[10],
                ps.pointToClass[11]);
    glUniform3f(glGetUniformLocation(p, u::kHeldLo), ps.heldBox[0], ps.heldBox[1], ps.heldBox[2]);
    glUniform3f(glGetUniformLocation(p, u::kHeldHi), ps.heldBox[3], ps.heldBox[4], ps.heldBox[5]);
    glUniform1i(glGetUniformLocation(p, u::kBodies), GLint(ps.body.size()));
    glUniform1f(glGetUniformLocation(p, u::kMaxSnap2), ps.maxSnap2);
  }
};

GLuint VolumeRenderer::Impl::useProgram(const RenderSettings& s, const Frame& f, const BackwardMap* deform,
                                        bool opaqueDepth, bool pathTrace) {
  ShaderVariant variant;
  variant.mip = s.preset == Preset::Mip;
  variant.shading = s.shading;
  variant.deformed = deform != nullptr;
  variant.attributes = deform && !deform->attributes.empty();
  variant.gaussian = deform && deform->upsampling == Upsampling::Gaussian;
  variant.snap = deform && snap.has_value();
  variant.held = variant.snap && snap->anyHeld;
  variant.twistStages = deform && twist ? twist->stages : 0;
  variant.outputBox = deform && output.has_value();
  variant.labels = hasLabels && (s.labelBlend > 0 || s.onlyLabel > 0) && !variant.mip;
  variant.opaqueDepth = opaqueDepth;
  variant.turnNormals = deform && s.shading && s.turnDeformedNormals && !variant.mip;
  variant.lighting = s.lighting.on() && s.shading && !variant.mip && lightSource != nullptr;
  variant.toneMap = variant.lighting && s.lighting.toneMap;
  if (pathTrace) {  // the path tracer reads normals (its BRDF), and lights by itself
    variant.pathTrace = true;
    variant.shading = true;
    variant.turnNormals = deform && s.turnDeformedNormals;
    variant.toneMap = variant.opaqueDepth = false;
    // Volume shadows: the light volume instead of traced shadow and sky rays.
    variant.lighting = s.cinematic.volumeShadows && lightSource != nullptr;
  }
  const GLuint p = program(variant);
  glUseProgram(p);

  glActiveTexture(GL_TEXTURE0 + kUnitVolume);
  glBindTexture(GL_TEXTURE_3D, volumeTex);
  if (variant.shading && !variant.mip) {
    // Texel differences -> physical gradient: the texels are values / valueScale.
    Mat3 m = gradients.toPhysical;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) *= valueScale;
    uniformMat3(p, "uGradToPhys", m);
    uniform1(p, "uGradMagScale", gradients.magScale);
  }
  if (variant.labels) {
    glActiveTexture(GL_TEXTURE0 + kUnitLabels);
    glBindTexture(GL_TEXTURE_3D, labelTex);
    glActiveTexture(GL_TEXTURE0 + kUnitLabelColours);
    glBindTexture(GL_TEXTURE_1D, labelColourTex);
    glUniform1f(glGetUniformLocation(p, "uLabelBlend"), static_cast<float>(s.labelBlend));
  }
  if (variant.deformed) {
    glActiveTexture(GL_TEXTURE0 + kUnitMap);
    glBindTexture(GL_TEXTURE_3D, mapTex);
    glActiveTexture(GL_TEXTURE0 + kUnitAttr);
    glBindTexture(GL_TEXTURE_3D, attrTex);
    if (variant.gaussian)
      uniform3(p, "uMapNodes", {double(deform->grid.dims.x), double(deform->grid.dims.y), double(deform->grid.dims.z)});
    if (variant.snap) setSnapUniforms(p);
    if (variant.twistStages > 0) setTwistUniforms(p);
    if (variant.turnNormals) {
      uniformMat3(p, "uNormalToSrcIndex", normalToSourceIndex);
      uniformMat3(p, "uNodeIndexToNormal", nodeIndexToNormal);
    }
    if (variant.outputBox) {
      uniform3(p, "uOutScale", output->scale);
      uniform3(p, "uOutOffset", output->offset);
      uniform3(p, "uOutDims", output->dims);
    }
  }
  SkipGrid& skip = variant.deformed ? cellSkip : blockSkip;
  glUniform3i(glGetUniformLocation(p, "uBlocks"), GLint(skip.dims.x), GLint(skip.dims.y),
              GLint(skip.dims.z));
  if (variant.mip) {
    const double width = s.windowWidth > 0 ? s.windowWidth : 1.0;
    uniform1(p, "uWinLo", s.windowCenter - 0.5 * width);
    uniform1(p, "uWinInvWidth", 1.0 / width);
    glActiveTexture(GL_TEXTURE0 + kUnitBlockMax);
    if (!skip.maxSet) fillSkipMax(skip, cellMaxValues(drawnMap->cells, blocks));  // only map cells wait
    glBindTexture(GL_TEXTURE_3D, skip.maxTex);
  } else {
    const TfTable tf = buildTfTable(s, f.stepMm);
    glActiveTexture(GL_TEXTURE0 + kUnitTf);
    glBindTexture(GL_TEXTURE_1D, tfTex);
    glTexSubImage1D(GL_TEXTURE_1D, 0, 0, kTfTableSize, GL_RGBA, GL_FLOAT, tf.rgba.data());
    uniform1(p, "uTfLo", tf.lo);
    // Map cells read their blocks' own ranges (they add their own voxel of support), and the
    // background on the grid's faces.
    std::vector<uint8_t> occ = variant.deformed ? ownBlockOccupancy(blocks, tf) : blockOccupancy(blocks, tf);
    const uint8_t background = backgroundOccupancy(blocks, tf);
    if (!skip.occupancySet || occ != skip.madeFrom || background != skip.madeFromBackground) {
      uploadOccupancy(skip, variant.deformed ? cellOccupancy(drawnMap->cells, occ, blocks.blocks, background != 0) : occ);
      skip.madeFrom = std::move(occ);
      skip.madeFromBackground = background;
      skip.occupancySet = true;
    }
    glActiveTexture(GL_TEXTURE0 + kUnitOccupancy);
    glBindTexture(GL_TEXTURE_3D, skip.occupancyTex);
    glActiveTexture(GL_TEXTURE0 + kUnitCoarseOccupancy);
    glBindTexture(GL_TEXTURE_3D, skip.coarseTex);
    glUniform3i(glGetUniformLocation(p, "uCoarseBlocks"), GLint(skip.coarseDims.x), GLint(skip.coarseDims.y),
                GLint(skip.coarseDims.z));
    uniform1(p, "uTfInvSpan", 1.0 / (tf.hi - tf.lo));
    if (variant.lighting) useLight(p, s, tf, f, variant.deformed ? drawnMap : nullptr);
    if (pathTrace) useMajorants(tf, f, deform, skip.dims);
  }
  return p;
}

void VolumeRenderer::Impl::useMajorants(const TfTable& tf, const Frame& f, const BackwardMap* deform, const Dims& dims) {
  std::vector<float> maj = blockMajorants(blocks, tf, f.stepMm);
  if (deform) {
    float scale = 1;  // the attribute field's density scale multiplies the extinction
    for (size_t i = 3; i < deform->attributes.size(); i += 4) scale = std::max(scale, deform->attributes[i]);
    maj = cellMajorants(drawnMap->cells, maj, blocks.blocks, scale);
  }
  // Its own unit before a new texture is bound: the unit active now holds the light volume.
  glActiveTexture(GL_TEXTURE0 + kUnitMajorant);
  if (!majorantTex || !(majorantDims == dims)) {
    deleteTexture(majorantTex);
    glGenTextures(1, &majorantTex);
    glBindTexture(GL_TEXTURE_3D, majorantTex);
    glTexStorage3D(GL_TEXTURE_3D, 1, GL_R32F, GLsizei(dims.x), GLsizei(dims.y), GLsizei(dims.z));
    setSampling(GL_TEXTURE_3D, GL_NEAREST, GL_CLAMP_TO_EDGE, nullptr);
    majorantDims = dims;
  }
  glBindTexture(GL_TEXTURE_3D, majorantTex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(dims.x), GLsizei(dims.y), GLsizei(dims.z), GL_RED, GL_FLOAT,
                  maj.data());
  checkGlError("cinematic majorants");
}

void VolumeRenderer::Impl::beginCinematic(Progressive& pr, const RenderSettings& s, bool guideInBands) {
  uploadMap();
  pr.settings = s;
  pr.samples = 0;
  pr.guide = RgbaImage();  // the denoise's edges: the same view ray cast (path_tracer.hpp)
  pr.guideRowDone.clear();
  pr.guideRowsLeft = 0;
  if (s.cinematic.denoise > 0) {
    pr.guide = RgbaImage(s.width, s.height);
    pr.guideRowDone.assign(size_t(s.height), 0);
    pr.guideRowsLeft = s.height;
    if (!guideInBands) drawGuideRows(pr, 0, s.height);
  }
  // The paths: at cinematic.traceScale of the size (finishPathTraced upsamples them).
  const RenderSettings ts = tracedSettings(s);
  pr.accumulation.bindCleared(ts.width, ts.height);
  pr.begun = true;
}

void VolumeRenderer::Impl::drawGuideRows(Progressive& pr, int rowBegin, int rowEnd) {
  const RenderSettings& s = pr.settings;
  target.bind(s.width, s.height, "render");
  draw(denoiseGuideSettings(s), target.framebuffer(), rowBegin, rowEnd, 0);
  readRgbaRows(target.framebuffer(), rowBegin, rowEnd, pr.guide, "denoise guide");
  for (int y = rowBegin; y < rowEnd; ++y)
    if (!pr.guideRowDone[size_t(y)]) {
      pr.guideRowDone[size_t(y)] = 1;
      --pr.guideRowsLeft;
    }
}

int VolumeRenderer::Impl::addCinematicPasses(Progressive& pr, const Cinematic& budget, int rowBegin, int rowEnd) {
  // The whole GL state again on every call: between two calls a viewer draws other things.
  const BackwardMap* deform = map ? &*map : nullptr;
  const RenderSettings ts = tracedSettings(pr.settings);
  const Frame ft = makeFrame(source, deform ? &deform->grid : nullptr, ts);
  const GLuint p = useProgram(ts, ft, deform, false, true);
  setFrameUniforms(p, ts, ft);
  setPathTraceUniforms(p, makePathLights(ft, ts), pr.settings.cinematic.seed);
  pr.accumulation.bind();
  glViewport(0, 0, ts.width, ts.height);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_SCISSOR_TEST);
  const bool band = rowBegin < rowEnd;
  if (band) {  // the traced picture's rows of the band (traceScale), GL's row 0 at the bottom
    const int h = pr.settings.height;
    const int t0 = int(int64_t(rowBegin) * ts.height / h), t1 = rowEnd >= h ? ts.height : int(int64_t(rowEnd) * ts.height / h);
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, ts.height - t1, ts.width, t1 - t0);
  }
  glEnable(GL_BLEND);  // each pass adds its samples' sums
  glBlendEquation(GL_FUNC_ADD);
  glBlendFunc(GL_ONE, GL_ONE);
  glBindVertexArray(vao);
  const int base = pr.samples;  // sample indices continue: N passes of 1 = one pass run of N
  const int done = runSamplePasses(budget, [&](int first, int count) {
    glUniform1i(glGetUniformLocation(p, "uSampleBase"), base + first);
    glUniform1i(glGetUniformLocation(p, "uSamplesPerPass"), count);
    glDrawArrays(GL_TRIANGLES, 0, 3);
  });
  glDisable(GL_BLEND);
  glDisable(GL_SCISSOR_TEST);
  checkGlError("path tracing");
  if (!band) pr.samples += done;
  return done;
}

RgbaImage VolumeRenderer::Impl::resolveCinematic(const Progressive& pr) const {
  if (pr.guideRowsLeft > 0) throw Error("resolveCinematic: the denoise guide is not complete (addCinematicGuideRows)");
  const PathSums sums = pr.accumulation.read(pr.samples);
  return finishPathTraced(sums, pr.settings, &pr.guide);
}

void VolumeRenderer::Impl::setFrameUniforms(GLuint p, const RenderSettings& s, const Frame& f) const {
  glUniform2f(glGetUniformLocation(p, "uViewport"), float(s.width), float(s.height));
  uniform3(p, "uEye", f.eye);
  uniform3(p, "uRight", f.right);
  uniform3(p, "uUp", f.up);
  uniform3(p, "uForward", f.forward);
  glUniform2f(glGetUniformLocation(p, "uHalf"), float(f.halfW), float(f.halfH));
  uniform1(p, "uPersp", f.perspective ? 1.0 : 0.0);
  float mat[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) mat[r * 3 + c] = float(f.physToBox(r, c));
  glUniformMatrix3fv(glGetUniformLocation(p, "uPhysToBox"), 1, GL_TRUE, mat);
  uniform3(p, "uBoxOrigin", f.box.origin);
  uniform3(p, "uBoxDims", {double(f.box.dims.x), double(f.box.dims.y), double(f.box.dims.z)});
  uniform3(p, "uClipLo", f.clipLo);
  uniform3(p, "uClipHi", f.clipHi);
  glUniform1i(glGetUniformLocation(p, "uOnlyLabel"), s.onlyLabel);
  uniform1(p, "uStep", f.stepMm);
  uniform1(p, "uJitter", s.jitter ? 1.0 : 0.0);
  glUniform4f(glGetUniformLocation(p, "uBackground"), s.background[0], s.background[1],
              s.background[2], s.background[3]);
  uniform1(p, "uValueScale", valueScale);
  uniform3(p, "uSourceDims",
           {double(source.dims.x), double(source.dims.y), double(source.dims.z)});

}

void VolumeRenderer::Impl::draw(const RenderSettings& s, GLuint fbo, int rowBegin, int rowEnd, GLuint opaqueDepth,
                                int colBegin, int colEnd) {
  uploadMap();
  const BackwardMap* deform = map ? &*map : nullptr;
  const Frame f = makeFrame(source, deform ? &deform->grid : nullptr, s);

  const GLuint p = useProgram(s, f, deform, opaqueDepth != 0);
  setFrameUniforms(p, s, f);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glViewport(0, 0, s.width, s.height);
  glDisable(GL_DEPTH_TEST);
  if (opaqueDepth) {
    // The volume in front of the surface (premultiplied) over the surface colour already there.
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glActiveTexture(GL_TEXTURE0 + kUnitOpaqueDepth);
    glBindTexture(GL_TEXTURE_2D, opaqueDepth);
  } else {
    glDisable(GL_BLEND);
  }
  // Rows [rowBegin, rowEnd) from the top are GL rows [height - rowEnd, height - rowBegin).
  const int glRow0 = s.height - rowEnd, rows = rowEnd - rowBegin;
  glEnable(GL_SCISSOR_TEST);
  if (colEnd < 0) colEnd = s.width;
  glScissor(colBegin, glRow0, colEnd - colBegin, rows);
  glBindVertexArray(vao);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_BLEND);
}

VolumeRenderer::VolumeRenderer(GlContext& context) : impl_(std::make_unique<Impl>(context)) {}
VolumeRenderer::~VolumeRenderer() = default;

struct VolumeRenderer::Prepared {
  Geometry geometry;
  GradientNormals gradients;
  BlockRanges blocks;
  std::shared_ptr<const LightSource> light;  ///< what the cinematic lighting is computed from
};

std::shared_ptr<const VolumeRenderer::Prepared> VolumeRenderer::prepare(const AnyVolume& volume, bool withLight) {
  geometryOf(volume).validate("render volume");
  return std::make_shared<const Prepared>(Prepared{geometryOf(volume), gradientNormals(volume),
                                                   computeBlockRanges(volume),
                                                   withLight ? makeLightSource(volume) : nullptr});
}

std::shared_ptr<const LightSource> VolumeRenderer::makeLightSource(const AnyVolume& volume) {
  return std::make_shared<const LightSource>(detail::makeLightSource(volume));
}

std::shared_ptr<const LightSource> VolumeRenderer::makeLightSource(const VolumeI16& volume) {
  return std::make_shared<const LightSource>(detail::makeLightSource(volume));
}

void VolumeRenderer::setLightSource(std::shared_ptr<const LightSource> light) {
  if (light && !(light->source.dims == impl_->source.dims && light->source.spacing == impl_->source.spacing))
    throw Error("setLightSource: made for another volume");
  impl_->context.makeCurrent();
  impl_->lightSource = std::move(light);
  deleteTexture(impl_->lightTex);  // computed from the previous light source, or none
}

bool VolumeRenderer::hasLightSource() const { return impl_->lightSource != nullptr; }

bool VolumeRenderer::usesLightSource(const RenderSettings& s) {
  if (s.preset == Preset::Mip) return false;
  // As useProgram's variant.lighting: the ray caster's lighting terms, the path tracer's shadows.
  return (s.lighting.on() && s.shading) || (s.quality == Quality::Cinematic && s.cinematic.volumeShadows);
}

void VolumeRenderer::setVolume(const AnyVolume& volume) { setVolume(volume, *prepare(volume)); }

void VolumeRenderer::setVolume(const AnyVolume& volume, const Prepared& prepared) {
  const Geometry& g = geometryOf(volume);
  g.validate("render volume");
  if (!(prepared.geometry.dims == g.dims)) throw Error("setVolume: prepared for another volume");
  impl_->context.makeCurrent();
  impl_->stepUpload.reset();
  impl_->hasVolume = false;
  std::visit([&](const auto& v) { impl_->uploadVolume(v); }, volume);
  finishVolume(g, prepared);
}

void VolumeRenderer::finishVolume(const Geometry& g, const Prepared& prepared) {
  impl_->blocks = prepared.blocks;
  impl_->gradients = prepared.gradients;
  impl_->lightSource = prepared.light;
  deleteTexture(impl_->lightTex);  // made for the previous volume
  makeSkipTextures(impl_->blockSkip, impl_->blocks.blocks, &impl_->blocks.maxValue);
  impl_->source = g;
  impl_->hasVolume = true;
  impl_->dropMapStep();
  impl_->mapUploaded = false;  // source index coordinates depend on the source geometry
  impl_->uploadMap();
  setLabelTint(nullptr);  // the labels belonged to the previous volume
}

bool VolumeRenderer::uploadVolumeStep(std::shared_ptr<const AnyVolume> volume, std::shared_ptr<const Prepared> prepared,
                                      size_t maxBytes) {
  Impl& m = *impl_;
  m.context.makeCurrent();
  const Geometry& g = geometryOf(*volume);
  if (!m.stepUpload || m.stepUpload->volume != volume || m.stepUpload->prepared != prepared) {
    g.validate("render volume");
    if (!(prepared->geometry.dims == g.dims)) throw Error("uploadVolumeStep: prepared for another volume");
    m.hasVolume = false;  // nothing is drawn until the new volume is complete
    std::visit([&](const auto& v) { m.allocVolume(v); }, *volume);
    m.stepUpload = Impl::StepUpload{volume, prepared, 0};
    // The allocation alone in its call (its own frame): llvmpipe clears the storage.
    return false;
  }
  Impl::StepUpload& u = *m.stepUpload;
  // Whole slices, at least one per step.
  const size_t voxelBytes = std::visit([](const auto& v) { return sizeof(*v.data()); }, *volume);
  const size_t sliceBytes = static_cast<size_t>(g.dims.x * g.dims.y) * voxelBytes;
  const int64_t z1 = std::min<int64_t>(g.dims.z, u.z + std::max<int64_t>(1, int64_t(maxBytes / sliceBytes)));
  std::visit([&](const auto& v) { m.uploadVolumeSlab(v, u.z, z1); }, *volume);
  u.z = z1;
  if (u.z < g.dims.z) return false;
  m.stepUpload.reset();
  finishVolume(g, *prepared);
  return true;
}

struct VolumeRenderer::VolumeTextures {
  GLuint volume = 0;
  double valueScale = 1;
  Geometry geometry;
};

template <class T>
std::shared_ptr<VolumeRenderer::VolumeTextures> VolumeRenderer::makeTexturesOf(
    const Volume<T>& v, const Prepared& prepared, size_t slabBytes, const std::function<void()>& betweenSlabs) {
  const Geometry& g = v.geometry();
  g.validate("render volume");
  if (!(prepared.geometry.dims == g.dims)) throw Error("makeVolumeTextures: prepared for another volume");
  auto t = std::make_shared<VolumeTextures>();
  t->geometry = g;
  // Whole z slices, about slabBytes a call: Mesa holds the objects' shared lock through each
  // texture call, and the other contexts' draws wait for it.
  const size_t sliceBytes = static_cast<size_t>(g.dims.x * g.dims.y) * sizeof(T);
  const int64_t step = std::max<int64_t>(1, int64_t(slabBytes / std::max<size_t>(1, sliceBytes)));
  t->volume = Impl::newVolumeTexture(v);
  t->valueScale = voxelFormat<T>().scale;
  for (int64_t z = 0; z < g.dims.z; z += step) {
    if (z > 0 && betweenSlabs) betweenSlabs();
    Impl::fillVolumeSlab(t->volume, v, z, std::min(g.dims.z, z + step));
  }
  glBindTexture(GL_TEXTURE_3D, 0);
  // Complete before another context samples them (llvmpipe copies at once; a GPU may not).
  glFinish();
  return t;
}

std::shared_ptr<VolumeRenderer::VolumeTextures> VolumeRenderer::makeVolumeTextures(
    const AnyVolume& volume, const Prepared& prepared, size_t slabBytes, const std::function<void()>& betweenSlabs) {
  return std::visit([&](const auto& v) { return makeTexturesOf(v, prepared, slabBytes, betweenSlabs); }, volume);
}

std::shared_ptr<VolumeRenderer::VolumeTextures> VolumeRenderer::makeVolumeTextures(
    const VolumeI16& volume, const Prepared& prepared, size_t slabBytes, const std::function<void()>& betweenSlabs) {
  return makeTexturesOf(volume, prepared, slabBytes, betweenSlabs);
}

void VolumeRenderer::adoptVolumeTextures(const std::shared_ptr<VolumeTextures>& textures, const Prepared& prepared) {
  Impl& m = *impl_;
  if (!(prepared.geometry.dims == textures->geometry.dims)) throw Error("adoptVolumeTextures: prepared for another volume");
  m.context.makeCurrent();
  m.stepUpload.reset();
  deleteTexture(m.volumeTex);
  m.volumeTex = std::exchange(textures->volume, 0);
  m.valueScale = textures->valueScale;
  finishVolume(textures->geometry, prepared);
}

void VolumeRenderer::discardVolumeTextures(const std::shared_ptr<VolumeTextures>& textures) {
  impl_->context.makeCurrent();
  deleteTexture(textures->volume);
}

void VolumeRenderer::setBackwardMap(const BackwardMap* map) {
  impl_->context.makeCurrent();
  impl_->dropMapStep();
  if (!map) {
    impl_->map.reset();
    impl_->drawnMap.reset();
    impl_->snap.reset();
    impl_->twist.reset();
    impl_->output.reset();
    deleteTexture(impl_->mapTex);
    deleteTexture(impl_->attrTex);
    return;
  }
  setBackwardMap(std::make_shared<const BackwardMap>(*map));
}

void VolumeRenderer::setBackwardMap(std::shared_ptr<const BackwardMap> map) {
  if (!map) return setBackwardMap(static_cast<const BackwardMap*>(nullptr));
  impl_->context.makeCurrent();
  impl_->dropMapStep();
  validateMap(*map);
  // Never drawn again: its cells and texels go before the new ones are made (into them when
  // they have the size).
  impl_->recycleDrawnMap();
  impl_->drawnMap.reset();
  impl_->map = std::move(map);
  impl_->mapUploaded = false;
  impl_->uploadMap();
}

std::shared_ptr<const VolumeRenderer::PreparedBackwardMap> VolumeRenderer::Impl::prepareFor(
    std::shared_ptr<const BackwardMap> map, const Geometry& source, const BlockRanges& blocks, MapBuffers* reuse) {
  validateMap(*map);
  PreparedMap pm = prepareMap(*map, source);
  auto out = std::make_shared<PreparedBackwardMap>();
  out->texDims = pm.texDims;
  // The texels: node positions (source index), or the twist kernel's weights (one float per
  // stage: uploaded in place for one joint, else as RGBA; the shader reads channel s).
  const std::vector<float>& texels = pm.texels();
  const int perTexel = pm.texelFloats();
  out->channels = perTexel == 1 ? 1 : 4;
  if (perTexel == 1) {
    out->texels = texels.data();
  } else {
    // Texels written once (no zeroing pass), in parallel.
    const size_t texelCount = texels.size() / size_t(perTexel);
    out->rgbaFloats = texelCount * 4;
    if (reuse && reuse->rgba && reuse->rgbaFloats == out->rgbaFloats) out->rgba = std::move(reuse->rgba);
    else out->rgba = std::make_unique_for_overwrite<float[]>(out->rgbaFloats);
    float* rgba = out->rgba.get();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, texelCount, size_t(1) << 16), [&](const tbb::blocked_range<size_t>& r) {
      if (perTexel == 4) {
        std::copy_n(texels.data() + 4 * r.begin(), 4 * (r.end() - r.begin()), rgba + 4 * r.begin());
        return;
      }
      for (size_t t = r.begin(); t < r.end(); ++t) {
        std::copy_n(texels.data() + size_t(perTexel) * t, perTexel, rgba + 4 * t);
        std::fill(rgba + 4 * t + perTexel, rgba + 4 * t + 4, 0.f);
      }
    });
    out->texels = rgba;
  }
  // A cell's samples read its corner nodes; the twist kernel's bulge off their chords.
  MapCellSupport support{pm.texDims, 0, pm.upsampling == Upsampling::Gaussian ? 4 : 1,
                         pm.snapMarginVoxels + pm.twistMarginVoxels};
  out->cells = computeMapCells(map->grid.dims, pm.texture(), blocks, &support,
                               reuse ? std::move(reuse->boxes) : std::vector<std::array<int16_t, 6>>{});
  if (reuse) *reuse = {};
  out->snap = std::move(pm.snap);
  if (pm.twist) out->twist = TwistUniforms::of(*pm.twist, map->grid, source);
  out->output = pm.output;
  out->normalToSourceIndex = pm.normalToSourceIndex;
  out->nodeIndexToNormal = pm.nodeIndexToNormal;
  out->source = source;
  out->map = std::move(map);
  return out;
}

std::shared_ptr<const VolumeRenderer::PreparedBackwardMap> VolumeRenderer::prepareBackwardMap(
    std::shared_ptr<const BackwardMap> map, const Prepared& volume) {
  if (!map) throw Error("prepareBackwardMap: no map");
  return Impl::prepareFor(std::move(map), volume.geometry, volume.blocks);
}

void VolumeRenderer::Impl::startMapStep(std::shared_ptr<const PreparedBackwardMap> p) {
  const BackwardMap& m = *p->map;
  checkTextureSize(m.grid.dims, "backward map grid");
  checkTextureSize(p->texDims, "backward map texture");
  MapStep st;
  // The class volume (the size of the CT) only when the snap brings another one. A class
  // volume half uploaded for the map this one replaces is continued, not started over: during a
  // drag a new map comes every frame, all with the same classes.
  const RigidSnap* rs = p->snap ? m.rigidSnap.get() : nullptr;
  st.newClasses = rs && !(classTex && uploadedClasses == rs->classes.get());
  if (st.newClasses && mapStep && mapStep->newClasses &&
      mapStep->prepared->map->rigidSnap->classes == rs->classes) {
    std::swap(st.classTex, mapStep->classTex);
    st.classZ = mapStep->classZ;
  }
  dropMapStep();
  st.mapTex = mapTexture(spareMap, p->texDims, p->channels == 1 ? GL_R32F : GL_RGBA32F);
  if (!m.attributes.empty()) st.attrTex = mapTexture(spareAttr, m.grid.dims);
  if (st.newClasses && !st.classTex) {
    const Dims& d = rs->classGrid.dims;
    checkTextureSize(d, "rigid snap class volume");
    glGenTextures(1, &st.classTex);
    glBindTexture(GL_TEXTURE_3D, st.classTex);
    glTexStorage3D(GL_TEXTURE_3D, 1, GL_R16UI, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z));
    setSampling(GL_TEXTURE_3D, GL_NEAREST, GL_CLAMP_TO_EDGE, nullptr);
  }
  st.prepared = std::move(p);
  mapStep = std::move(st);
  checkGlError("backward map allocation");
}

bool VolumeRenderer::Impl::continueMapStep(size_t maxBytes) {
  MapStep& st = *mapStep;
  const PreparedBackwardMap& p = *st.prepared;
  const BackwardMap& m = *p.map;
  size_t budget = maxBytes;
  bool any = false;
  // Slices [z, z + n) of one texture, as many as the budget allows (one at least per call).
  auto slabs = [&](GLuint tex, const Dims& d, int64_t& z, size_t texelBytes, GLenum format, GLenum type,
                   const void* data) {
    const size_t slice = static_cast<size_t>(d.x * d.y) * texelBytes;
    while (z < d.z) {
      int64_t n = std::min<int64_t>(d.z - z, int64_t(std::min<size_t>(budget / slice, size_t(d.z))));
      if (n == 0) {
        if (any) return false;
        n = 1;
      }
      glBindTexture(GL_TEXTURE_3D, tex);
      glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
      glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, GLint(z), GLsizei(d.x), GLsizei(d.y), GLsizei(n), format, type,
                      static_cast<const char*>(data) + static_cast<size_t>(z) * slice);
      z += n;
      budget -= std::min(budget, static_cast<size_t>(n) * slice);
      any = true;
    }
    return true;
  };
  if (!slabs(st.mapTex, p.texDims, st.mapZ, 4 * size_t(p.channels), p.channels == 1 ? GL_RED : GL_RGBA, GL_FLOAT,
             p.texels))
    return false;
  if (st.attrTex && !slabs(st.attrTex, m.grid.dims, st.attrZ, 16, GL_RGBA, GL_FLOAT, m.attributes.data())) return false;
  if (st.newClasses && !slabs(st.classTex, m.rigidSnap->classGrid.dims, st.classZ, 2, GL_RED_INTEGER,
                              GL_UNSIGNED_SHORT, m.rigidSnap->classes->data()))
    return false;
  checkGlError("backward map upload");
  // Complete: the pending textures replace the drawn ones (kept as spares for the next map).
  retire(spareMap, mapTex, mapTexDims, mapTexFormat);
  std::swap(mapTex, st.mapTex);
  mapTexDims = p.texDims;
  mapTexFormat = p.channels == 1 ? GL_R32F : GL_RGBA32F;
  retire(spareAttr, attrTex, attrTexDims);
  std::swap(attrTex, st.attrTex);
  attrTexDims = m.grid.dims;
  if (st.newClasses) {
    deleteTexture(classTex);
    std::swap(classTex, st.classTex);
    uploadedClasses = m.rigidSnap->classes.get();
    heldClasses = m.rigidSnap->classes;
  }
  makeSkipTextures(cellSkip, p.cells.cells, nullptr);
  snap = p.snap;
  twist = p.twist;
  output = p.output;
  normalToSourceIndex = p.normalToSourceIndex;
  nodeIndexToNormal = p.nodeIndexToNormal;
  map = p.map;
  drawnMap = st.prepared;
  mapUploaded = true;
  mapStep.reset();
  checkGlError("backward map upload");
  return true;
}

namespace {
bool sameGeometry(const Geometry& a, const Geometry& b) {
  if (!(a.dims == b.dims)) return false;
  for (const Vec3& p : {Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}})
    if (norm(a.indexToPhysical(p) - b.indexToPhysical(p)) > 1e-9) return false;
  return true;
}
}  // namespace

bool VolumeRenderer::uploadBackwardMapStep(std::shared_ptr<const PreparedBackwardMap> prepared, size_t maxBytes) {
  Impl& m = *impl_;
  m.context.makeCurrent();
  if (!prepared) throw Error("uploadBackwardMapStep: no map");
  if (m.drawnMap == prepared && m.mapUploaded) return true;
  if (!m.hasVolume || !sameGeometry(prepared->source, m.source)) {
    // Prepared for another volume: the map is kept and prepared for this one when drawn.
    m.dropMapStep();
    m.map = prepared->map;
    m.mapUploaded = false;
    m.uploadMap();
    return true;
  }
  if (!m.mapStep || m.mapStep->prepared != prepared) m.startMapStep(std::move(prepared));
  return m.continueMapStep(maxBytes);
}

void VolumeRenderer::setLabelTint(const LabelTint* tint) {
  Impl& m = *impl_;
  m.context.makeCurrent();
  deleteTexture(m.labelTex);
  deleteTexture(m.labelColourTex);
  m.hasLabels = false;
  if (!tint) return;
  if (!m.hasVolume) throw Error("setLabelTint: set the volume first");
  if (!(tint->ids.dims() == m.source.dims))
    throw Error("label tint: label map " + tint->ids.dims().str() + " does not match the volume " + m.source.dims.str());
  if (tint->colours.size() != size_t(kMaxTintLabels)) throw Error("label tint: colour table must have 4096 entries");
  const Dims d = tint->ids.dims();
  // Ids below 256 (nearly every label map) as R8UI: half the texture (87 MiB less at
  // 512x512x350 on llvmpipe, where textures are the process's memory), converted a slab at a time.
  const uint16_t* ids = tint->ids.data();
  const size_t n = tint->ids.size();
  const bool bytes = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 1 << 16), true,
      [&](const tbb::blocked_range<size_t>& r, bool ok) {
        for (size_t i = r.begin(); ok && i < r.end(); ++i) ok = ids[i] < 256;
        return ok;
      },
      [](bool a, bool b) { return a && b; });
  glGenTextures(1, &m.labelTex);
  glBindTexture(GL_TEXTURE_3D, m.labelTex);
  glTexStorage3D(GL_TEXTURE_3D, 1, bytes ? GL_R8UI : GL_R16UI, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z));
  if (bytes) {
    const size_t slice = static_cast<size_t>(d.x * d.y);
    const int64_t step = std::max<int64_t>(1, int64_t((size_t(8) << 20) / slice));
    std::vector<uint8_t> slab(slice * static_cast<size_t>(std::min<int64_t>(step, d.z)));
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    for (int64_t z0 = 0; z0 < d.z; z0 += step) {
      const int64_t z1 = std::min(d.z, z0 + step);
      const uint16_t* src = ids + static_cast<size_t>(z0) * slice;
      tbb::parallel_for(tbb::blocked_range<size_t>(0, static_cast<size_t>(z1 - z0) * slice, 1 << 16),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i < r.end(); ++i) slab[i] = static_cast<uint8_t>(src[i]);
                        });
      glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, GLint(z0), GLsizei(d.x), GLsizei(d.y), GLsizei(z1 - z0), GL_RED_INTEGER,
                      GL_UNSIGNED_BYTE, slab.data());
    }
  } else {
    glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
    glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z), GL_RED_INTEGER,
                    GL_UNSIGNED_SHORT, ids);
  }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glGenTextures(1, &m.labelColourTex);
  glBindTexture(GL_TEXTURE_1D, m.labelColourTex);
  glTexStorage1D(GL_TEXTURE_1D, 1, GL_RGBA8, kMaxTintLabels);
  glTexSubImage1D(GL_TEXTURE_1D, 0, 0, kMaxTintLabels, GL_RGBA, GL_UNSIGNED_BYTE, tint->colours.data());
  glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  checkGlError("label tint upload");
  m.hasLabels = true;
}

RgbaImage VolumeRenderer::render(const RenderSettings& s) {
  checkImageSize(s.width, s.height);
  if (s.quality == Quality::Cinematic && s.preset != Preset::Mip) {
    if (!impl_->hasVolume) throw Error("render: no volume set (call setVolume first)");
    Impl& m = *impl_;
    m.context.makeCurrent();
    const auto t0 = std::chrono::steady_clock::now();
    m.beginCinematic(m.oneShot, s);
    m.addCinematicPasses(m.oneShot, s.cinematic);
    RgbaImage image = m.resolveCinematic(m.oneShot);
    m.lastMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    m.lastSamples = m.oneShot.samples;
    return image;
  }
  RgbaImage image(s.width, s.height);
  renderRows(s, 0, s.height, image);
  return image;
}

void VolumeRenderer::renderRows(const RenderSettings& s, int rowBegin, int rowEnd, RgbaImage& image) {
  checkImageSize(s.width, s.height);
  if (image.width != s.width || image.height != s.height)
    throw Error("renderRows: the image must be " + std::to_string(s.width) + "x" + std::to_string(s.height));
  rowBegin = std::clamp(rowBegin, 0, s.height);
  rowEnd = std::clamp(rowEnd, rowBegin, s.height);
  if (rowBegin == rowEnd) return;
  if (!impl_->hasVolume) throw Error("render: no volume set (call setVolume first)");
  Impl& m = *impl_;
  m.context.makeCurrent();
  m.target.bind(s.width, s.height, "render");
  const auto t0 = std::chrono::steady_clock::now();
  m.draw(s, m.target.framebuffer(), rowBegin, rowEnd, 0);
  glFinish();
  m.lastMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  checkGlError("ray casting");

  readRgbaRows(m.target.framebuffer(), rowBegin, rowEnd, image, "glReadPixels");
}

void VolumeRenderer::renderInto(const RenderSettings& s, const RenderTarget& target) {
  renderIntoRows(s, target, 0, s.height);
}

void VolumeRenderer::renderIntoRows(const RenderSettings& s, const RenderTarget& target, int rowBegin, int rowEnd) {
  renderIntoTile(s, target, 0, s.width, rowBegin, rowEnd);
}

void VolumeRenderer::renderIntoTile(const RenderSettings& s, const RenderTarget& target, int colBegin, int colEnd,
                                    int rowBegin, int rowEnd) {
  checkImageSize(s.width, s.height);
  if (target.width != s.width || target.height != s.height)
    throw Error("renderInto: the target is " + std::to_string(target.width) + "x" + std::to_string(target.height) +
                ", the settings " + std::to_string(s.width) + "x" + std::to_string(s.height));
  rowBegin = std::clamp(rowBegin, 0, s.height);
  rowEnd = std::clamp(rowEnd, rowBegin, s.height);
  colBegin = std::clamp(colBegin, 0, s.width);
  colEnd = std::clamp(colEnd, colBegin, s.width);
  if (rowBegin == rowEnd || colBegin == colEnd) return;
  if (!impl_->hasVolume) throw Error("render: no volume set (call setVolume first)");
  Impl& m = *impl_;
  m.context.makeCurrent();
  m.timer.begin();
  m.draw(s, target.framebuffer, rowBegin, rowEnd, target.opaqueDepth, colBegin, colEnd);
  m.timer.end();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  checkGlError("ray casting into a target");
}

double VolumeRenderer::lastRenderMs() const { return impl_->lastMs; }

double VolumeRenderer::lastGpuMs() const { return impl_->timer.lastMs(); }

int VolumeRenderer::lastSamples() const { return impl_->lastSamples; }

void VolumeRenderer::beginCinematic(const RenderSettings& s) { beginCinematic(s, false); }

void VolumeRenderer::beginCinematic(const RenderSettings& s, bool guideInBands) {
  checkImageSize(s.width, s.height);
  if (s.preset == Preset::Mip) throw Error("cinematic: the mip preset is not path traced");
  if (!impl_->hasVolume) throw Error("render: no volume set (call setVolume first)");
  impl_->context.makeCurrent();
  impl_->beginCinematic(impl_->progressive, s, guideInBands);
}

int VolumeRenderer::addCinematicGuideRows(int rowBegin, int rowEnd) {
  Impl& m = *impl_;
  if (!m.progressive.begun) throw Error("addCinematicGuideRows: call beginCinematic first");
  Impl::Progressive& pr = m.progressive;
  rowBegin = std::clamp(rowBegin, 0, pr.settings.height);
  rowEnd = std::clamp(rowEnd, rowBegin, pr.settings.height);
  if (pr.guideRowsLeft > 0 && rowBegin < rowEnd) {
    m.context.makeCurrent();
    m.drawGuideRows(pr, rowBegin, rowEnd);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  }
  return pr.guideRowsLeft;
}

int VolumeRenderer::addCinematicSamples(int n) { return addCinematicSamples(n, 0.0); }

int VolumeRenderer::addCinematicSamples(int n, double timeLimitS) {
  Impl& m = *impl_;
  if (!m.progressive.begun) throw Error("addCinematicSamples: call beginCinematic first");
  if (n <= 0) return m.progressive.samples;
  m.context.makeCurrent();
  Cinematic budget = m.progressive.settings.cinematic;
  budget.samples = n;
  budget.timeLimitS = std::max(0.0, timeLimitS);
  m.addCinematicPasses(m.progressive, budget);
  return m.progressive.samples;
}

int VolumeRenderer::addCinematicRows(int rowBegin, int rowEnd) {
  Impl& m = *impl_;
  if (!m.progressive.begun) throw Error("addCinematicRows: call beginCinematic first");
  const int h = m.progressive.settings.height;
  rowBegin = std::clamp(rowBegin, 0, h);
  rowEnd = std::clamp(rowEnd, rowBegin, h);
  if (rowBegin == rowEnd) return m.progressive.samples;
  m.context.makeCurrent();
  Cinematic one = m.progressive.settings.cinematic;
  one.samples = 1;
  one.timeLimitS = 0;
  m.addCinematicPasses(m.progressive, one, rowBegin, rowEnd);
  if (rowEnd == h) ++m.progressive.samples;  // every row has it now
  return m.progressive.samples;
}

RgbaImage VolumeRenderer::resolveCinematic() {
  Impl& m = *impl_;
  if (!m.progressive.begun || m.progressive.samples == 0)
    throw Error("resolveCinematic: no samples yet (beginCinematic, then addCinematicSamples)");
  m.context.makeCurrent();
  RgbaImage image = m.resolveCinematic(m.progressive);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return image;
}

int VolumeRenderer::cinematicSamples() const { return impl_->progressive.begun ? impl_->progressive.samples : 0; }

}  // namespace vellum::render
