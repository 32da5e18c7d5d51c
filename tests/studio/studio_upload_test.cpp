// Issue #22: the studio fills a new volume's 3D textures on a worker thread, on a hidden GL
// context sharing the window's objects, so that no frame waits for llvmpipe's allocation and
// copy; the view then draws exactly what the textures uploaded on the window's own context give.
#include <gtest/gtest.h>

#include <GLFW/glfw3.h>

#include <chrono>
#include <cstdlib>
#include <memory>
#include <thread>

#include "studio_run.hpp"
#include "view3d.hpp"
#include "window_context.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::studio {
namespace {
using vellum::test::studio::boneScene;

TEST(StudioUpload, TexturesFilledOnTheWorkerContextDrawTheSamePicture) {
  if (!std::getenv("DISPLAY")) GTEST_SKIP() << "no DISPLAY (run under xvfb-run -a)";
  ASSERT_TRUE(glfwInit());
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
  GLFWwindow* window = glfwCreateWindow(64, 64, "upload test", nullptr, nullptr);
  ASSERT_NE(window, nullptr);
  {
    WindowContext context(window);
    Scene scene = boneScene();
    auto ct = std::make_shared<const AnyVolume>(scene.ct);
    auto prepared = render::VolumeRenderer::prepare(*ct);
    View3D view(context);
    // The first call starts the worker; later ones poll it (wait on the job, not on a count).
    EXPECT_FALSE(view.uploadVolumeStep(ct, prepared, 1 << 20));
    bool done = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
    while (!(done = view.uploadVolumeStep(ct, prepared, 1 << 20)) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_TRUE(done);
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
  glfwDestroyWindow(window);
  glfwTerminate();
}

}  // namespace
}  // namespace vellum::studio
