#version 460
#extension GL_GOOGLE_include_directive : require
#define SHEXP_CLUSTER_PIXEL
#include "../common.glsl"
layout(binding = 3, rgba32f) uniform readonly image2D gbuf_position;
#include "clusters.glsl"
