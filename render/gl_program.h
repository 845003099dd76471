#pragma once
// Compiling and linking GLSL programs: a shader that does not compile or link throws
// RenderError with the driver's log, never crashes. Needs a current GL context.

#include "render/gl.h"

namespace hapvox::render {

GLuint compile_shader(GLenum kind, const char* source);
/// A program of one vertex and one fragment shader.
GLuint link_program(const char* vertex, const char* fragment);

}  // namespace hapvox::render
