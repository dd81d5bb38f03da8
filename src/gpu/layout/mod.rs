//! Byte-exact GPU data: the uniform structs (mirrored in `shaders/types.wgsl`, tied by a test
//! against naga's layouter), the record formats and flags the shaders share, the packing of the
//! scene and its accelerator into one `rgba32uint` texture ([`pack`]), the BVH's device nodes
//! ([`bvh`]) and the generated WGSL constants ([`prelude`]).
//!
//! Why a texture: on lavapipe a storage-buffer load in a hot loop costs more than a texture
//! load and uniform buffers are too small for scenes (docs/performance.md, "Scene texture as a
//! storage image"). Every record is whole texels
//! (vec4<u32>), so each traversal step costs as few load instructions as possible; floats are
//! stored as their bits and `bitcast` back in the shader.

pub mod bvh;
pub mod pack;
pub mod patch;
pub mod prelude;
pub mod volume;

pub use bvh::{bvh_nodes, decode_qnode, quantise_node, BvhLattice};
pub use pack::{
    bvh_rows_bound, pack_accel, pack_scene, params, sphere_anchor, swap_accel, AccelSection, Prefix,
};
pub use prelude::wgsl_constants;

use crate::scene::{Filter, MaterialKind, Wrap, MAX_LIGHTS};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// The scene texture is `1 << SCENE_TEX_SHIFT` texels wide; texel `i` is in column
/// `i & (width - 1)` of row `i >> SCENE_TEX_SHIFT`. A scene whose rows fit the device's largest
/// texture side (16384 on lavapipe: 1 GiB, about 9M triangles with normals) is one 2D texture;
/// a larger one is a 2D array of layers of `1 << SCENE_LAYER_SHIFT` rows, row `r` in layer
/// `r >> SCENE_LAYER_SHIFT` (`Variant::layered`), up to the array-layer limit (256 at least).
pub const SCENE_TEX_SHIFT: u32 = 12;
pub const SCENE_TEX_WIDTH: u32 = 1 << SCENE_TEX_SHIFT;
/// Rows per layer of a layered scene texture, and per upload band of any: 64 MiB, so that at
/// most that much is wasted in the last layer, and wgpu's staging copy is never more.
pub const SCENE_LAYER_SHIFT: u32 = 10;
pub const SCENE_LAYER_ROWS: u32 = 1 << SCENE_LAYER_SHIFT;

/// Texels per record; the shader's decoders read these constants from the generated prelude.
pub const SPHERE_TEXELS: u32 = 2;
pub const TRIANGLE_TEXELS: u32 = 3;
pub const NORMAL_TEXELS: u32 = 3;
pub const MATERIAL_TEXELS: u32 = 2;
pub const CONE_TEXELS: u32 = 3;
/// A light's shell section (shell shadow mode) starts with its header and its depth slabs.
pub const SHELL_HEADER_TEXELS: u32 = 2;
/// A shell object (shell shadow mode): bounding sphere, record, a mesh's bounding box.
pub const SHELL_OBJECT_TEXELS: u32 = 3;
/// A mesh's contour edge (shell shadow mode): its two end points.
pub const SHELL_EDGE_TEXELS: u32 = 2;
pub const UV_TEXELS: u32 = 2;
/// Texture records: one texel each. Texture pixels: four RGBA8 pixels (one u32 each) per texel.
pub const TEXTURE_TEXELS: u32 = 1;
pub const PIXELS_PER_TEXEL: u32 = 4;
/// Cells per texel: (start, count) pairs.
pub const CELLS_PER_TEXEL: u32 = 2;
pub const REFS_PER_TEXEL: u32 = 4;
pub const MACRO_BITS_PER_TEXEL: u32 = 128;
/// BVH nodes of the stack walk: one [`BvhNode`] (two texels) each.
pub const BVH_NODE_TEXELS: u32 = 2;
/// BVH nodes of the stackless walk: one texel each ([`quantise_node`]): the box as six 16-bit
/// steps of the lattice [`BvhLattice`] (`[lo.x | lo.y << 16, lo.z | hi.x << 16, hi.y | hi.z <<
/// 16]`), then the link word: an inner node's [`BVH_INNER`] | escape, a leaf's count <<
/// [`BVH_COUNT_SHIFT`] | its reference texel. Half the fetches of a [`BvhNode`], which is what a
/// lavapipe loop iteration pays most for (docs/performance.md, "Compact BVH nodes").
pub const BVH_QNODE_TEXELS: u32 = 1;
/// A compact leaf's primitive count sits above this bit of its link word.
pub const BVH_COUNT_SHIFT: u32 = 28;
/// The largest step of a compact node's box coordinates.
pub const BVH_QUANT_MAX: u32 = 0xffff;
// A leaf's count (at most `MAX_LEAF`) fits between the count shift and the inner bit, and its
// references in one texel.
const _: () = assert!(crate::accel::bvh::MAX_LEAF < 1 << (31 - BVH_COUNT_SHIFT));
const _: () = assert!(crate::accel::bvh::MAX_LEAF <= REFS_PER_TEXEL as usize);
/// `BvhNode::b` of an inner node has this bit set; the split axis is in the bits from
/// [`BVH_AXIS_SHIFT`], the right child's index below them.
pub const BVH_INNER: u32 = 1 << 31;
pub const BVH_AXIS_SHIFT: u32 = 29;
pub const BVH_CHILD_MASK: u32 = (1 << BVH_AXIS_SHIFT) - 1;
/// `Params::macro_res[3]`: the accelerator packed (the dispatcher compiles its traversal).
pub const ACCEL_GRID: u32 = 0;
pub const ACCEL_BVH: u32 = 1;
pub const ACCEL_BVH_STACKLESS: u32 = 2;
/// A BVH box is grown by this many f32 ulps of its largest coordinate (and [`BVH_MARGIN_REL`] of
/// its extent) beyond the outward rounding: room for the rounding of the primitives' own f32
/// records and of the intersection tests, which may report a hit a little outside the exact
/// shape.
const BVH_MARGIN_ULPS: f64 = 8.0;
const BVH_MARGIN_REL: f64 = 1e-5;
/// Marks a triangle without vertex normals.
pub const NO_NORMALS: u32 = u32::MAX;
/// Marks a triangle without texture coordinates.
pub const NO_UVS: u32 = u32::MAX;
/// Marks an untextured material.
pub const NO_TEXTURE: u32 = u32::MAX;

/// Where a texture record's flags word keeps the v wrap and the filter (the u wrap is in bits
/// 0..2): `wrap_u | wrap_v << TEXTURE_WRAP_V_SHIFT | filter << TEXTURE_FILTER_SHIFT`.
pub const TEXTURE_WRAP_V_SHIFT: u32 = 2;
pub const TEXTURE_FILTER_SHIFT: u32 = 4;

/// Wrap and filter codes as stored in a texture record.
pub fn wrap_code(w: Wrap) -> u32 {
    match w {
        Wrap::Repeat => 0,
        Wrap::Clamp => 1,
        Wrap::Mirror => 2,
    }
}

pub fn filter_code(f: Filter) -> u32 {
    match f {
        Filter::Nearest => 0,
        Filter::Linear => 1,
    }
}

/// Material kind codes as stored in the material record.
pub fn material_code(kind: &MaterialKind) -> u32 {
    match kind {
        MaterialKind::Diffuse { .. } => 0,
        MaterialKind::Metal { .. } => 1,
        MaterialKind::Dielectric { .. } => 2,
        MaterialKind::Polished { .. } => 3,
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// xyz position, w radius.
    pub position_radius: [f32; 4],
    /// rgb intensity l_e; w: in shell shadow mode, the bits of the u32 first texel of this
    /// light's shell section ([`PackedScene::shell_sections`]), else 0.
    pub color: [f32; 4],
}

/// A BVH node as the shader reads it (two texels). Mirrors `struct BvhNode` in
/// `shaders/types.wgsl`. Inner node `i`: `a` is its escape (the first node after its subtree),
/// `b` = [`BVH_INNER`] | axis << [`BVH_AXIS_SHIFT`] | right child (the left is `i + 1`).
/// Leaf: `a` is its reference texel (one per leaf, in node order), `b` how many references it
/// holds (its next node is `i + 1`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub lo: [f32; 3],
    pub a: u32,
    pub hi: [f32; 3],
    pub b: u32,
}

/// Everything constant over a frame. Mirrors `struct Params` in `shaders/types.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Params {
    pub eye: [f32; 4],
    /// Camera right/up scaled to the image plane's half-extents, and forward (see `CameraBasis`).
    pub cam_u: [f32; 4],
    pub cam_v: [f32; 4],
    pub cam_w: [f32; 4],
    pub ambient_sky: [f32; 4],
    pub ambient_ground: [f32; 4],
    pub ambient_up: [f32; 4],
    pub background: [f32; 4],
    pub accel_min: [f32; 4],
    pub accel_max: [f32; 4],
    pub cell: [f32; 4],
    pub inv_cell: [f32; 4],
    /// xyz cells per axis (w unused: the fine cells per macro-cell side are the WGSL constant
    /// `MACRO_FACTOR`, which the shader divides by without a run-time divide).
    pub cells: [u32; 4],
    /// xyz macro-cells per axis; w the accelerator ([`ACCEL_GRID`], [`ACCEL_BVH`],
    /// [`ACCEL_BVH_STACKLESS`]). With a BVH, `accel_min`/`accel_max` are its root box and the
    /// other grid fields 0.
    pub macro_res: [u32; 4],
    /// First texel of the sphere, triangle, vertex-normal and material records.
    pub prim_base: [u32; 4],
    /// First texel of the cone records, texture-coordinate records, texture records and texture
    /// pixels.
    pub aux_base: [u32; 4],
    /// First texel of the cell ranges, primitive references, macro-cell bits and shadow-bundle
    /// points; with a BVH: of its nodes, its references, the node count, the bundle points.
    pub accel_base: [u32; 4],
    /// width, height, max_depth, light count.
    pub image: [u32; 4],
    /// The eye rays: columns, rows, 1 if they pass through pixel corners (SPD's rule, a
    /// (width+1)x(height+1) grid) else 0 (pixel centres, width x height); unused. See [`eye_grid`].
    pub eye_grid: [u32; 4],
    /// weight_cutoff, ray offset (relative), unused, unused.
    pub trace: [f32; 4],
    /// Shadow mode (docs/shadows.md): kind (`ShadowMode::kind_index`), bundle size, rotate
    /// (0/1), falloff | combine << 8.
    pub shadow: [u32; 4],
    pub lights: [GpuLight; MAX_LIGHTS],
    /// The volumes (`layout::volume`): first record texel, count, looks (`volume::look_bits`),
    /// unused.
    pub volume: [u32; 4],
    /// Each volume's isovalues (live: a new one changes only this uniform).
    pub iso: [[f32; 4]; crate::scene::volume::MAX_VOLUMES],
    /// The patches (`layout::patch`): first leaf texel, leaf count, the pieces' degree (what a
    /// pipeline not specialised to one reads), 0.
    pub patches: [u32; 4],
}

/// The per-dispatch uniform: what one dispatch covers and how its pixels update the frame
/// buffer. Mirrors `struct Launch` in `shaders/types.wgsl`. Made by the constructors below, one
/// per entry point, which say what `work` holds for it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Launch {
    /// x0, y0, width, height in pixels (the bands' `render` entry point).
    pub rect: [u32; 4],
    /// Bundle samples `[first, end)` this pass traces (end clamped to the bundle size), whether
    /// it is the first pass (which writes ambient, background and ray counts; later passes add
    /// their share of the light to the output) and whether it is the last (which updates the
    /// frame buffer). See [`Launch::whole`].
    pub pass_range: [u32; 4],
    /// The entry point's own words: see [`Launch::bands`], [`Launch::queue`],
    /// [`Launch::slice`], [`Launch::resolve`].
    pub work: [u32; 4],
    /// The sample index, frame flags (`FRAME_*`), the dissolve's state at the slice's first
    /// position, and the output's base: the eye ray (pixel) index that lands in output vec4 0,
    /// so that a piece of a picture larger than the output buffer is traced into it
    /// ([`Launch::at_base`]; compact outputs ignore it).
    pub sample: [u32; 4],
    /// Sub-pixel offset of this sample from the pixel centre (x, y), the blend weight α of new
    /// samples with [`FRAME_BLEND`], unused.
    pub jitter: [f32; 4],
}

/// Which sample of its pixels a dispatch traces, and how it lands in the frame buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSample {
    /// The sample index: seeds (bundle rotations) and the refinement jitter depend on it and on
    /// the pixel only, never on who traced it.
    pub index: u32,
    /// `FRAME_*` flags (0: the output buffer only).
    pub flags: u32,
    /// Sub-pixel offset from the pixel centre.
    pub jitter: [f32; 2],
    /// The blend weight α of [`FRAME_BLEND`].
    pub alpha: f32,
}

impl Launch {
    /// One pass over everything in `rect`: the readback kernels' dispatch.
    pub fn whole(rect: [u32; 4]) -> Launch {
        Launch { rect, pass_range: WHOLE_PASS, ..Launch::default() }
    }

    fn with_sample(pass_range: [u32; 4], s: PixelSample) -> Launch {
        Launch {
            pass_range,
            sample: [s.index, s.flags, 0, 0],
            jitter: [s.jitter[0], s.jitter[1], s.alpha, 0.0],
            ..Launch::default()
        }
    }

    /// `render` over `rect` in pass `pass_range`. `work`: the threads its rows of tiles are dealt
    /// to, set by `recording::Dispatch::dealt`.
    pub fn bands(rect: [u32; 4], pass_range: [u32; 4], s: PixelSample) -> Launch {
        Launch { rect, ..Self::with_sample(pass_range, s) }
    }

    /// `render_queue`: `work` = chunks in the boundary array, tiles per workgroup (its budget),
    /// tile columns, the loop budget a workgroup stops taking chunks at.
    pub fn queue(
        pass_range: [u32; 4],
        s: PixelSample,
        chunks: u32,
        budget: u32,
        columns: u32,
        loops: u32,
    ) -> Launch {
        Launch { work: [chunks, budget, columns, loops], ..Self::with_sample(pass_range, s) }
    }

    /// `render_slice`: `work` = the slice's first position and length, the order's kind
    /// ([`ORDER_TABLE`] or [`ORDER_DISSOLVE`]) and the dissolve's bits; the dissolve's register
    /// at the first position in `sample[2]`.
    pub fn slice(
        pass_range: [u32; 4],
        s: PixelSample,
        first: u32,
        len: u32,
        order: u32,
        bits: u32,
        state: u32,
    ) -> Launch {
        let mut l = Self::with_sample(pass_range, s);
        l.work = [first, len, order, bits];
        l.sample[2] = state;
        l
    }

    /// This launch with its output written from eye ray `base` on: eye ray `i` lands in output
    /// vec4 `i - base` (a piece of a large picture in an output buffer that holds only it).
    pub fn at_base(self, base: u32) -> Launch {
        let mut l = self;
        l.sample[3] = base;
        l
    }

    /// `resolve_frame`: `work` = the pixels of the frame and the first this dispatch resolves,
    /// their output into the frame buffer.
    pub fn resolve(first: u32, pixels: u32, s: PixelSample) -> Launch {
        Launch { work: [pixels, first, 0, 0], ..Self::with_sample([0; 4], s) }
    }
}

/// `Launch::pass_range` of a single pass over all of a pixel's bundle samples.
pub const WHOLE_PASS: [u32; 4] = [0, u32::MAX, 1, 1];

/// The bands' workgroup (`render` in shaders/trace.wgsl): 4 pixels wide and 16 tall, 64
/// invocations. Lavapipe cuts its 8-lane SIMD groups from the linear local index (Mesa ≥ 24.1),
/// so each group is a 4×2 block of pixels instead of an 8×1 row: closer
/// rays, fewer lanes waiting on a neighbour's longer walk.
pub const RENDER_TILE: [u32; 2] = [4, 16];

/// Tiles of the conventional mode: 32×2 pixels, RTRT's own; one workgroup traces one tile.
pub const TILE_W: u32 = 32;
pub const TILE_H: u32 = 2;

/// The most tiles a chunk of the conventional queue holds: a schedule's larger chunks (RTRT's
/// with few workers: 351 tiles for P = 2 at 1280×720) are cut into pieces this size, so that one
/// chunk stays well inside lavapipe's loop limit (docs/interactive.md).
pub const MAX_CHUNK_TILES: u32 = 16;

/// The loops whose SIMD efficiency a `Variant::simd_stats` kernel counts (shaders/trace.wgsl,
/// `loop_tick`), in the order of their counters: the accelerator's walk (BVH nodes, grid cells),
/// the candidates it hands out (a leaf's or a cell's primitives), the ray tree (one iteration a
/// ray shaded) and the lights (with the soft-shadow modes' samples).
pub const SIMD_LOOPS: [&str; 4] = ["walk", "candidates", "ray tree", "lights"];

/// The stats buffer (shaders/types.wgsl `stats`): the four ray counts, then from word
/// `STATS_SIMD_AT` per entry of [`SIMD_LOOPS`] two 64-bit counters (low word first):
/// lane-iterations in which the lane was active, and iterations its SIMD group ran.
pub const STATS_SIMD_AT: u32 = 4;
/// 32-bit words of the stats buffer.
pub const STATS_WORDS: u32 = STATS_SIMD_AT + 4 * SIMD_LOOPS.len() as u32;
// The shader keeps the loops' counters in a vec4u each (shaders/trace.wgsl).
const _: () = assert!(SIMD_LOOPS.len() == 4);

/// `Launch::sample[1]` flags: the pixel's last pass writes the frame buffer …
pub const FRAME_WRITE: u32 = 1;
/// … adding its sample to the sum (progressive refinement; alpha counts samples) …
pub const FRAME_ACCUMULATE: u32 = 2;
/// … or blending it into the old value with weight `Launch::jitter[2]` …
pub const FRAME_BLEND: u32 = 4;
/// … and tracing two of four sub-pixel positions per visit (the paper's frameless jitter).
pub const FRAME_JITTER_PAIRS: u32 = 8;
/// A slice's output is compact: position i of the slice in output vec4 i, not at its pixel (what
/// a distributed worker reads back as one range).
pub const OUT_COMPACT: u32 = 16;

/// `Launch::work[2]` of `render_slice`: the pixel order is a table in the work buffer …
pub const ORDER_TABLE: u32 = 0;
/// … or the dissolve's LFSR, its jump matrices in the work buffer.
pub const ORDER_DISSOLVE: u32 = 1;

/// lavapipe (gallivm) stops every loop of a shader invocation once the loops together have run
/// 65535 iterations (`LP_MAX_TGSI_LOOP_ITERATIONS`, shared by all loops of the shader; it exists
/// to stop hangs). Renders past it are silently wrong, so the render kernel counts its loop
/// iterations into the output's alpha and the renderer checks them against this.
pub const LAVAPIPE_LOOP_LIMIT: u32 = 65535;
/// Bundle samples per pass: shadow bundles are split over passes so that no invocation comes
/// near [`LAVAPIPE_LOOP_LIMIT`] (each sample is a grid walk of tens of iterations, per shading
/// point of the ray tree). The light term is linear in the visibility, so passes add up exactly.
pub const BUNDLE_SAMPLES_PER_PASS: u32 = 16;

/// Relative offset of spawned rays along the geometric normal (docs/shading.md, "Ray origins").
pub const RAY_OFFSET_REL: f32 = 1e-4;

/// The scene and grid as texels, with where each section starts.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedScene {
    pub texels: Vec<[u32; 4]>,
    pub prim_base: [u32; 4],
    pub aux_base: [u32; 4],
    pub accel_base: [u32; 4],
    /// First texel of each light's shell section (shell shadow mode; empty otherwise).
    pub shell_sections: Vec<u32>,
    /// With a BVH, the lattice its compact nodes were quantised to ([`params`] hands it to the
    /// shader).
    pub bvh_lattice: Option<BvhLattice>,
    /// First texel of the volume records (`layout::volume`).
    pub volume_base: u32,
    /// The patches (`layout::patch`): first leaf texel, leaf count, degree, 0.
    pub patch: [u32; 4],
}

impl PackedScene {
    /// Rows for `texels.len()` at [`SCENE_TEX_WIDTH`] texels per row, across layers (at least 1).
    pub fn rows(&self) -> u32 {
        rows_of(self.texels.len())
    }
}

/// Rows that `texels` texels take at [`SCENE_TEX_WIDTH`] a row (at least 1).
pub fn rows_of(texels: usize) -> u32 {
    (texels as u64).div_ceil(SCENE_TEX_WIDTH as u64).max(1) as u32
}

/// The scene texture's rows per layer, its layers, and whether it is layered, for `rows` rows on
/// a device whose largest side is `max_side`: one plain 2D texture of just the rows needed while
/// they fit, else a 2D array of [`SCENE_LAYER_ROWS`]-row layers.
pub fn scene_extent(rows: u32, max_side: u32) -> (u32, u32, bool) {
    if rows <= max_side {
        (rows.max(1), 1, false)
    } else {
        (SCENE_LAYER_ROWS, rows.div_ceil(SCENE_LAYER_ROWS), true)
    }
}

/// The accelerator packed into `params` (`Params::macro_res[3]`).
pub fn accel_code(params: &Params) -> u32 {
    params.macro_res[3]
}

/// Points `p` at `cam` (eye, frame, image size; positions relative to `origin` as the scene
/// was packed): what a moving camera changes between dispatches.
pub fn set_camera(p: &mut Params, cam: &crate::scene::Camera, origin: DVec3) {
    let b = cam.basis();
    p.eye = v4(cam.eye - origin, 0.0);
    p.cam_u = v4(b.u, 0.0);
    p.cam_v = v4(b.v, 0.0);
    p.cam_w = v4(b.w, 0.0);
    p.image[0] = cam.width;
    p.image[1] = cam.height;
    p.eye_grid = eye_grid(cam.width, cam.height, p.eye_grid[2] != 0);
}

/// `Params::eye_grid` for an image of `width` x `height` pixels: rays through the pixel centres,
/// or through the pixel corners (one more column and row: the image's edges are sampled too).
pub fn eye_grid(width: u32, height: u32, corners: bool) -> [u32; 4] {
    let extra = corners as u32;
    [width + extra, height + extra, extra, 0]
}

/// `v` as the f32 vec4 the shaders read, `w` last.
pub(crate) fn v4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

/// `v` rounded to f32, as the bits of a texel's first three words, `w` last.
pub(crate) fn f32_bits(v: DVec3, w: u32) -> [u32; 4] {
    [(v.x as f32).to_bits(), (v.y as f32).to_bits(), (v.z as f32).to_bits(), w]
}
