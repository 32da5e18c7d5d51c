#pragma once
// Small OpenGL helpers for the renderer (include only from .cpp files of modules/render).
#define GL_GLEXT_PROTOTYPES
#include <GL/glcorearb.h>

#include <string>

namespace vellum::render::detail {

/// Compiles and links a program; throws vellum::Error with the info log on failure.
GLuint buildProgram(const std::string& vertexSource, const std::string& fragmentSource);

/// Throws vellum::Error naming `what` if glGetError() reports an error.
void checkGlError(const char* what);

}  // namespace vellum::render::detail
