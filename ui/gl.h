// OpenGL 3.3 core declarations for the editor's own GL calls, and GLFW without its GL header.
// Mesa's libGL exports every core entry point, so the prototypes are linked directly
// (GL_GLEXT_PROTOTYPES) and no loader library is needed. Only ui/ GL files include this.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
