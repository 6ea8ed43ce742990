#version 460
#extension GL_GOOGLE_include_directive : require
#define SHADE_PIXEL
#define SHEXP_PIXEL
#include "shade.glsl"
#include "../target_pixel.glsl"

float shexp_pixel_first_vertex() {
    return imageLoad(gbuf_geometric, target_pixel()).w;
}
