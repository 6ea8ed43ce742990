// The blocker-tile hooks of the shade passes that traverse the blocker BVH (isg, lobes, shexp); include
// before common/bvh.glsl. In the pixel variant (SHADE_PIXEL, defined by the technique's pixel.comp):
// - every invocation counts the BVH nodes it tests (BVH_COUNT_VISITS) and target_pixel.glsl writes the count
//   to NodeVisits (the "blockers tested per pixel" counter, engine::passes::shade::tiles);
// - with BVH_TILES (the technique's option tiles=on) every traversal starts from the pixel's tile list
//   (blocker_tiles/cull.comp) instead of the root; target_pixel.glsl defines bvh_tile_range().
// The vertex variant traverses from the root and counts nothing.
#ifndef SHADE_TILES_GLSL
#define SHADE_TILES_GLSL
#ifdef SHADE_PIXEL
#define BVH_COUNT_VISITS
layout(std430, binding = 40) writeonly buffer NodeVisits { uint node_visits[]; };
#ifdef BVH_TILES
// Written by blocker_tiles/cull.comp: [0] the record stride S, tile t's record at 1 + t S (its length, then
// its start nodes).
layout(std430, binding = 41) readonly buffer TileNodes { uint tile_nodes[]; };
#define BVH_TILE_NODE(i) tile_nodes[i]
const uint BVH_TILE_SIDE = 16u;
#endif
#endif
#endif
