#pragma once
// OpenGL core declarations. glvnd's libOpenGL exports every core entry point up to 4.5, so
// no loader library is needed; we use only 3.3 core functions.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
