#version 460
#extension GL_GOOGLE_include_directive : require
#define SHEXP_PIXEL
#include "shade.glsl"
#include "../target_pixel.glsl"
