#include "render/gl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "render/gl.h"

namespace hapvox::render {
namespace {

std::string egl_error_text(const char* what) {
  char code[32];
  std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(eglGetError()));
  return std::string("EGL: ") + what + " (error " + code + ")";
}

bool has_extension(const char* list, const char* name) {
  if (list == nullptr) return false;
  const std::size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n) {
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  }
  return false;
}

// A GPU's EGL device (EGL_EXT_platform_device: NVIDIA's driver, Mesa on a DRM device), or
// EGL_NO_DISPLAY when there is none. Mesa's software device is skipped: without a GPU the
// surfaceless platform (llvmpipe) is used, as it always was. HAPVOX_EGL=surfaceless skips
// GPUs too.
EGLDisplay open_gpu_display() {
  const char* choice = std::getenv("HAPVOX_EGL");
  if (choice != nullptr && std::strcmp(choice, "surfaceless") == 0) return EGL_NO_DISPLAY;
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_extension(client, "EGL_EXT_platform_device") ||
      !has_extension(client, "EGL_EXT_device_enumeration")) {
    return EGL_NO_DISPLAY;
  }
  auto query_devices =
      reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
      eglGetProcAddress("eglQueryDeviceStringEXT"));
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (query_devices == nullptr || device_string == nullptr || get_platform_display == nullptr) {
    return EGL_NO_DISPLAY;
  }
  EGLDeviceEXT devices[16];
  EGLint count = 0;
  if (query_devices(16, devices, &count) == EGL_FALSE) return EGL_NO_DISPLAY;
  for (EGLint i = 0; i < count; ++i) {
    if (has_extension(device_string(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software")) {
      continue;
    }
    EGLDisplay display = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
    EGLint major = 0, minor = 0;
    if (display == EGL_NO_DISPLAY || eglInitialize(display, &major, &minor) == EGL_FALSE) {
      continue;
    }
    if (has_extension(eglQueryString(display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context")) {
      return display;
    }
    eglTerminate(display);
  }
  return EGL_NO_DISPLAY;
}

// Mesa's surfaceless platform: no X server, no DRM device (headless CI machines).
EGLDisplay open_surfaceless_display() {
  // Client extensions are queried on EGL_NO_DISPLAY; without EGL_MESA_platform_surfaceless
  // we would need an X server or a DRM device, which headless machines do not have.
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_extension(client, "EGL_MESA_platform_surfaceless")) {
    throw RenderError(
        "EGL: the surfaceless platform (EGL_MESA_platform_surfaceless) is not available; "
        "install Mesa's EGL (Debian: libegl-mesa0 libgl1-mesa-dri)");
  }
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr) {
    throw RenderError("EGL: eglGetPlatformDisplayEXT is missing");
  }
  EGLDisplay display =
      get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (display == EGL_NO_DISPLAY || eglInitialize(display, &major, &minor) == EGL_FALSE) {
    throw RenderError(egl_error_text("cannot open the surfaceless display"));
  }
  if (!has_extension(eglQueryString(display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context")) {
    eglTerminate(display);
    throw RenderError("EGL: the display cannot make a context current without a surface");
  }
  return display;
}

}  // namespace

GlContext::GlContext() {
  EGLDisplay display = open_gpu_display();
  if (display == EGL_NO_DISPLAY) display = open_surfaceless_display();
  display_ = display;
  if (eglBindAPI(EGL_OPENGL_API) == EGL_FALSE) {
    eglTerminate(display);
    throw RenderError(egl_error_text("OpenGL is not supported by this EGL"));
  }
  const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                                       3,
                                       EGL_CONTEXT_MINOR_VERSION,
                                       3,
                                       EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                       EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                       EGL_NONE};
  // No config: we render into our own framebuffer objects, never into an EGL surface.
  EGLContext context =
      eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, context_attributes);
  if (context == EGL_NO_CONTEXT) {
    eglTerminate(display);
    throw RenderError(egl_error_text("cannot create an OpenGL 3.3 core context"));
  }
  context_ = context;
  make_current();
  renderer_ = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  version_ = reinterpret_cast<const char*>(glGetString(GL_VERSION));
}

GlContext::~GlContext() {
  EGLDisplay display = static_cast<EGLDisplay>(display_);
  eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(display, static_cast<EGLContext>(context_));
  eglTerminate(display);
}

void GlContext::make_current() {
  if (eglMakeCurrent(static_cast<EGLDisplay>(display_), EGL_NO_SURFACE, EGL_NO_SURFACE,
                     static_cast<EGLContext>(context_)) == EGL_FALSE) {
    throw RenderError(egl_error_text("cannot make the context current"));
  }
}

void GlContext::release() {
  eglMakeCurrent(static_cast<EGLDisplay>(display_), EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
}

void check_gl(const char* what) {
  const GLenum error = glGetError();
  if (error != GL_NO_ERROR) {
    char code[32];
    std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(error));
    throw RenderError(std::string("OpenGL: ") + what + ": error " + code);
  }
}

}  // namespace hapvox::render
