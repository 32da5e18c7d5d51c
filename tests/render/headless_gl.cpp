#include "headless_gl.hpp"

#include <memory>

namespace vellum::test {

render::GlContext& headlessGl() {
  static std::unique_ptr<render::GlContext> context = render::GlContext::createHeadless();
  return *context;
}

}  // namespace vellum::test
