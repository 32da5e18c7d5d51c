// Issue #22: the studio fills a new volume's 3D textures on a worker thread, on a hidden GL
// context sharing the window's objects, so that no frame waits for llvmpipe's allocation and
// copy; the view then draws exactly what the textures uploaded on the window's own context give.
#include <gtest/gtest.h>

#include <GLFW/glfw3.h>

#include <chrono>
#include <cstdlib>
#include <memory>
#include <optional>
#include <thread>

#include "studio_run.hpp"
#include "view3d.hpp"
#include "window_context.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::studio {
namespace {
using vellum::test::studio::boneScene;

// A hidden GL 4.3 core window (the studio's context kind); null when GLFW cannot make one.
GLFWwindow* hiddenWindow() {
  if (!glfwInit()) return nullptr;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
  return glfwCreateWindow(64, 64, "upload test", nullptr, nullptr);
}

// Each test: a hidden window with the studio's context, and the bone phantom's scene and CT.
class StudioUpload : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::getenv("DISPLAY")) GTEST_SKIP() << "no DISPLAY (run under xvfb-run -a)";
    window_ = hiddenWindow();
    ASSERT_NE(window_, nullptr);
    context.emplace(window_);
  }
  void TearDown() override {
    context.reset();  // the context's objects go before their window
    if (window_) glfwDestroyWindow(window_);
    glfwTerminate();
  }
  std::optional<WindowContext> context;
  Scene scene = boneScene();
  std::shared_ptr<const AnyVolume> ct = std::make_shared<const AnyVolume>(scene.ct);

 private:
  GLFWwindow* window_ = nullptr;
};

// Fills the view's textures on its worker (the first call starts it; later ones poll: waits
// on the job, not on a count; the deadline only ends a hang). True once the volume is drawn.
bool uploadOnWorker(View3D& view, const std::shared_ptr<const AnyVolume>& ct,
                    const std::shared_ptr<const render::VolumeRenderer::Prepared>& prepared) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
  while (!view.uploadVolumeStep(ct, prepared, 1 << 20))
    if (std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    else
      return false;
  return true;
}

TEST_F(StudioUpload, TexturesFilledOnTheWorkerContextDrawTheSamePicture) {
  auto prepared = render::VolumeRenderer::prepare(*ct);
  View3D view(*context);
  EXPECT_FALSE(view.uploadVolumeStep(ct, prepared, 1 << 20));  // starts the worker, not done at once
  ASSERT_TRUE(uploadOnWorker(view, ct, prepared));
  const int w = 60, h = 44;
  const RgbaImage fromWorker = view.renderImage(scene, w, h);
  view.setVolume(scene.ct);  // the same volume uploaded on the window's context
  const RgbaImage onWindow = view.renderImage(scene, w, h);
  ASSERT_EQ(fromWorker.width, w);
  EXPECT_TRUE(fromWorker.pixels == onWindow.pixels) << "the worker's textures draw another picture";
  size_t differ = 0;  // the picture shows the phantom, not only the background
  for (size_t i = 0; i + 4 <= fromWorker.pixels.size(); i += 4)
    differ += fromWorker.pixels[i] != fromWorker.pixels[0] || fromWorker.pixels[i + 1] != fromWorker.pixels[1];
  EXPECT_GT(differ, size_t(w * h / 20));
}

// The view at rest, refined (waits on the view's state; the deadline only ends a hang).
RgbaImage refinedPicture(View3D& view, const Scene& scene, int w, int h) {
  view.invalidate();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
  do view.update(scene, w, h, false);
  while (!view.refined() && std::chrono::steady_clock::now() < deadline);
  EXPECT_TRUE(view.refined());
  return view.readShown();
}

// The Loader prepares the 3D view without the light source (21 MiB at 512^2 x 350); switching
// shadows on makes it on a worker and the view then draws what a renderer prepared with the
// light at once draws.
TEST_F(StudioUpload, LightSourceMadeOnDemandDrawsThePictureOfOnePreparedWithIt) {
  auto prepared = render::VolumeRenderer::prepare(*ct, false);  // as the Loader does
  View3D view(*context);
  ASSERT_TRUE(uploadOnWorker(view, ct, prepared));
  // Lighting off: no light source made or held.
  view.stepLight(scene);
  EXPECT_FALSE(view.lightPending());
  EXPECT_FALSE(view.hasLight());
  EXPECT_FALSE(view.unlit(scene));

  scene.render.lighting.shadows = 1;
  scene.render.lighting.occlusion = 0.6;
  const int w = 60, h = 44;
  EXPECT_TRUE(view.unlit(scene));
  const RgbaImage unlit = refinedPicture(view, scene, w, h);  // before the light is asked for
  view.stepLight(scene);
  EXPECT_TRUE(view.lightPending());
  const auto lightDeadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
  while (view.lightPending() && std::chrono::steady_clock::now() < lightDeadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    view.stepLight(scene);  // adopts the worker's light source once made
  }
  ASSERT_TRUE(view.hasLight());
  EXPECT_FALSE(view.unlit(scene));
  const RgbaImage lit = refinedPicture(view, scene, w, h);

  View3D atOnce(*context);
  atOnce.setVolume(scene.ct);  // prepared with the light source, as before on demand
  const RgbaImage expected = refinedPicture(atOnce, scene, w, h);
  ASSERT_EQ(lit.width, w);
  ASSERT_EQ(expected.width, w);
  EXPECT_TRUE(lit.pixels == expected.pixels) << "the light made on demand draws another picture";
  EXPECT_FALSE(unlit.pixels == lit.pixels) << "shadows and occlusion changed nothing: the test shows nothing";
}

}  // namespace
}  // namespace vellum::studio
