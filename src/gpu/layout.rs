//! Byte-exact GPU data: the uniform structs (mirrored in `shaders/types.wgsl`, tied by a test
//! against naga's layouter) and the packing of scene and grid into one `rgba32uint` texture.
//!
//! Why a texture: on lavapipe a storage-buffer load in a hot loop costs ~2x a texture load and
//! uniform buffers are too small for scenes (LAVAPIPE.md). Every record is whole texels
//! (vec4<u32>), so each traversal step costs as few load instructions as possible; floats are
//! stored as their bits and `bitcast` back in the shader.

use crate::accel::bvh::NodeKind;
use crate::accel::{AccelRef, Bvh, BvhWalk, PrimKind, PrimRef};
use crate::scene::{
    bundle_samples, light_shells, Filter, MaterialKind, Scene, ShadowMode, ShellShape, Wrap, MAX_BUNDLE,
    MAX_LIGHTS,
};
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
/// A shell object (shell shadow mode): bounding sphere, record.
pub const SHELL_OBJECT_TEXELS: u32 = 2;
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
    pub grid_min: [f32; 4],
    pub grid_max: [f32; 4],
    pub grid_cell: [f32; 4],
    pub grid_inv_cell: [f32; 4],
    /// xyz cells per axis (w unused: the fine cells per macro-cell side are the WGSL constant
    /// `MACRO_FACTOR`, which the shader divides by without a run-time divide).
    pub grid_res: [u32; 4],
    /// xyz macro-cells per axis; w the accelerator ([`ACCEL_GRID`], [`ACCEL_BVH`],
    /// [`ACCEL_BVH_STACKLESS`]). With a BVH, `grid_min`/`grid_max` are its root box and the
    /// other grid fields 0.
    pub macro_res: [u32; 4],
    /// First texel of the sphere, triangle, vertex-normal and material records.
    pub prim_base: [u32; 4],
    /// First texel of the cone records, texture-coordinate records, texture records and texture
    /// pixels.
    pub aux_base: [u32; 4],
    /// First texel of the cell ranges, primitive references, macro-cell bits and shadow-bundle
    /// points; with a BVH: of its nodes, its references, the node count, the bundle points.
    pub grid_base: [u32; 4],
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
}

/// What one dispatch covers and how its pixels update the frame buffer. Mirrors `struct Tile` in
/// `shaders/types.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Tile {
    /// x0, y0, width, height in pixels (the headless bands' `render` entry point).
    pub rect: [u32; 4],
    /// Bundle samples `[first, end)` this pass traces (end clamped to the bundle size), whether
    /// it is the first pass (which writes ambient, background and ray counts; later passes add
    /// their share of the light to the output) and whether it is the last (which updates the
    /// frame buffer). See [`Tile::whole`].
    pub pass_range: [u32; 4],
    /// `render`: threads the rows of tiles are dealt to (1: in order; `backend::Dispatch::dealt`),
    /// unused ×3. `render_queue`: chunks in the boundary array, tiles
    /// per workgroup (its budget), tile columns, unused. `render_slice`: first position, positions, [`ORDER_TABLE`] or
    /// [`ORDER_DISSOLVE`], the dissolve's bits.
    pub work: [u32; 4],
    /// Progressive-refinement sample index, frame flags (`FRAME_*`), the dissolve's state at the
    /// slice's first position, unused.
    pub sample: [u32; 4],
    /// Sub-pixel offset of this sample from the pixel centre (x, y), the blend weight α of new
    /// samples with [`FRAME_BLEND`], unused.
    pub jitter: [f32; 4],
}

impl Tile {
    /// One pass over everything: what a single dispatch of `rect` means.
    pub fn whole(rect: [u32; 4]) -> Tile {
        Tile { rect, pass_range: [0, u32::MAX, 1, 1], ..Tile::default() }
    }
}

/// Tiles of the conventional mode: 32×2 pixels, RTRT's own; one workgroup traces one tile.
/// The band renderer's workgroup (`render` in shaders/trace.wgsl): 4 pixels wide and 16 tall, 64
/// invocations. Lavapipe cuts its 8-lane SIMD groups from the linear local index (Mesa ≥ 24.1,
/// ../shared/LAVAPIPE.md), so each group is a 4×2 block of pixels instead of an 8×1 row: closer
/// rays, fewer lanes waiting on a neighbour's longer walk (docs/performance.md, "Lane shape").
pub const RENDER_TILE: [u32; 2] = [4, 16];

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

/// `Tile::sample[1]` flags: the pixel's last pass writes the frame buffer …
pub const FRAME_WRITE: u32 = 1;
/// … adding its sample to the sum (progressive refinement; alpha counts samples) …
pub const FRAME_ACCUMULATE: u32 = 2;
/// … or blending it into the old value with weight `Tile::jitter[2]` …
pub const FRAME_BLEND: u32 = 4;
/// … and tracing two of four sub-pixel positions per visit (the paper's frameless jitter).
pub const FRAME_JITTER_PAIRS: u32 = 8;

/// `Tile::work[2]` of `render_slice`: the pixel order is a table in the work buffer …
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

fn v4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn f4(v: DVec3, w: u32) -> [u32; 4] {
    [(v.x as f32).to_bits(), (v.y as f32).to_bits(), (v.z as f32).to_bits(), w]
}

/// The scene and grid as texels, with where each section starts.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedScene {
    pub texels: Vec<[u32; 4]>,
    pub prim_base: [u32; 4],
    pub aux_base: [u32; 4],
    pub grid_base: [u32; 4],
    /// First texel of each light's shell section (shell shadow mode; empty otherwise).
    pub shell_sections: Vec<u32>,
    /// With a BVH, the lattice its compact nodes were quantised to ([`params`] hands it to the
    /// shader).
    pub bvh_lattice: Option<BvhLattice>,
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

/// The point of a sphere's surface nearest `eye` (any point when the eye is at the centre), in
/// f64: `intersect_sphere` measures from it.
pub fn sphere_anchor(center: DVec3, radius: f64, eye: DVec3) -> DVec3 {
    center + radius * (eye - center).try_normalize().unwrap_or(DVec3::Y)
}

/// Positions are stored relative to `origin` (see `GpuScene::upload_at`).
/// Lays out, in order: spheres, triangles, vertex normals, materials, cones, cell ranges,
/// references, macro-cell bits. Record formats (the shader's `scene.wgsl` decodes the same):
/// - sphere: `[c.xyz, r]`, `[material, anchor.xyz]` (`sphere_anchor`)
/// - triangle: `[p0.xyz, material]`, `[p1.xyz, normal_record or NO_NORMALS]`,
///   `[p2.xyz, uv_record or NO_UVS]`
/// - vertex normals: `[n0.xyz, 0]`, `[n1.xyz, 0]`, `[n2.xyz, 0]`
/// - material: `[colour.rgb, kind]`, `[eta, exponent, texture or NO_TEXTURE, 0]`
/// - cone: `[base.xyz, base_radius]`, `[axis.xyz, apex_radius]`, `[material, 0, 0, 0]`, where
///   `axis = apex - base` is formed in f64: rounding it, rather than the apex, keeps a short
///   cone's axis accurate far from the origin.
/// - texture coordinates: `[u0, v0, u1, v1]`, `[u2, v2, 0, 0]`
/// - texture: `[first pixel, width, height, flags]` (`wrap_code`, `filter_code`, placed by
///   `TEXTURE_WRAP_V_SHIFT`, `TEXTURE_FILTER_SHIFT`); pixels: the RGBA8 texels of every texture as u32 (r in the low byte,
///   `unpack4x8unorm`'s order), four per texel, each texture starting at its first pixel.
/// - cells: `[start0, count0, start1, count1]`; refs: four `PrimRef`s; macro bits: four words.
/// - shadow-bundle points (bundle mode only): `[x0, y0, x1, y1]` on the unit disc.
/// - shell sections (shell mode only), one per light (`scene::light_shells`):
///   `[objects, first cell texel, first list texel, 0]`,
///   then per object `[bound centre.xyz, bound radius]`, `[prim, a, b, c]` where `prim` is the
///   `PrimRef` of a sphere or cone (its record is the bound for spheres) or of a mesh's first
///   triangle, with `a` its end triangle and `[b, c)` the texels of its contour edges; then the
///   edges, `[a.xyz, 0]`, `[b.xyz, 0]`; then the light buffer's cells (`scene::shell_cell`),
///   `[first, count, cones, meshes]` into the list (its spheres come first, its cones from
///   `cones` on, its meshes from `meshes` on), and the list: object indices, four per texel.
///
/// With a BVH (`accel`), its nodes ([`BvhNode`], [`bvh_nodes`]) and references (four per texel)
/// take the place of the cells, references and macro bits.
pub fn pack_scene<'a>(scene: &Scene, accel: impl Into<AccelRef<'a>>, origin: DVec3) -> PackedScene {
    let accel = accel.into();
    // Sized exactly up front (the shell sections reserve their own): a large mesh's texels are
    // most of the host's memory, and a growing Vec would double them for a moment.
    let with = |has: fn(&crate::scene::Mesh) -> bool| -> usize {
        scene.meshes.iter().filter(|m| has(m)).map(|m| m.indices.len()).sum()
    };
    let (normal_tris, uv_tris) = (with(|m| m.normals.is_some()), with(|m| m.uvs.is_some()));
    let pixels = scene.textures.iter().map(|t| t.texels.len()).sum::<usize>();
    let accel_texels = accel_texels(accel);
    let bundle = match scene.trace.shadows {
        ShadowMode::Bundle { samples, .. } => samples as usize,
        _ => 0,
    };
    let capacity = SPHERE_TEXELS as usize * scene.spheres.len()
        + (TRIANGLE_TEXELS as usize) * scene.triangle_count()
        + NORMAL_TEXELS as usize * normal_tris
        + MATERIAL_TEXELS as usize * scene.materials.len()
        + 3 * scene.cones.len()
        + UV_TEXELS as usize * uv_tris
        + scene.textures.len()
        + pixels.div_ceil(PIXELS_PER_TEXEL as usize)
        + accel_texels
        + bundle.div_ceil(2);
    let mut t: Vec<[u32; 4]> = Vec::with_capacity(capacity);
    let sphere_base = 0u32;
    for s in &scene.spheres {
        t.push(f4(s.center - origin, (s.radius as f32).to_bits()));
        let anchor = f4(sphere_anchor(s.center, s.radius, origin) - origin, 0);
        t.push([s.material, anchor[0], anchor[1], anchor[2]]);
    }
    let triangle_base = t.len() as u32;
    // Normal and uv records are numbered in triangle order; their sections are filled after.
    let (mut normal_records, mut uv_records) = (0u32, 0u32);
    let next = |present: bool, counter: &mut u32, none: u32| {
        if present {
            *counter += 1;
            *counter - 1
        } else {
            none
        }
    };
    for tri in scene.triangles() {
        let normal_record = next(tri.n.is_some(), &mut normal_records, NO_NORMALS);
        let uv_record = next(tri.uv.is_some(), &mut uv_records, NO_UVS);
        t.push(f4(tri.p[0] - origin, tri.material));
        t.push(f4(tri.p[1] - origin, normal_record));
        t.push(f4(tri.p[2] - origin, uv_record));
    }
    let normal_base = t.len() as u32;
    for n in scene.triangles().filter_map(|tri| tri.n) {
        t.extend(n.iter().map(|v| f4(*v, 0)));
    }
    let material_base = t.len() as u32;
    for m in &scene.materials {
        let code = material_code(&m.kind);
        let (colour, eta, exponent) = match m.kind {
            MaterialKind::Diffuse { color } => (color, 1.0, 0.0),
            MaterialKind::Metal { color, exponent } => (color, 1.0, exponent),
            MaterialKind::Dielectric { eta, exponent } => (DVec3::ONE, eta, exponent),
            MaterialKind::Polished { color, eta, exponent } => (color, eta, exponent),
        };
        t.push(f4(colour, code));
        let texture = m.texture.unwrap_or(NO_TEXTURE);
        t.push([(eta as f32).to_bits(), (exponent as f32).to_bits(), texture, 0]);
    }
    let cone_base = t.len() as u32;
    for c in &scene.cones {
        t.push(f4(c.base - origin, (c.base_radius as f32).to_bits()));
        t.push(f4(c.apex - c.base, (c.apex_radius as f32).to_bits()));
        t.push([c.material, 0, 0, 0]);
    }
    let uv_base = t.len() as u32;
    for uv in scene.triangles().filter_map(|tri| tri.uv) {
        let b = uv.map(|v| [(v.x as f32).to_bits(), (v.y as f32).to_bits()]);
        t.push([b[0][0], b[0][1], b[1][0], b[1][1]]);
        t.push([b[2][0], b[2][1], 0, 0]);
    }
    let texture_base = t.len() as u32;
    let mut first = 0u32;
    for tex in &scene.textures {
        let flags = wrap_code(tex.wrap[0])
            | wrap_code(tex.wrap[1]) << TEXTURE_WRAP_V_SHIFT
            | filter_code(tex.filter) << TEXTURE_FILTER_SHIFT;
        t.push([first, tex.width, tex.height, flags]);
        first += tex.texels.len() as u32;
    }
    let pixel_base = t.len() as u32;
    let pixels: Vec<u32> =
        scene.textures.iter().flat_map(|tex| tex.texels.iter().map(|&p| u32::from_le_bytes(p))).collect();
    for chunk in pixels.chunks(PIXELS_PER_TEXEL as usize) {
        let mut texel = [0u32; 4];
        texel[..chunk.len()].copy_from_slice(chunk);
        t.push(texel);
    }
    let (accel_base, bvh_lattice) = push_accel(&mut t, accel, origin);
    let bundle_base = push_bundle(&mut t, scene.trace.shadows);
    let mut shell_sections = vec![];
    if let ShadowMode::Shell { .. } = scene.trace.shadows {
        for light in &scene.lights {
            let sh = light_shells(scene, light.position, light.radius);
            let section = t.len() as u32;
            shell_sections.push(section);
            let edge_base = section + 1 + SHELL_OBJECT_TEXELS * sh.objects.len() as u32;
            let cell_base = edge_base + SHELL_EDGE_TEXELS * sh.edges.len() as u32;
            let list_base = cell_base + sh.cells.len() as u32;
            let listed = sh.cells.iter().map(Vec::len).sum::<usize>();
            t.reserve_exact((list_base - section) as usize + listed.div_ceil(4));
            t.push([sh.objects.len() as u32, cell_base, list_base, 0]);
            for o in &sh.objects {
                t.push(f4(o.center - origin, (o.radius as f32).to_bits()));
                t.push(match o.shape {
                    ShellShape::Sphere(i) => [PrimRef::new(PrimKind::Sphere, i).0, 0, 0, 0],
                    ShellShape::Cone(i) => [PrimRef::new(PrimKind::Cone, i).0, 0, 0, 0],
                    ShellShape::Mesh { triangles, edges } => [
                        PrimRef::new(PrimKind::Triangle, triangles[0]).0,
                        triangles[1],
                        edge_base + SHELL_EDGE_TEXELS * edges[0],
                        edge_base + SHELL_EDGE_TEXELS * edges[1],
                    ],
                });
            }
            for [a, b] in &sh.edges {
                t.push(f4(*a - origin, 0));
                t.push(f4(*b - origin, 0));
            }
            // A cell's list holds its spheres, then its cones, then its meshes (objects are in
            // that order and every list in object order), each kind visited by a loop of its own.
            let mut first = 0u32;
            for cell in &sh.cells {
                let before = |kind: fn(&ShellShape) -> bool| {
                    cell.iter().filter(|&&k| kind(&sh.objects[k as usize].shape)).count() as u32
                };
                let cones_from = before(|s| matches!(s, ShellShape::Sphere(_)));
                let meshes_from = cones_from + before(|s| matches!(s, ShellShape::Cone(_)));
                debug_assert!(cell.windows(2).all(|w| w[0] < w[1]), "a cell's list in object order");
                t.push([first, cell.len() as u32, cones_from, meshes_from]);
                first += cell.len() as u32;
            }
            let list: Vec<u32> = sh.cells.concat();
            for chunk in list.chunks(4) {
                let mut texel = [0u32; 4];
                texel[..chunk.len()].copy_from_slice(chunk);
                t.push(texel);
            }
        }
    }
    PackedScene {
        texels: t,
        prim_base: [sphere_base, triangle_base, normal_base, material_base],
        aux_base: [cone_base, uv_base, texture_base, pixel_base],
        grid_base: [accel_base[0], accel_base[1], accel_base[2], bundle_base],
        shell_sections,
        bvh_lattice,
    }
}

/// Texels of `accel`'s section ([`push_accel`]).
fn accel_texels(accel: AccelRef) -> usize {
    match accel {
        AccelRef::Grid(grid) => {
            (grid.cell_start.len() - 1).div_ceil(CELLS_PER_TEXEL as usize)
                + grid.prim_refs.len().div_ceil(REFS_PER_TEXEL as usize)
                + grid.macro_bits.len().div_ceil(4)
        }
        AccelRef::Bvh(bvh, walk) => {
            let node_texels = match walk {
                BvhWalk::Stack => BVH_NODE_TEXELS,
                BvhWalk::Stackless => BVH_QNODE_TEXELS,
            };
            node_texels as usize * bvh.nodes.len() + bvh_leaves(bvh).count().max(1)
        }
    }
}

/// An accelerator's section of the scene texture packed on its own, for [`swap_accel`] (the
/// viewer's background BVH build packs it on its own thread): its texels, its `grid_base` words
/// counted from its start, and a BVH's lattice.
pub struct AccelSection {
    texels: Vec<[u32; 4]>,
    bases: [u32; 3],
    /// The third base is a BVH's node count, not a texel index.
    counted: bool,
    lattice: Option<BvhLattice>,
}

/// `accel`'s section as [`pack_scene`] packs it, positions relative to `origin`.
pub fn pack_accel<'a>(accel: impl Into<AccelRef<'a>>, origin: DVec3) -> AccelSection {
    let accel = accel.into();
    // Room for what [`swap_accel`] and the upload add around it in place (a copy of 24M texels
    // took 0.21 s of a 16M-triangle scene's 0.54 s swap): the head of its first row (less than
    // a row), the bundle's sample pairs, and the padding of its last row.
    let room = 2 * SCENE_TEX_WIDTH as usize + MAX_BUNDLE.div_ceil(2) as usize;
    let mut texels = Vec::with_capacity(accel_texels(accel) + room);
    let (bases, lattice) = push_accel(&mut texels, accel, origin);
    AccelSection { texels, bases, counted: matches!(accel, AccelRef::Bvh(..)), lattice }
}

/// What a packed scene keeps when its accelerator is swapped ([`PackedScene::prefix`]): all the
/// texels before the accelerator's section stay on the device; the host keeps only the part of
/// the section's first row before it, so that the new section can be written from a whole row.
pub struct Prefix {
    head: Vec<[u32; 4]>,
    at: u32,
    prim_base: [u32; 4],
    aux_base: [u32; 4],
}

impl PackedScene {
    /// What [`swap_accel`] needs to put another accelerator in this packing's place; `None` with
    /// shell shadows, whose sections follow the accelerator's and point at texels by index.
    pub fn prefix(&self) -> Option<Prefix> {
        if !self.shell_sections.is_empty() {
            return None;
        }
        let at = self.grid_base[0];
        let row = at / SCENE_TEX_WIDTH * SCENE_TEX_WIDTH;
        let head = self.texels[row as usize..at as usize].to_vec();
        Some(Prefix { head, at, prim_base: self.prim_base, aux_base: self.aux_base })
    }
}

/// Rows that `packed` needs at most with a stackless BVH over its `prims` primitives in place of
/// its accelerator: a leaf holds at least one primitive, so there are at most 2n - 1 nodes of
/// one texel and n texels of references (SPD balls' SAH leaves hold one sphere each: 3n).
pub fn bvh_rows_bound(packed: &PackedScene, prims: usize) -> u32 {
    let bundle = packed.texels.len() - packed.grid_base[3] as usize;
    rows_of(packed.grid_base[0] as usize + 3 * prims.max(1) + bundle)
}

/// The scene of `prefix` with `section` as its accelerator: the row to write from and the packed
/// texels from that row on (`PackedScene::texels` holding only those), the same texels
/// [`pack_scene`] would give there, with the bases and lattice [`params`] reads.
pub fn swap_accel(prefix: &Prefix, section: AccelSection, shadows: ShadowMode) -> (u32, PackedScene) {
    let row = prefix.at / SCENE_TEX_WIDTH;
    // In place: `pack_accel` left room for the head.
    let mut t = section.texels;
    t.splice(0..0, prefix.head.iter().copied());
    let start = row * SCENE_TEX_WIDTH;
    let bundle_base = start + push_bundle(&mut t, shadows);
    let [a, b, c] = section.bases;
    let third = if section.counted { c } else { prefix.at + c };
    let packed = PackedScene {
        texels: t,
        prim_base: prefix.prim_base,
        aux_base: prefix.aux_base,
        grid_base: [prefix.at + a, prefix.at + b, third, bundle_base],
        shell_sections: vec![],
        bvh_lattice: section.lattice,
    };
    (row, packed)
}

/// Appends `accel`'s section to `t`: its `grid_base` words (texel indices into `t`; a BVH's
/// third word is its node count) and, for a BVH, the lattice its nodes are quantised to. Nothing
/// in it depends on where it lands: its links count from its own bases, so it can be packed
/// apart ([`pack_accel`]).
fn push_accel(t: &mut Vec<[u32; 4]>, accel: AccelRef, origin: DVec3) -> ([u32; 3], Option<BvhLattice>) {
    let mut bvh_lattice = None;
    let bases = match accel {
        AccelRef::Grid(grid) => {
            let cells = grid.cell_start.len() - 1;
            let cell_base = t.len() as u32;
            for first in (0..cells).step_by(CELLS_PER_TEXEL as usize) {
                let mut texel = [0u32; 4];
                for (k, c) in (first..cells.min(first + CELLS_PER_TEXEL as usize)).enumerate() {
                    texel[2 * k] = grid.cell_start[c];
                    texel[2 * k + 1] = grid.cell_start[c + 1] - grid.cell_start[c];
                }
                t.push(texel);
            }
            let ref_base = push_refs(t, &grid.prim_refs);
            let macro_base = t.len() as u32;
            for chunk in grid.macro_bits.chunks(4) {
                let mut texel = [0u32; 4];
                texel[..chunk.len()].copy_from_slice(chunk);
                t.push(texel);
            }
            [cell_base, ref_base, macro_base]
        }
        AccelRef::Bvh(bvh, walk) => {
            let node_base = t.len() as u32;
            let nodes = bvh_nodes(bvh, origin);
            let lattice = BvhLattice::of_nodes(&nodes);
            match walk {
                BvhWalk::Stack => {
                    // Its shader takes the left child for the lower centroids along `axis`.
                    debug_assert!(
                        bvh.nodes.iter().all(|n| !matches!(n.kind, NodeKind::Inner { swapped: true, .. })),
                        "the stack walk's tree keeps the builder's order"
                    );
                    for n in nodes {
                        let [a, b]: [[u32; 4]; 2] = bytemuck::cast(n);
                        t.push(a);
                        t.push(b);
                    }
                }
                BvhWalk::Stackless => t.extend(nodes.iter().map(|n| quantise_node(n, &lattice))),
            }
            bvh_lattice = Some(lattice);
            // One texel of references per leaf (at most `MAX_LEAF` = 4), in node order: a leaf
            // reads its list with one fetch.
            let ref_base = t.len() as u32;
            for (first, count) in bvh_leaves(bvh) {
                let mut texel = [0u32; 4];
                for (k, r) in bvh.refs[first as usize..(first + count) as usize].iter().enumerate() {
                    texel[k] = r.0;
                }
                t.push(texel);
            }
            if t.len() as u32 == ref_base {
                t.push([0; 4]);
            }
            [node_base, ref_base, bvh.nodes.len() as u32]
        }
    };
    (bases, bvh_lattice)
}

/// Appends the bundle shadow mode's sample pairs (nothing in the other modes); returns where
/// they start.
fn push_bundle(t: &mut Vec<[u32; 4]>, shadows: ShadowMode) -> u32 {
    let bundle_base = t.len() as u32;
    if let ShadowMode::Bundle { samples, .. } = shadows {
        for pair in bundle_samples(samples).chunks(2) {
            let xy = |k: usize| pair.get(k).map_or([0, 0], |p| p.map(|v| (v as f32).to_bits()));
            let (a, b) = (xy(0), xy(1));
            t.push([a[0], a[1], b[0], b[1]]);
        }
    }
    bundle_base
}

/// The frame constants for `scene` drawn with `grid` laid out as in `packed`, positions relative
/// to `origin` as in [`pack_scene`].
pub fn params<'a>(
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    packed: &PackedScene,
    origin: DVec3,
) -> Params {
    let cam = &scene.camera;
    let mut lights = [GpuLight::default(); MAX_LIGHTS];
    for (i, (g, l)) in lights.iter_mut().zip(&scene.lights).enumerate() {
        g.position_radius = v4(l.position - origin, l.radius as f32);
        let section = packed.shell_sections.get(i).copied().unwrap_or(0);
        g.color = v4(l.color, f32::from_bits(section));
    }
    let mut p = Params {
        eye: [0.0; 4],
        cam_u: [0.0; 4],
        cam_v: [0.0; 4],
        cam_w: [0.0; 4],
        ambient_sky: v4(scene.ambient.sky, 0.0),
        ambient_ground: v4(scene.ambient.ground, 0.0),
        ambient_up: v4(scene.ambient.up.normalize(), 0.0),
        background: v4(scene.background, 0.0),
        grid_min: [0.0; 4],
        grid_max: [0.0; 4],
        grid_cell: [0.0; 4],
        grid_inv_cell: [0.0; 4],
        grid_res: [0; 4],
        macro_res: [0; 4],
        prim_base: packed.prim_base,
        aux_base: packed.aux_base,
        grid_base: packed.grid_base,
        image: [cam.width, cam.height, scene.trace.max_depth, scene.lights.len() as u32],
        eye_grid: eye_grid(cam.width, cam.height, false),
        trace: [scene.trace.weight_cutoff as f32, RAY_OFFSET_REL, 0.0, 0.0],
        shadow: match scene.trace.shadows {
            ShadowMode::Hard => [0; 4],
            ShadowMode::Bundle { samples, rotate } => [1, samples, rotate as u32, 0],
            ShadowMode::Shell { falloff, combine } => [2, 0, 0, falloff as u32 | (combine as u32) << 8],
        },
        lights,
    };
    match accel.into() {
        AccelRef::Grid(grid) => {
            let res = grid.res;
            p.grid_min = v4(grid.min - origin, 0.0);
            p.grid_max = v4(grid.max - origin, 0.0);
            p.grid_cell = v4(grid.cell_size, 0.0);
            p.grid_inv_cell = v4(grid.cell_size.recip(), 0.0);
            p.grid_res = [res[0], res[1], res[2], 0];
            p.macro_res = [grid.macro_res[0], grid.macro_res[1], grid.macro_res[2], ACCEL_GRID];
        }
        AccelRef::Bvh(bvh, walk) => {
            let lattice = packed.bvh_lattice.unwrap_or_else(|| BvhLattice::of(bvh, origin));
            p.grid_min = [lattice.base[0], lattice.base[1], lattice.base[2], 0.0];
            p.grid_max = [lattice.top[0], lattice.top[1], lattice.top[2], 0.0];
            p.grid_cell = [lattice.step[0], lattice.step[1], lattice.step[2], 0.0];
            p.macro_res[3] = match walk {
                BvhWalk::Stack => ACCEL_BVH,
                BvhWalk::Stackless => ACCEL_BVH_STACKLESS,
            };
        }
    }
    set_camera(&mut p, cam, origin);
    p
}

/// Appends `refs` to the scene texels, [`REFS_PER_TEXEL`] to a texel (the grid's cell lists and
/// the BVH's leaves alike); returns the texel they start at.
fn push_refs(t: &mut Vec<[u32; 4]>, refs: &[PrimRef]) -> u32 {
    let base = t.len() as u32;
    for chunk in refs.chunks(REFS_PER_TEXEL as usize) {
        let mut texel = [0u32; 4];
        for (k, r) in chunk.iter().enumerate() {
            texel[k] = r.0;
        }
        t.push(texel);
    }
    base
}

/// The device's nodes of `bvh`, boxes relative to `origin`: each rounded outward to f32 and
/// grown by a margin (`BVH_MARGIN_ULPS`, `BVH_MARGIN_REL`), so that a ray the f32 slab test
/// misses misses the box in exact arithmetic too, with room for the primitives' own rounding.
/// A leaf's `a` is its reference texel: leaves in node order, one texel each.
pub fn bvh_nodes(bvh: &Bvh, origin: DVec3) -> Vec<BvhNode> {
    let mut leaf = 0u32;
    bvh.nodes
        .iter()
        .map(|n| {
            let (lo, hi) = node_box(n, origin);
            let (a, b) = match n.kind {
                NodeKind::Inner { axis, right, escape, .. } => {
                    (escape, BVH_INNER | (axis as u32) << BVH_AXIS_SHIFT | right)
                }
                NodeKind::Leaf { count, .. } => {
                    leaf += 1;
                    (leaf - 1, count)
                }
            };
            BvhNode { lo, a, hi, b }
        })
        .collect()
}

/// `n`'s box relative to `origin`, grown by the margin and rounded outward to f32.
fn node_box(n: &crate::accel::bvh::Node, origin: DVec3) -> ([f32; 3], [f32; 3]) {
    let down = |v: f64| {
        let f = v as f32;
        if (f as f64) > v {
            f.next_down()
        } else {
            f
        }
    };
    let up = |v: f64| {
        let f = v as f32;
        if (f as f64) < v {
            f.next_up()
        } else {
            f
        }
    };
    let (lo, hi) = (n.lo - origin, n.hi - origin);
    let magnitude = lo.abs().max(hi.abs()).max_element();
    let margin = BVH_MARGIN_ULPS * f32::EPSILON as f64 * magnitude + BVH_MARGIN_REL * (hi - lo).max_element();
    let (lo, hi) = (lo - margin, hi + margin);
    ([down(lo.x), down(lo.y), down(lo.z)], [up(hi.x), up(hi.y), up(hi.z)])
}

/// (first reference, count) of each leaf of `bvh`, in node order.
fn bvh_leaves(bvh: &Bvh) -> impl Iterator<Item = (u32, u32)> + '_ {
    bvh.nodes.iter().filter_map(|n| match n.kind {
        NodeKind::Leaf { first, count } => Some((first, count)),
        NodeKind::Inner { .. } => None,
    })
}

/// The lattice a compact node's box coordinates are steps of, per axis: `base + q · step` for q
/// in 0..=[`BVH_QUANT_MAX`], covering every node's f32 box ([`bvh_nodes`]). The shader decodes
/// with `fma(q, step, base)` in f32 (`Params::grid_min` and `grid_cell`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhLattice {
    pub base: [f32; 3],
    pub top: [f32; 3],
    pub step: [f32; 3],
}

impl BvhLattice {
    /// The lattice of `bvh`'s nodes packed relative to `origin`.
    pub fn of(bvh: &Bvh, origin: DVec3) -> Self {
        Self::of_nodes(&bvh_nodes(bvh, origin))
    }

    /// The lattice covering `nodes` (as [`bvh_nodes`] rounds them).
    pub fn of_nodes(nodes: &[BvhNode]) -> Self {
        let (mut base, mut top) = ([f32::MAX; 3], [f32::MIN; 3]);
        for n in nodes {
            let (lo, hi) = (n.lo, n.hi);
            for k in 0..3 {
                base[k] = base[k].min(lo[k]);
                top[k] = top[k].max(hi[k]);
            }
        }
        let mut step = [0f32; 3];
        for k in 0..3 {
            let mut s = ((top[k] as f64 - base[k] as f64) / BVH_QUANT_MAX as f64) as f32;
            while decoded(BVH_QUANT_MAX, s, base[k]).0 < top[k] {
                s = s.next_up();
            }
            step[k] = s;
        }
        BvhLattice { base, top, step }
    }
}

/// `a · b + c` rounded once. Without the FMA instruction in the build's target (the default
/// x86-64 target has none) `f32::mul_add` is a software routine of about a hundred cycles, which
/// was most of `pack_scene`'s time on a BVH scene (14 715 nodes of SPD balls_s4: 11 ms); the
/// CPU's own instruction, where it has one, gives the same bits.
fn fma(a: f32, b: f32, c: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        #[target_feature(enable = "fma")]
        fn hardware(a: f32, b: f32, c: f32) -> f32 {
            a.mul_add(b, c)
        }
        // SAFETY: the CPU has FMA (detected just above).
        return unsafe { hardware(a, b, c) };
    }
    a.mul_add(b, c)
}

/// The lowest and highest value the device may compute for `fma(q, step, base)` in f32: fused
/// (one rounding) or not (two), whichever its compiler emits.
fn decoded(q: u32, step: f32, base: f32) -> (f32, f32) {
    let fused = fma(q as f32, step, base);
    let split = q as f32 * step + base;
    (fused.min(split), fused.max(split))
}

/// The compact texel of `n` ([`BVH_QNODE_TEXELS`]): its box's lower corner rounded down and
/// upper corner rounded up to `lattice` steps, so the decoded box holds the f32 box however the
/// device rounds the decode; the link word from `n`'s escape or leaf texel and count.
pub fn quantise_node(n: &BvhNode, lattice: &BvhLattice) -> [u32; 4] {
    let mut q = [0u32; 6];
    for k in 0..3 {
        let (base, step) = (lattice.base[k], lattice.step[k]);
        let steps = |v: f32| if step > 0.0 { (v as f64 - base as f64) / step as f64 } else { 0.0 };
        let clamp = |v: f64| v.clamp(0.0, BVH_QUANT_MAX as f64) as u32;
        let mut lo = clamp(steps(n.lo[k]).floor());
        while lo > 0 && decoded(lo, step, base).1 > n.lo[k] {
            lo -= 1;
        }
        let mut hi = clamp(steps(n.hi[k]).ceil());
        while hi < BVH_QUANT_MAX && decoded(hi, step, base).0 < n.hi[k] {
            hi += 1;
        }
        q[k] = lo;
        q[3 + k] = hi;
    }
    let link = if n.b & BVH_INNER != 0 { BVH_INNER | n.a } else { n.b << BVH_COUNT_SHIFT | n.a };
    [q[0] | q[1] << 16, q[2] | q[3] << 16, q[4] | q[5] << 16, link]
}

/// The box the device decodes from a compact texel `t` (the f32 fma, fused), for tests.
pub fn decode_qnode(t: [u32; 4], lattice: &BvhLattice) -> ([f32; 3], [f32; 3]) {
    let q = [t[0] & 0xffff, t[0] >> 16, t[1] & 0xffff, t[1] >> 16, t[2] & 0xffff, t[2] >> 16];
    let at = |k: usize, v: u32| (v as f32).mul_add(lattice.step[k], lattice.base[k]);
    ([at(0, q[0]), at(1, q[1]), at(2, q[2])], [at(0, q[3]), at(1, q[4]), at(2, q[5])])
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
    s += &c("SHELL_OBJECT_TEXELS", SHELL_OBJECT_TEXELS);
    s += &c("SHELL_EDGE_TEXELS", SHELL_EDGE_TEXELS);
    s += &c("SHELL_CELL_RES", crate::scene::SHELL_CELL_RES);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{default_scene, ShadowMode};

    /// `pack_scene` sizes its texels before writing them (a growing Vec would briefly double a
    /// large mesh's memory); this keeps the up-front count in step with what is written.
    #[test]
    fn packed_scenes_are_allocated_exactly() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut scenes = vec![default_scene()];
        for name in ["textured.toml", "mesh.toml", "cones.toml"] {
            scenes.push(crate::io::load(&dir.join(name)).expect("scene loads"));
        }
        let mut bundle = default_scene();
        bundle.trace.shadows = ShadowMode::Bundle { samples: 7, rotate: true };
        scenes.push(bundle);
        for scene in &scenes {
            let grid = crate::accel::Grid::build(scene);
            let packed = pack_scene(scene, &grid, scene.camera.eye);
            assert_eq!(packed.texels.capacity(), packed.texels.len());
            let bvh = Bvh::build(scene);
            for walk in [BvhWalk::Stackless, BvhWalk::Stack] {
                let packed = pack_scene(scene, AccelRef::Bvh(&bvh, walk), scene.camera.eye);
                assert_eq!(packed.texels.capacity(), packed.texels.len());
            }
        }
    }

    /// A grid-packed scene with a BVH swapped in ([`swap_accel`]) is, from the row it is
    /// written from, texel for texel what packing the scene with the BVH gives, with the same
    /// bases and lattice; and back, from the BVH to a grid. Scenes with textures (their pixels
    /// come just before the accelerator) and in the bundle shadow mode (its samples after it).
    /// The rows a grid-packed scene reserves for its BVH hold it.
    #[test]
    fn a_swapped_accelerator_packs_as_the_whole_scene_would() {
        use crate::accel::grid::Grid;
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut bundled = crate::io::load(&dir.join("spd/balls_s2.nff")).expect("scene loads");
        bundled.trace.shadows = ShadowMode::Bundle { samples: 7, rotate: true };
        let scenes = [default_scene(), crate::io::load(&dir.join("textured.toml")).expect("loads"), bundled];
        for scene in &scenes {
            let origin = scene.camera.eye + DVec3::new(0.5, -0.25, 2.0);
            let grid = Grid::build(scene);
            let bvh = Bvh::build(scene).ordered_towards(origin);
            let walk = BvhWalk::Stackless;
            for (from, to) in [
                (AccelRef::Grid(&grid), AccelRef::Bvh(&bvh, walk)),
                (AccelRef::Bvh(&bvh, walk), AccelRef::Grid(&grid)),
            ] {
                let before = pack_scene(scene, from, origin);
                let whole = pack_scene(scene, to, origin);
                let prefix = before.prefix().expect("no shells");
                let (row, swapped) = swap_accel(&prefix, pack_accel(to, origin), scene.trace.shadows);
                let start = (row * SCENE_TEX_WIDTH) as usize;
                assert!(
                    start <= before.grid_base[0] as usize && before.texels[..start] == whole.texels[..start]
                );
                assert!(swapped.texels == whole.texels[start..], "the texels from row {row}");
                assert_eq!(
                    (swapped.prim_base, swapped.aux_base, swapped.grid_base, swapped.bvh_lattice),
                    (whole.prim_base, whole.aux_base, whole.grid_base, whole.bvh_lattice)
                );
                assert_eq!(params(scene, to, &swapped, origin), params(scene, to, &whole, origin));
                if let AccelRef::Grid(_) = from {
                    assert!(
                        bvh_rows_bound(&before, scene.primitive_count()) >= whole.rows(),
                        "room for the BVH"
                    );
                }
            }
        }
        let mut shells = default_scene();
        shells.trace.shadows = ShadowMode::Shell { falloff: Default::default(), combine: Default::default() };
        assert!(pack_scene(&shells, &Grid::build(&shells), DVec3::ZERO).prefix().is_none());
    }

    /// Every compact node's decoded box holds its f32 box, whether the device fuses the decode's
    /// multiply-add or not, and is at most two steps looser on each side; the link words say
    /// what the two-texel nodes say. Scenes: near the origin, far from it (1e5), and flat (a
    /// mesh in a plane: zero extent on one axis).
    #[test]
    fn compact_nodes_hold_their_boxes() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut scenes = vec![default_scene()];
        for name in ["mesh.toml", "cones.toml", "spd/balls_s2.nff", "spd/tetra_s4.nff"] {
            scenes.push(crate::io::load(&dir.join(name)).expect("scene loads"));
        }
        let flat = crate::scene::Mesh {
            positions: (0..64).map(|i| DVec3::new((i % 8) as f64, 0.0, (i / 8) as f64 * 0.37)).collect(),
            normals: None,
            uvs: None,
            indices: (0..49).filter(|i| i % 8 != 7).map(|i| [i, i + 1, i + 8]).collect(),
            material: 0,
        };
        let mut plane = default_scene();
        plane.spheres.clear();
        plane.meshes = vec![flat];
        scenes.push(plane);
        let origins = |s: &Scene| [s.camera.eye, s.camera.eye + DVec3::splat(1e5), DVec3::ZERO];
        for scene in &scenes {
            let bvh = Bvh::build(scene);
            for origin in origins(scene) {
                let lattice = BvhLattice::of(&bvh, origin);
                for (i, n) in bvh_nodes(&bvh, origin).iter().enumerate() {
                    let t = quantise_node(n, &lattice);
                    let q = [t[0] & 0xffff, t[0] >> 16, t[1] & 0xffff, t[1] >> 16, t[2] & 0xffff, t[2] >> 16];
                    for k in 0..3 {
                        let (base, step) = (lattice.base[k], lattice.step[k]);
                        let (lo, hi) = (decoded(q[k], step, base), decoded(q[3 + k], step, base));
                        assert!(
                            lo.1 <= n.lo[k] && hi.0 >= n.hi[k],
                            "node {i} axis {k}: {lo:?} {hi:?} vs {n:?}"
                        );
                        let step = step as f64;
                        assert!(
                            (n.lo[k] - lo.0) as f64 <= 2.0 * step && (hi.1 - n.hi[k]) as f64 <= 2.0 * step
                        );
                    }
                    if n.b & BVH_INNER != 0 {
                        assert_eq!(t[3], BVH_INNER | n.a, "node {i}: escape");
                    } else {
                        assert_eq!(
                            (t[3] >> BVH_COUNT_SHIFT, t[3] & ((1 << BVH_COUNT_SHIFT) - 1)),
                            (n.b, n.a)
                        );
                    }
                }
            }
        }
    }
}
