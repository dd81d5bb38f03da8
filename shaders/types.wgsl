// GPU structs and bindings. Rust mirrors: src/gpu/layout/mod.rs (structs) and src/gpu/bindings.rs
// (the binding table), each tied to this file by a test.

struct Light {
    position_radius: vec4f,
    color: vec4f,
}

struct Params {
    eye: vec4f,
    cam_u: vec4f,
    cam_v: vec4f,
    cam_w: vec4f,
    ambient_sky: vec4f,
    ambient_ground: vec4f,
    ambient_up: vec4f,
    background: vec4f,
    accel_min: vec4f,
    accel_max: vec4f,
    cell: vec4f,
    inv_cell: vec4f,
    cells: vec4u,
    macro_res: vec4u,
    prim_base: vec4u,
    aux_base: vec4u,
    accel_base: vec4u,
    image: vec4u,
    eye_grid: vec4u,
    trace: vec4f,
    shadow: vec4u,
    lights: array<Light, MAX_LIGHTS>,
    volume: vec4u,
    iso: array<vec4f, MAX_VOLUMES>,
    patches: vec4u,
}

// A BVH node of the stack walk (two texels of the scene texture; src/gpu/layout.rs, BvhNode).
// The stackless walk reads compact one-texel nodes instead (layout.rs, quantise_node).
struct BvhNode {
    lo: vec3f,
    a: u32,
    hi: vec3f,
    b: u32,
}

struct Launch {
    rect: vec4u,
    pass_range: vec4u,
    work: vec4u,
    sample: vec4u,
    jitter: vec4f,
}

@group(0) @binding(0) var<uniform> params: Params;
// @binding(1), scene_tex, and its loader `scene_load` are in the prelude (src/gpu/shaders.rs):
// a 2D texture or, for scenes past one layer, a 2D array.
@group(0) @binding(2) var<storage, read_write> out_buf: array<vec4f>;
@group(0) @binding(3) var<storage, read_write> stats: array<atomic<u32>, STATS_WORDS>;
@group(0) @binding(4) var<uniform> launch: Launch;
@group(0) @binding(5) var<storage, read> test_in: array<vec4f>;
// The dispatch modes' inputs (shaders/modes.wgsl): the conventional mode's chunk boundaries, or
// the frameless mode's pixel order (a table, or the dissolve's jump matrices).
@group(0) @binding(6) var<storage, read> work_buf: array<u32>;
// [0]: the next chunk of the conventional mode's tile queue.
@group(0) @binding(7) var<storage, read_write> queue: array<atomic<u32>, 4>;
// What the viewer shows: per pixel the sum of its samples (rgb) and their count (a).
@group(0) @binding(8) var<storage, read_write> frame_buf: array<vec4f>;

const NO_HIT: u32 = 0xffffffffu;
const MISS: f32 = -1.0;
const BIG: f32 = 3.0e38;
const PI: f32 = 3.141592653589793;
const TAU: f32 = 6.283185307179586;
