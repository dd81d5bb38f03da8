// Decoding the scene texture. Record formats: src/gpu/layout.rs, pack_scene.

fn texel(i: u32) -> vec4u {
    return scene_load(i & ((1u << SCENE_TEX_SHIFT) - 1u), i >> SCENE_TEX_SHIFT);
}

fn ftexel(i: u32) -> vec4f {
    return bitcast<vec4f>(texel(i));
}

fn prim_kind(r: u32) -> u32 {
    return r >> PRIM_KIND_SHIFT;
}

fn prim_index(r: u32) -> u32 {
    return r & ((1u << PRIM_INDEX_BITS) - 1u);
}

// Sphere `i`: centre xyz, radius w.
fn load_sphere(i: u32) -> vec4f {
    return ftexel(params.prim_base.x + i * SPHERE_TEXELS);
}

fn sphere_material(i: u32) -> u32 {
    return texel(params.prim_base.x + i * SPHERE_TEXELS + 1u).x;
}

// Sphere `i`'s anchor: the point of its surface nearest the eye (see `intersect_sphere`).
fn sphere_anchor(i: u32) -> vec3f {
    return ftexel(params.prim_base.x + i * SPHERE_TEXELS + 1u).yzw;
}

struct Triangle {
    p0: vec3f,
    p1: vec3f,
    p2: vec3f,
    material: u32,
    normals: u32,
    uvs: u32,
}

fn load_triangle(i: u32) -> Triangle {
    let base = params.prim_base.y + i * TRIANGLE_TEXELS;
    let a = texel(base);
    let b = texel(base + 1u);
    let c = texel(base + 2u);
    return Triangle(bitcast<vec3f>(a.xyz), bitcast<vec3f>(b.xyz), bitcast<vec3f>(c.xyz), a.w, b.w, c.w);
}

// Interpolated vertex normal of normal record `rec` at barycentrics (b1, b2).
fn vertex_normal(rec: u32, b1: f32, b2: f32) -> vec3f {
    let base = params.prim_base.z + rec * NORMAL_TEXELS;
    let n0 = ftexel(base).xyz;
    let n1 = ftexel(base + 1u).xyz;
    let n2 = ftexel(base + 2u).xyz;
    return (1.0 - b1 - b2) * n0 + b1 * n1 + b2 * n2;
}

// Interpolated texture coordinates of uv record `rec` at barycentrics (b1, b2).
fn vertex_uv(rec: u32, b1: f32, b2: f32) -> vec2f {
    let base = params.aux_base.y + rec * UV_TEXELS;
    let a = ftexel(base);
    let b = ftexel(base + 1u);
    return (1.0 - b1 - b2) * a.xy + b1 * a.zw + b2 * b.xy;
}

struct Material {
    color: vec3f,
    kind: u32,
    eta: f32,
    exponent: f32,
    texture: u32,
}

fn load_material(m: u32) -> Material {
    let base = params.prim_base.w + m * MATERIAL_TEXELS;
    let a = texel(base);
    let b = texel(base + 1u);
    return Material(bitcast<vec3f>(a.xyz), a.w, bitcast<f32>(b.x), bitcast<f32>(b.y), b.z);
}

// Cone `i`: from `base` (radius r0) to `base + axis` (radius r1).
struct Cone {
    base: vec3f,
    r0: f32,
    axis: vec3f,
    r1: f32,
}

fn load_cone(i: u32) -> Cone {
    let base = params.aux_base.x + i * CONE_TEXELS;
    let a = ftexel(base);
    let b = ftexel(base + 1u);
    return Cone(a.xyz, a.w, b.xyz, b.w);
}

fn cone_material(i: u32) -> u32 {
    return texel(params.aux_base.x + i * CONE_TEXELS + 2u).x;
}

// (start, count) of grid cell `c`'s primitive references.
fn cell_range(c: u32) -> vec2u {
    let t = texel(params.accel_base.x + c / 2u);
    return select(t.xy, t.zw, (c & 1u) == 1u);
}

fn prim_ref(i: u32) -> u32 {
    return texel(params.accel_base.y + i / 4u)[i % 4u];
}

fn macro_occupied(m: u32) -> bool {
    let word = texel(params.accel_base.z + m / 128u)[(m / 32u) % 4u];
    return ((word >> (m % 32u)) & 1u) != 0u;
}
