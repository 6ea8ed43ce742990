#version 460
#extension GL_GOOGLE_include_directive : require
#define SHADE_PIXEL
#include "shade.glsl"
#include "../target_pixel.glsl"
