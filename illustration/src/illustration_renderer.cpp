// GL illustration ray caster: scene uploaded once, style table per render, one program per
// shader variant.
#include "vellum/illustration/illustration_renderer.hpp"

#include <bit>
#include <chrono>
#include <cstring>
#include <map>

#include "gl_util.hpp"        // modules/render: buildProgram, checkGlError, readRgbaRows
#include "illustration_renderer_common.hpp"
#include "illustration_renderer_shader.hpp"
#include "image_refine.hpp"
#include "render_common.hpp"  // modules/render: makeFrame (same camera and rays)
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::illustration {

using namespace detail;
using render::detail::buildProgram;
using render::detail::checkGlError;
using render::detail::readRgbaRows;

namespace {

enum Unit : GLint { kUnitFields = 0, kUnitStyle, kUnitOcc, kUnitCt, kUnitTf, kUnitTexVol };

// The caster draws one triangle over the whole image, or a refinement level's tiles as 4 x 4
// points (clip space): llvmpipe shades a point aligned to its 4 x 4 block once, where the two
// triangles of a quad would each shade every block their diagonal crosses.
constexpr const char* kRectVertexShader = R"(#version 450 core
layout(location = 0) in vec2 aPos;
void main() {
  gl_Position = vec4(aPos, 0.0, 1.0);
  gl_PointSize = 4.0;
}
)";

/// A refinement level's float target: straight RGBA (location 0) and nearOut (location 1).
struct LevelTarget {
  GLuint fbo = 0, colour = 0, near = 0;
  int width = 0, height = 0;
  void bind(int w, int h) {
    if (!fbo || w != width || h != height) {
      release();
      glGenFramebuffers(1, &fbo);
      glBindFramebuffer(GL_FRAMEBUFFER, fbo);
      glGenRenderbuffers(1, &colour);
      glBindRenderbuffer(GL_RENDERBUFFER, colour);
      glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA32F, w, h);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour);
      glGenRenderbuffers(1, &near);
      glBindRenderbuffer(GL_RENDERBUFFER, near);
      glRenderbufferStorage(GL_RENDERBUFFER, GL_R32F, w, h);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_RENDERBUFFER, near);
      if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw Error("illustrate: float render target " + std::to_string(w) + "x" + std::to_string(h) + " incomplete");
      width = w;
      height = h;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    const GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, bufs);
  }
  void release() {
    if (fbo) glDeleteFramebuffers(1, &fbo);
    for (GLuint* r : {&colour, &near})
      if (*r) glDeleteRenderbuffers(1, r);
    fbo = colour = near = 0;
    width = height = 0;
  }
};

void params(GLenum target, GLint filter, GLint wrap) {
  glTexParameteri(target, GL_TEXTURE_MIN_FILTER, filter);
  glTexParameteri(target, GL_TEXTURE_MAG_FILTER, filter);
  glTexParameteri(target, GL_TEXTURE_WRAP_S, wrap);
  glTexParameteri(target, GL_TEXTURE_WRAP_T, wrap);
  glTexParameteri(target, GL_TEXTURE_WRAP_R, wrap);
}

void del(GLuint& t) {
  if (t) glDeleteTextures(1, &t);
  t = 0;
}

GLuint make3d(GLenum internal, const Dims& d, GLenum format, GLenum type, const void* data, GLint filter, GLint wrap) {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_3D, t);
  glTexStorage3D(GL_TEXTURE_3D, 1, internal, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (data) glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(d.x), GLsizei(d.y), GLsizei(d.z), format, type, data);
  params(GL_TEXTURE_3D, filter, wrap);
  return t;
}

void u3(GLuint p, const char* n, const Vec3& v) { glUniform3f(glGetUniformLocation(p, n), float(v.x), float(v.y), float(v.z)); }
void u3(GLuint p, const char* n, const Vec3f& v) { glUniform3f(glGetUniformLocation(p, n), v.x, v.y, v.z); }
void u1(GLuint p, const char* n, double v) { glUniform1f(glGetUniformLocation(p, n), float(v)); }
void m3(GLuint p, const char* n, const Mat3& m) {
  float a[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a[r * 3 + c] = float(m(r, c));
  glUniformMatrix3fv(glGetUniformLocation(p, n), 1, GL_TRUE, a);
}

}  // namespace

struct IllustrationRenderer::Impl {
  render::GlContext& context;
  GLuint fieldTex = 0, styleTex = 0, occTex = 0, ctTex = 0, tfTex = 0, texVolTex = 0;
  GLuint vao = 0, vbo = 0;
  std::vector<LevelTarget> levelTargets;  ///< per refinement level (image_refine.hpp)
  render::detail::OffscreenTarget target;  ///< destroyed after the body of ~Impl, context still current
  bool hasScene = false;
  Geometry geometry;
  std::vector<Label> table;  // label table and largest id (style resolution)
  int maxId = 0;
  BlockFields blocks;
  std::vector<PaintSlot> slots;
  std::optional<AnyVolume> ct;
  bool ctUploaded = false;
  std::string texVolPath;
  Dims texVolDims;
  std::map<std::string, GLuint> programs;
  double lastMs = 0, uploadMs = 0;
  RefineStats lastStats;
  int64_t lastPixels = 0;

  explicit Impl(render::GlContext& c) : context(c) {
    context.makeCurrent();
    glGenVertexArrays(1, &vao);
    glGenBuffers(1, &vbo);
    glBindVertexArray(vao);
    glBindBuffer(GL_ARRAY_BUFFER, vbo);
    glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
    glEnableVertexAttribArray(0);
    glBindVertexArray(0);
    glGenTextures(1, &styleTex);
    glBindTexture(GL_TEXTURE_2D, styleTex);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, kRowTexels, kMaxLabels);
    params(GL_TEXTURE_2D, GL_NEAREST, GL_CLAMP_TO_EDGE);
    glGenTextures(1, &tfTex);
    glBindTexture(GL_TEXTURE_1D, tfTex);
    glTexStorage1D(GL_TEXTURE_1D, 1, GL_RGBA32F, kTfSize);
    glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    checkGlError("illustration renderer set-up");
  }
  ~Impl() {
    context.makeCurrent();
    for (auto& [k, p] : programs) glDeleteProgram(p);
    for (GLuint* t : {&fieldTex, &styleTex, &occTex, &ctTex, &tfTex, &texVolTex}) del(*t);
    for (LevelTarget& l : levelTargets) l.release();
    glDeleteBuffers(1, &vbo);
    glDeleteVertexArrays(1, &vao);
  }

  GLuint program(const ShaderVariant& v) {
    auto it = programs.find(v.key());
    if (it != programs.end()) return it->second;
    const GLuint p = buildProgram(kRectVertexShader, illustrationFragmentSource(v));
    glUseProgram(p);
    const std::pair<const char*, GLint> units[] = {{"uFields", kUnitFields}, {"uStyle", kUnitStyle},
                                                   {"uOccupancy", kUnitOcc}, {"uCt", kUnitCt}, {"uTf", kUnitTf},
                                                   {"uTexVol", kUnitTexVol}};
    for (const auto& [name, unit] : units) glUniform1i(glGetUniformLocation(p, name), unit);
    programs[v.key()] = p;
    return p;
  }

  void uploadCt() {  // lazily: only styles that use the CT pay for it
    if (ctUploaded) return;
    const Volume4 c = computeCtGradient(*ct);
    del(ctTex);
    ctTex = make3d(GL_RGBA16F, c.dims, GL_RGBA, GL_HALF_FLOAT, c.half.data(), GL_LINEAR, GL_CLAMP_TO_EDGE);
    computeBlockCtRange(blocks, *ct);
    checkGlError("CT upload");
    ctUploaded = true;
  }

  void uploadTextureVolume(const std::string& path) {
    if (texVolTex && texVolPath == path) return;
    const TextureVolume t = loadTextureVolume(path);
    del(texVolTex);
    texVolTex = make3d(GL_R32F, t.dims, GL_RED, GL_FLOAT, t.value.data(), GL_LINEAR, GL_REPEAT);
    texVolPath = path;
    texVolDims = t.dims;
    checkGlError("texture volume upload");
  }
};

IllustrationRenderer::IllustrationRenderer(render::GlContext& context) : impl_(std::make_unique<Impl>(context)) {}
IllustrationRenderer::~IllustrationRenderer() = default;
double IllustrationRenderer::lastRenderMs() const { return impl_->lastMs; }
double IllustrationRenderer::lastUploadMs() const { return impl_->uploadMs; }
double IllustrationRenderer::lastTracedFraction() const {
  return impl_->lastStats.traced > 0 && impl_->lastPixels > 0 ? double(impl_->lastStats.traced) / double(impl_->lastPixels) : 0.0;
}

void IllustrationRenderer::setScene(const ShapeScene& scene) {
  validateScene(scene);
  Impl& m = *impl_;
  m.context.makeCurrent();
  const auto t0 = std::chrono::steady_clock::now();
  m.hasScene = false;
  const Dims d = scene.grid().dims;
  GLint max3d = 0;
  glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
  if (d.x > max3d || d.y > max3d || d.z > max3d)
    throw Error("illustrate: volume of " + d.str() + " exceeds the GL 3D texture limit of " + std::to_string(max3d));
  // Per-segment distances: four a RGBA16_SNORM texel, groups stacked along z, uploaded in
  // slabs (no whole-volume staging copy).
  const FieldVolume fv = makeFieldVolume(scene, false);
  const int groups = std::max(fv.groups, 1);
  if (d.z * groups > max3d)
    throw Error("illustrate: " + std::to_string(scene.fields.size()) + " segments of " + d.str() +
                " exceed the GL 3D texture limit of " + std::to_string(max3d) + " slices (" +
                std::to_string(groups) + " groups of 4 stacked)");
  del(m.fieldTex);
  del(m.occTex);
  del(m.ctTex);
  m.fieldTex = make3d(GL_RGBA16_SNORM, Dims{d.x, d.y, d.z * groups}, GL_RGBA, GL_SHORT, nullptr, GL_LINEAR,
                      GL_CLAMP_TO_EDGE);
  {
    std::vector<int16_t> slab;
    const int64_t slabZ = std::max<int64_t>(1, (int64_t(1) << 22) / std::max<int64_t>(d.x * d.y, 1));
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    for (int g = 0; g < groups; ++g)
      for (int64_t z0 = 0; z0 < d.z; z0 += slabZ) {
        const int64_t z1 = std::min(d.z, z0 + slabZ);
        packFieldSlab(scene, g, z0, z1, slab);
        glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, GLint(g * d.z + z0), GLsizei(d.x), GLsizei(d.y), GLsizei(z1 - z0),
                        GL_RGBA, GL_SHORT, slab.data());
      }
  }
  m.slots = fv.slots;
  m.blocks = computeBlockFields(scene);
  m.occTex = make3d(GL_R8, m.blocks.blocks, GL_RED, GL_UNSIGNED_BYTE, nullptr, GL_NEAREST, GL_CLAMP_TO_EDGE);
  checkGlError("scene upload");
  m.geometry = scene.grid();
  m.table = scene.segments.table();
  m.maxId = scene.segments.maxId();
  m.ct = scene.ct;
  m.ctUploaded = false;
  m.hasScene = true;
  glFinish();
  m.uploadMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

RgbaImage IllustrationRenderer::render(const Style& style, const IllustrationSettings& settings) {
  Impl& m = *impl_;
  if (!m.hasScene) throw Error("illustrate: no scene set (call setScene first)");
  m.context.makeCurrent();
  const auto& s = settings.render;
  const render::detail::Frame f = render::detail::makeFrame(m.geometry, nullptr, s);
  const StyleTable table = packStyle(style, m.table, m.maxId, m.geometry);
  ShaderVariant v;
  v.eight = settings.interpolation == Interpolation::Eight;
  v.texture = table.usesTexture;
  v.textureVolume = table.usesTextureVolume;
  v.ct = table.usesCt;
  v.slots = int(m.slots.size());
  v.ink = table.usesInk;
  paintItems(table, m.slots, v.items, v.inkSlots);
  if (v.ct) {
    if (!m.ct) throw Error("illustrate: style '" + style.name + "' uses the CT (illum = ct or boundary_measure = ct) but no CT was given");
    m.uploadCt();
  }
  if (v.textureVolume) {
    if (style.textureVolume.empty()) throw Error("illustrate: style '" + style.name + "' has texture = volume rows but no texture_volume");
    m.uploadTextureVolume(style.textureVolume);
  }
  const SampleFrame sf = makeSampleFrame(m.geometry, f, table);
  const bool newProgram = !m.programs.count(v.key());
  const GLuint p = m.program(v);
  m.target.bind(s.width, s.height, "illustrate");
  glUseProgram(p);

  glBindTexture(GL_TEXTURE_2D, m.styleTex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, kRowTexels, kMaxLabels, GL_RGBA, GL_FLOAT, table.texels.data());
  const std::vector<uint8_t> occ =
      occupancyTexels(blockOccupancy(m.blocks, table, m.slots, sf.coverageH, sf.inkReachMm, sf.inkLineMm), m.blocks.blocks);
  glBindTexture(GL_TEXTURE_3D, m.occTex);
  glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, GLsizei(m.blocks.blocks.x), GLsizei(m.blocks.blocks.y),
                  GLsizei(m.blocks.blocks.z), GL_RED, GL_UNSIGNED_BYTE, occ.data());
  glBindTexture(GL_TEXTURE_1D, m.tfTex);
  glTexSubImage1D(GL_TEXTURE_1D, 0, 0, kTfSize, GL_RGBA, GL_FLOAT, table.tf.data());

  const std::pair<GLint, std::pair<GLenum, GLuint>> binds[] = {
      {kUnitFields, {GL_TEXTURE_3D, m.fieldTex}},
      {kUnitStyle, {GL_TEXTURE_2D, m.styleTex}},  {kUnitOcc, {GL_TEXTURE_3D, m.occTex}},
      {kUnitCt, {GL_TEXTURE_3D, m.ctTex}},        {kUnitTf, {GL_TEXTURE_1D, m.tfTex}},
      {kUnitTexVol, {GL_TEXTURE_3D, m.texVolTex}}};
  for (const auto& [unit, tb] : binds) {
    glActiveTexture(GL_TEXTURE0 + unit);
    glBindTexture(tb.first, tb.second);
  }
  glActiveTexture(GL_TEXTURE0);

  glUniform2f(glGetUniformLocation(p, "uViewport"), float(s.width), float(s.height));
  u3(p, "uEye", f.eye);
  u3(p, "uRight", f.right);
  u3(p, "uUp", f.up);
  u3(p, "uForward", f.forward);
  glUniform2f(glGetUniformLocation(p, "uHalf"), float(f.halfW), float(f.halfH));
  u1(p, "uPersp", f.perspective ? 1.0 : 0.0);
  m3(p, "uPhysToBox", f.physToBox);
  const Geometry& g = m.geometry;
  m3(p, "uBoxToPhys", g.direction * Mat3::fromColumns({g.spacing.x, 0, 0}, {0, g.spacing.y, 0}, {0, 0, g.spacing.z}));
  u3(p, "uBoxOrigin", f.box.origin);
  u3(p, "uBoxDims", Vec3{double(g.dims.x), double(g.dims.y), double(g.dims.z)});
  u1(p, "uStep", f.stepMm);
  u1(p, "uJitter", s.jitter ? 1.0 : 0.0);
  glUniform4f(glGetUniformLocation(p, "uBackground"), s.background[0], s.background[1], s.background[2], s.background[3]);
  u3(p, "uLight", sf.light);
  u3(p, "uCentre", sf.centre);
  u1(p, "uRadius", sf.radius);
  u1(p, "uCoverageH", sf.coverageH);
  glUniform2f(glGetUniformLocation(p, "uPixMm"), sf.pixMm0, sf.pixMm1);
  glUniform3i(glGetUniformLocation(p, "uBlocks"), GLint(m.blocks.blocks.x), GLint(m.blocks.blocks.y), GLint(m.blocks.blocks.z));
  {
    std::vector<float> slots(std::max<size_t>(m.slots.size(), 1) * 4, 0.f);
    for (size_t i = 0; i < m.slots.size(); ++i) {
      slots[i * 4] = float(m.slots[i].id);
      slots[i * 4 + 1] = float(m.slots[i].shellId);
      slots[i * 4 + 2] = m.slots[i].shellMm;
    }
    if (!m.slots.empty()) glUniform4fv(glGetUniformLocation(p, "uSlots"), GLsizei(m.slots.size()), slots.data());
    glUniformMatrix3fv(glGetUniformLocation(p, "uGradToPhys"), 1, GL_TRUE, sf.gradToPhys.data());
    std::vector<float> lo, hi;
    gradientWindows(table, m.slots, sf.coverageH, lo, hi);
    glUniform4fv(glGetUniformLocation(p, "uGradLo"), GLsizei(lo.size() / 4), lo.data());
    glUniform4fv(glGetUniformLocation(p, "uGradHi"), GLsizei(hi.size() / 4), hi.data());
    std::vector<float> so, si;
    skipBands(table, m.slots, sf.coverageH, sf.inkPassMm, skipMarginMm(g), so, si);
    for (std::vector<float>* v : {&so, &si})  // GLSL floats: inf as a large finite value
      for (float& x : *v) x = std::clamp(x, -1e30f, 1e30f);
    glUniform4fv(glGetUniformLocation(p, "uSkipOut"), GLsizei(so.size() / 4), so.data());
    glUniform4fv(glGetUniformLocation(p, "uSkipIn"), GLsizei(si.size() / 4), si.data());
    u1(p, "uSkipOn", settings.adaptiveStep ? 1.0 : 0.0);
    float axes[9];
    for (int l = 0; l < 3; ++l) {
      axes[l * 3] = sf.hatchAxis[l].x;
      axes[l * 3 + 1] = sf.hatchAxis[l].y;
      axes[l * 3 + 2] = sf.hatchAxis[l].z;
    }
    glUniform3fv(glGetUniformLocation(p, "uHatchAxis"), 3, axes);
    u1(p, "uHatchPixMm", sf.hatchPixMm);
    u1(p, "uCreaseProbeMm", sf.creaseProbeMm);
  }
  u1(p, "uTfLo", table.tfLo);
  u1(p, "uTfHi", table.tfHi);
  u3(p, "uTexDims", Vec3{double(m.texVolDims.x), double(m.texVolDims.y), double(m.texVolDims.z)});

  glDisable(GL_BLEND);
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_PROGRAM_POINT_SIZE);
  glBindVertexArray(m.vao);
  glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
  std::vector<float> verts;
  auto draw = [&](GLenum mode) {
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(verts.size() * sizeof(float)), verts.data(), GL_STREAM_DRAW);
    glDrawArrays(mode, 0, GLsizei(verts.size() / 2));
    glFinish();
  };
  const std::vector<float> wholeImage{-1.f, -1.f, 3.f, -1.f, -1.f, 3.f};
  const GLint locSpacing = glGetUniformLocation(p, "uLevelSpacing"), locRows = glGetUniformLocation(p, "uLevelRows");
  glBindFramebuffer(GL_FRAMEBUFFER, m.target.framebuffer());
  if (newProgram) {  // llvmpipe compiles at the first draw: keep that out of lastRenderMs
    glViewport(0, 0, 1, 1);
    glUniform1i(locSpacing, 1);
    glUniform1i(locRows, 1);
    verts = wholeImage;
    draw(GL_TRIANGLES);
  }
  const auto t0 = std::chrono::steady_clock::now();
  RgbaImage image(s.width, s.height);
  m.lastStats = {};
  m.lastPixels = int64_t(s.width) * s.height;
  if (settings.refineLevels <= 0) {  // a ray through every pixel, straight into the RGBA8 target
    glViewport(0, 0, s.width, s.height);
    glUniform1i(locSpacing, 1);
    glUniform1i(locRows, s.height);
    verts = wholeImage;
    draw(GL_TRIANGLES);
    checkGlError("illustration ray casting");
    readRgbaRows(m.target.framebuffer(), 0, s.height, image, "glReadPixels");
    m.lastStats.traced = int64_t(s.width) * s.height;
  } else {
    // Image-space refinement: each level's tile runs drawn into its float target, read back.
    std::vector<float> rgba, near;
    image = refineImage(
        s.width, s.height, settings.refineLevels, settings.refineTolerance,
        [&](RefineLevel& l, const std::vector<TileRun>& runs) {
          const size_t k = size_t(std::countr_zero(unsigned(l.spacing)));
          if (m.levelTargets.size() <= k) m.levelTargets.resize(k + 1);
          m.levelTargets[k].bind(l.nx, l.ny);
          glViewport(0, 0, l.nx, l.ny);
          glUniform1i(locSpacing, l.spacing);
          glUniform1i(locRows, l.ny);
          verts.clear();
          for (const TileRun& r : runs)  // tile (a, y): GL pixels [4a, 4a + 4) x [ny - 4y - 4, ny - 4y)
            for (int a = r.x0; a < r.x1; ++a) {
              verts.push_back(2.f * float(4 * a + 2) / float(l.nx) - 1.f);
              verts.push_back(2.f * float(l.ny - 4 * r.y - 2) / float(l.ny) - 1.f);
            }
          draw(GL_POINTS);
          checkGlError("illustration ray casting");
          // Read back the rows the runs cover (GL rows bottom up).
          const int jLo = 4 * runs.front().y, jHi = 4 * runs.back().y + 4;
          const int rows = jHi - jLo;
          rgba.resize(size_t(l.nx) * size_t(rows) * 4);
          near.resize(size_t(l.nx) * size_t(rows));
          glPixelStorei(GL_PACK_ALIGNMENT, 4);
          glReadBuffer(GL_COLOR_ATTACHMENT0);
          glReadPixels(0, l.ny - jHi, l.nx, rows, GL_RGBA, GL_FLOAT, rgba.data());
          glReadBuffer(GL_COLOR_ATTACHMENT1);
          glReadPixels(0, l.ny - jHi, l.nx, rows, GL_RED, GL_FLOAT, near.data());
          checkGlError("illustration level read-back");
          for (const TileRun& r : runs)
            for (int j = 4 * r.y; j < 4 * r.y + 4; ++j) {
              const size_t src = size_t(jHi - 1 - j) * size_t(l.nx), dst = size_t(j) * size_t(l.nx);
              const size_t i0 = size_t(4 * r.x0), i1 = size_t(4 * r.x1);
              std::copy(rgba.begin() + std::ptrdiff_t((src + i0) * 4), rgba.begin() + std::ptrdiff_t((src + i1) * 4),
                        l.rgba.begin() + std::ptrdiff_t((dst + i0) * 4));
              std::copy(near.begin() + std::ptrdiff_t(src + i0), near.begin() + std::ptrdiff_t(src + i1),
                        l.near.begin() + std::ptrdiff_t(dst + i0));
            }
        },
        &m.lastStats);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  }
  m.lastMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return image;
}

}  // namespace vellum::illustration
