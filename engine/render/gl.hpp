#pragma once
// The one place that includes the OpenGL headers: OpenGL 3.3 core entry points are called
// directly (GLVND's libOpenGL exports them; no loader library is needed). Internal to
// engine/render.
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/gl.h>
#include <GL/glext.h>
