#pragma once
// The test program's one headless GL context (EGL surfaceless on llvmpipe), made on first use
// and kept for the program's life: every GL test of a program draws in it.
#include "vellum/render/gl_context.hpp"

namespace vellum::test {

render::GlContext& headlessGl();

}  // namespace vellum::test
