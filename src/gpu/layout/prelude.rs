//! The numbers the shaders share with the host, as WGSL constants for the generated prelude
//! (`gpu::shaders`): each lives in one place, here or in `scene`/`accel`.

use super::*;
use crate::accel::{PrimKind, PrimRef};
use crate::scene::{Filter, MaterialKind, Wrap, MAX_LIGHTS};
use glam::DVec3;

/// WGSL `const` declarations for every number the shaders share with this file, so each lives
/// in one place (here, or in `scene`/`accel`).
pub fn wgsl_constants() -> String {
    let c = |name: &str, v: u32| format!("const {name}: u32 = {v}u;\n");
    let mut s = String::new();
    s += &c("SCENE_TEX_SHIFT", SCENE_TEX_SHIFT);
    s += &c("SCENE_LAYER_SHIFT", SCENE_LAYER_SHIFT);
    s += &c("SPHERE_TEXELS", SPHERE_TEXELS);
    s += &c("TRIANGLE_TEXELS", TRIANGLE_TEXELS);
    s += &c("NORMAL_TEXELS", NORMAL_TEXELS);
    s += &c("MATERIAL_TEXELS", MATERIAL_TEXELS);
    s += &c("CONE_TEXELS", CONE_TEXELS);
    s += &c("SHELL_HEADER_TEXELS", SHELL_HEADER_TEXELS);
    s += &c("SHELL_OBJECT_TEXELS", SHELL_OBJECT_TEXELS);
    s += &c("SHELL_EDGE_TEXELS", SHELL_EDGE_TEXELS);
    s += &c("SHELL_DIRECT_TRIANGLES", crate::scene::SHELL_DIRECT_TRIANGLES);
    s += &c("NO_NORMALS", NO_NORMALS);
    s += &c("UV_TEXELS", UV_TEXELS);
    s += &c("TEXTURE_TEXELS", TEXTURE_TEXELS);
    s += &c("PIXELS_PER_TEXEL", PIXELS_PER_TEXEL);
    s += &c("NO_UVS", NO_UVS);
    s += &c("NO_TEXTURE", NO_TEXTURE);
    s += &c("TEXTURE_WRAP_V_SHIFT", TEXTURE_WRAP_V_SHIFT);
    s += &c("TEXTURE_FILTER_SHIFT", TEXTURE_FILTER_SHIFT);
    for (name, w) in Wrap::NAMES {
        s += &c(&format!("WRAP_{}", name.to_uppercase()), wrap_code(w));
    }
    for (name, f) in Filter::NAMES {
        s += &c(&format!("FILTER_{}", name.to_uppercase()), filter_code(f));
    }
    s += &c("MACRO_FACTOR", crate::accel::grid::MACRO_FACTOR);
    s += &c("MAX_LIGHTS", MAX_LIGHTS as u32);
    s += &c("RENDER_TILE_W", RENDER_TILE[0]);
    s += &c("RENDER_TILE_H", RENDER_TILE[1]);
    s += &c("TILE_W", TILE_W);
    s += &c("TILE_H", TILE_H);
    s += &c("MAX_CHUNK_TILES", MAX_CHUNK_TILES);
    s += &c("FRAME_WRITE", FRAME_WRITE);
    s += &c("FRAME_ACCUMULATE", FRAME_ACCUMULATE);
    s += &c("FRAME_BLEND", FRAME_BLEND);
    s += &c("FRAME_JITTER_PAIRS", FRAME_JITTER_PAIRS);
    s += &c("OUT_COMPACT", OUT_COMPACT);
    s += &c("ORDER_TABLE", ORDER_TABLE);
    s += &c("ORDER_DISSOLVE", ORDER_DISSOLVE);
    s += &c("MAX_STACK", crate::scene::MAX_TRACE_DEPTH);
    s += &c("STATS_WORDS", STATS_WORDS);
    s += &c("STATS_SIMD_AT", STATS_SIMD_AT);
    for (k, name) in SIMD_LOOPS.iter().enumerate() {
        s += &c(&format!("LOOP_{}", name.replace(' ', "_").to_uppercase()), k as u32);
    }
    s += &c("BVH_NODE_TEXELS", BVH_NODE_TEXELS);
    s += &c("BVH_COUNT_SHIFT", BVH_COUNT_SHIFT);
    s += &c("BVH_INNER", BVH_INNER);
    s += &c("BVH_AXIS_SHIFT", BVH_AXIS_SHIFT);
    s += &c("BVH_CHILD_MASK", BVH_CHILD_MASK);
    s += &c("BVH_STACK", crate::accel::bvh::MAX_DEPTH as u32);
    s += &c("ACCEL_GRID", ACCEL_GRID);
    s += &c("ACCEL_BVH", ACCEL_BVH);
    s += &c("ACCEL_BVH_STACKLESS", ACCEL_BVH_STACKLESS);
    s += &c("PRIM_INDEX_BITS", PrimRef::INDEX_BITS);
    s += &c("PRIM_KIND_SHIFT", PrimRef::KIND_SHIFT);
    s += &c("PRIM_SPHERE", PrimKind::Sphere as u32);
    s += &c("PRIM_TRIANGLE", PrimKind::Triangle as u32);
    s += &c("PRIM_CONE", PrimKind::Cone as u32);
    s += &c("PRIM_VOLUME", PrimKind::Volume as u32);
    s += &c("VOLUME_TEXELS", super::volume::VOLUME_TEXELS);
    s += &c("MAX_VOLUMES", crate::scene::volume::MAX_VOLUMES as u32);
    s += &c("LOOK_ISO", crate::scene::transfer::Look::Iso.code());
    s += &c("LOOK_MIP", crate::scene::transfer::Look::Mip.code());
    s += &c("LOOK_DVR", crate::scene::transfer::Look::Dvr.code());
    s += &c("TRANSFER_ENTRIES", crate::scene::transfer::TRANSFER_ENTRIES as u32);
    s += &c("DVR_CELL_SAMPLES", crate::scene::transfer::DVR_CELL_SAMPLES);
    let f = |name: &str, v: f64| format!("const {name}: f32 = {v:?};\n");
    s += &f("DVR_STEP", crate::scene::transfer::DVR_STEP);
    s += &f("DVR_EARLY_OUT", crate::scene::transfer::DVR_EARLY_OUT);
    s += &c("PRIM_PATCH", PrimKind::Patch as u32);
    s += &c("LEAF_TEXELS", super::patch::LEAF_TEXELS);
    s += &c("PIECE_HEADER_TEXELS", super::patch::PIECE_HEADER_TEXELS);
    s += &c("PATCH_ANY", super::patch::PATCH_ANY);
    s += &c("PATCH_NEWTON_STEPS", super::patch::NEWTON_STEPS);
    s += &f("PATCH_TOLERANCE", super::patch::TOLERANCE);
    s += &f("PATCH_OVERLAP", crate::scene::patch::leaves::OVERLAP);
    for (name, kind) in [
        ("MAT_DIFFUSE", MaterialKind::Diffuse { color: DVec3::ZERO }),
        ("MAT_METAL", MaterialKind::Metal { color: DVec3::ZERO, exponent: 0.0 }),
        ("MAT_DIELECTRIC", MaterialKind::Dielectric { eta: 1.0, exponent: 0.0 }),
        ("MAT_POLISHED", MaterialKind::Polished { color: DVec3::ZERO, eta: 1.0, exponent: 0.0 }),
    ] {
        s += &c(name, material_code(&kind));
    }
    s
}
