#pragma once
// One EGL context for the whole render_tests binary: EGL displays are process-wide anyway,
// and a context per test file would only make more of them.

#include "render/gl_context.h"

namespace hapvox::render {

inline GlContext& suite_gl_context() {
  static GlContext gl;
  return gl;
}

}  // namespace hapvox::render
