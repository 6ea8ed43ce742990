#version 460
#extension GL_GOOGLE_include_directive : require
#include "../common.glsl"
layout(std430, binding = 3) readonly buffer WorldVertices { Vertex world[]; };
#include "clusters.glsl"
