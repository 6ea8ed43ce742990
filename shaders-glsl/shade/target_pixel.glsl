// Per-pixel target: one invocation per G-buffer pixel; background pixels show the environment.
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 3, rgba32f) uniform readonly image2D gbuf_position;
layout(binding = 4, rgba32f) uniform readonly image2D gbuf_normal;
layout(binding = 5, rgba32f) uniform writeonly image2D radiance;
layout(binding = 18, rgba32f) uniform readonly image2D gbuf_geometric;

vec3 camera_ray(ivec2 px) {
    vec2 ndc = (vec2(px) + 0.5) / vec2(frame.size.xy) * 2.0 - 1.0;
    return normalize(frame.forward.xyz + ndc.x * frame.tan_half_fov_x * frame.right.xyz - ndc.y * frame.tan_half_fov_y * frame.up.xyz);
}

// This invocation's pixel: the 8 × 8 workgroup's pixels in Morton order, so that each run of 8
// consecutive invocations (one SIMD vector on llvmpipe's 256-bit lanes) shades a 4 × 2 block rather than
// a row of 8: neighbours see more similar blockers and their loops diverge less (README, "Speed").
ivec2 target_pixel() {
    uint l = gl_LocalInvocationIndex;
    uvec2 m = uvec2((l & 1u) | ((l >> 1u) & 2u) | ((l >> 2u) & 4u), ((l >> 1u) & 1u) | ((l >> 2u) & 2u) | ((l >> 3u) & 4u));
    return ivec2(gl_WorkGroupID.xy * 8u + m);
}

#ifdef BVH_TILE_NODE
// This pixel's tile list in TileNodes (shade/tiles.glsl): [first, end).
uvec2 bvh_tile_range() {
    uvec2 t = uvec2(target_pixel()) / BVH_TILE_SIDE;
    uint tiles_x = (frame.size.x + BVH_TILE_SIDE - 1u) / BVH_TILE_SIDE;
    uint base = 1u + (t.y * tiles_x + t.x) * tile_nodes[0];
    return uvec2(base + 1u, base + 1u + tile_nodes[base]);
}
#endif

void main() {
    ivec2 px = target_pixel();
    if (any(greaterThanEqual(uvec2(px), frame.size.xy))) return;
    vec4 p = imageLoad(gbuf_position, px);
    vec3 result;
    if (p.w < 0.5) {
        result = environment_radiance(camera_ray(px));
    } else {
        ShadePoint sp;
        sp.position = p.xyz;
        sp.normal = imageLoad(gbuf_normal, px).xyz;
        sp.geometric = imageLoad(gbuf_geometric, px).xyz;
        sp.view = normalize(frame.eye.xyz - p.xyz);
        sp.material = materials[uint(p.w - 0.5)];
        result = shade_point(sp);
    }
    // No NaN or inf may reach an image.
    if (any(isnan(result)) || any(isinf(result))) result = vec3(0.0);
    imageStore(radiance, px, vec4(result, 1.0));
#ifdef BVH_COUNT_VISITS
    node_visits[uint(px.y) * frame.size.x + uint(px.x)] = p.w < 0.5 ? 0xffffffffu : bvh_visits;
#endif
}
