#pragma once
// A headless OpenGL context: EGL on Mesa's surfaceless platform (no X server, no window),
// OpenGL 3.3 core. Runs on llvmpipe on a CPU-only machine and on a GPU driver unchanged.
// A context is current on the thread that made it (or called make_current) only: the
// render thread owns it, no other thread issues GL calls.

#include <stdexcept>
#include <string>

namespace hapvox::render {

/// EGL or OpenGL is missing or refused what we asked for. what() reads "EGL: PROBLEM".
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class GlContext {
 public:
  /// Opens the surfaceless EGL display, creates an OpenGL 3.3 core context and makes it
  /// current on this thread. Throws RenderError (never crashes) when EGL, the surfaceless
  /// platform or a 3.3 core context is not available.
  GlContext();
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  /// Makes the context current on the calling thread (after it was released elsewhere).
  void make_current();
  /// Releases it from the calling thread.
  void release();

  /// GL_RENDERER and GL_VERSION, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)", "4.5 (Core ...)".
  const std::string& renderer() const { return renderer_; }
  const std::string& version() const { return version_; }

 private:
  void* display_ = nullptr;  // EGLDisplay
  void* context_ = nullptr;  // EGLContext
  std::string renderer_;
  std::string version_;
};

/// Throws RenderError("OpenGL: WHAT: error 0x...") if glGetError reports one.
void check_gl(const char* what);

}  // namespace hapvox::render
