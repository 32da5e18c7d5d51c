// Opaque meshes into colour + linear ray-distance depth (render_target.hpp's convention).
#include "vellum/render/mesh_renderer.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "gl_util.hpp"
#include "render_common.hpp"
#include "vellum/core/error.hpp"
#include "vellum_render_glsl.hpp"  // generated from ../shaders/*.glsl

namespace vellum::render {

using namespace detail;

namespace {

std::string meshFragmentSource() {
  std::ostringstream s;
  s.precision(9);
  s << "#version 450 core\n" << std::showpoint;
  s << "#define AMBIENT " << kAmbient << "\n#define DIFFUSE " << kDiffuse << "\n";
  s << "#define SPECULAR " << kSpecular << "\n#define SHININESS " << kShininess << "\n";
  s << "#define DEPTH_RANGE_MM " << kOpaqueDepthRangeMm << "\n";
  s << glsl::kMeshFrag;
  return s.str();
}

void checkMesh(const SurfaceMesh& m, size_t index) {
  const std::string name = "mesh " + std::to_string(index);
  if (m.positionsMm.size() % 3) throw Error(name + ": position count is not a multiple of 3");
  if (m.triangles.size() % 3) throw Error(name + ": index count is not a multiple of 3");
  const size_t vertices = m.positionsMm.size() / 3;
  for (uint32_t i : m.triangles)
    if (i >= vertices)
      throw Error(name + ": vertex index " + std::to_string(i) + " out of range (" + std::to_string(vertices) + " vertices)");
}

}  // namespace

std::vector<float> vertexNormals(const SurfaceMesh& mesh) {
  std::vector<float> n(mesh.positionsMm.size(), 0.f);
  const float* p = mesh.positionsMm.data();
  for (size_t t = 0; t + 2 < mesh.triangles.size(); t += 3) {
    const uint32_t a = mesh.triangles[t], b = mesh.triangles[t + 1], c = mesh.triangles[t + 2];
    const Vec3 pa{p[3 * a], p[3 * a + 1], p[3 * a + 2]}, pb{p[3 * b], p[3 * b + 1], p[3 * b + 2]},
        pc{p[3 * c], p[3 * c + 1], p[3 * c + 2]};
    const Vec3 face = cross(pb - pa, pc - pa);  // length = twice the area: area weighting
    for (uint32_t v : {a, b, c})
      for (int k = 0; k < 3; ++k) n[3 * v + size_t(k)] += float(face[k]);
  }
  for (size_t v = 0; v < n.size(); v += 3) {
    const float len = std::sqrt(n[v] * n[v] + n[v + 1] * n[v + 1] + n[v + 2] * n[v + 2]);
    if (len > 0)
      for (int k = 0; k < 3; ++k) n[v + size_t(k)] /= len;
  }
  return n;
}

struct MeshRenderer::Impl {
  GlContext& context;
  GLuint program = 0, vao = 0, vertexBuffer = 0, indexBuffer = 0;
  struct Range {
    size_t firstIndex = 0, indexCount = 0;
    GLint baseVertex = 0;
    std::array<float, 3> rgb{};
  };
  std::vector<Range> ranges;
  mutable GpuTimer timer;

  explicit Impl(GlContext& c) : context(c) {
    context.makeCurrent();
    program = buildProgram(glsl::kMeshVert, meshFragmentSource());
    glGenVertexArrays(1, &vao);
    glGenBuffers(1, &vertexBuffer);
    glGenBuffers(1, &indexBuffer);
    glBindVertexArray(vao);
    glBindBuffer(GL_ARRAY_BUFFER, vertexBuffer);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, indexBuffer);  // recorded in the VAO
    glEnableVertexAttribArray(0);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));
    glBindVertexArray(0);
    checkGlError("mesh renderer set-up");
  }

  ~Impl() {
    context.makeCurrent();
    glDeleteBuffers(1, &vertexBuffer);
    glDeleteBuffers(1, &indexBuffer);
    glDeleteVertexArrays(1, &vao);
    glDeleteProgram(program);
  }
};

MeshRenderer::MeshRenderer(GlContext& context) : impl_(std::make_unique<Impl>(context)) {}
MeshRenderer::~MeshRenderer() = default;

void MeshRenderer::setMeshes(const std::vector<SurfaceMesh>& meshes) {
  std::vector<float> vertices;  // interleaved position, normal
  std::vector<uint32_t> indices;
  std::vector<Impl::Range> ranges;
  for (size_t i = 0; i < meshes.size(); ++i) {
    const SurfaceMesh& m = meshes[i];
    checkMesh(m, i);
    const std::vector<float> normals = vertexNormals(m);
    ranges.push_back({indices.size(), m.triangles.size(), GLint(vertices.size() / 6), m.rgb});
    for (size_t v = 0; v < m.positionsMm.size(); v += 3) {
      vertices.insert(vertices.end(), m.positionsMm.begin() + long(v), m.positionsMm.begin() + long(v) + 3);
      vertices.insert(vertices.end(), normals.begin() + long(v), normals.begin() + long(v) + 3);
    }
    indices.insert(indices.end(), m.triangles.begin(), m.triangles.end());
  }
  Impl& s = *impl_;
  s.context.makeCurrent();
  glBindBuffer(GL_ARRAY_BUFFER, s.vertexBuffer);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(vertices.size() * sizeof(float)), vertices.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.indexBuffer);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(indices.size() * sizeof(uint32_t)), indices.data(), GL_STATIC_DRAW);
  checkGlError("mesh upload");
  s.ranges = std::move(ranges);
}

size_t MeshRenderer::meshCount() const { return impl_->ranges.size(); }

void MeshRenderer::draw(const Projection& camera, FramebufferTarget& target, const std::vector<bool>& visible,
                        double depthBiasMm) {
  if (camera.width() != target.width() || camera.height() != target.height())
    throw Error("mesh renderer: the camera is " + std::to_string(camera.width()) + "x" + std::to_string(camera.height()) +
                ", the target " + std::to_string(target.width()) + "x" + std::to_string(target.height()));
  Impl& s = *impl_;
  s.context.makeCurrent();
  // z only decides clipping, which GL_DEPTH_CLAMP turns off; the depth test uses gl_FragDepth.
  const std::array<double, 16> vp = camera.viewProjectionGl(1.0, kOpaqueDepthRangeMm);
  float m[16];
  for (int i = 0; i < 16; ++i) m[i] = float(vp[size_t(i)]);
  glUseProgram(s.program);
  glUniformMatrix4fv(glGetUniformLocation(s.program, "uViewProjection"), 1, GL_FALSE, m);
  const Vec3& eye = camera.eye();
  const Vec3& fwd = camera.viewDirection();
  glUniform3f(glGetUniformLocation(s.program, "uEye"), float(eye.x), float(eye.y), float(eye.z));
  glUniform3f(glGetUniformLocation(s.program, "uForward"), float(fwd.x), float(fwd.y), float(fwd.z));
  glUniform1f(glGetUniformLocation(s.program, "uPersp"), camera.perspective() ? 1.f : 0.f);
  glUniform1f(glGetUniformLocation(s.program, "uDepthBias"), float(depthBiasMm));
  const GLint rgbLocation = glGetUniformLocation(s.program, "uRgb");
  glBindFramebuffer(GL_FRAMEBUFFER, target.opaqueFramebuffer());
  glViewport(0, 0, target.width(), target.height());
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);  // two-sided: open or inverted meshes still occlude
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glEnable(GL_DEPTH_CLAMP);
  glBindVertexArray(s.vao);
  s.timer.begin();
  for (size_t i = 0; i < s.ranges.size(); ++i) {
    if (!visible.empty() && (i >= visible.size() || !visible[i])) continue;
    const Impl::Range& r = s.ranges[i];
    glUniform3f(rgbLocation, r.rgb[0], r.rgb[1], r.rgb[2]);
    glDrawElementsBaseVertex(GL_TRIANGLES, GLsizei(r.indexCount), GL_UNSIGNED_INT,
                             reinterpret_cast<void*>(r.firstIndex * sizeof(uint32_t)), r.baseVertex);
  }
  s.timer.end();
  glBindVertexArray(0);
  glDisable(GL_DEPTH_CLAMP);
  glDisable(GL_DEPTH_TEST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  checkGlError("mesh draw");
}

double MeshRenderer::lastDrawMs() const { return impl_->timer.lastMs(); }

}  // namespace vellum::render
