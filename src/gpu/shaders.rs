//! Shader composition, the one way: a generated prelude of constants, the shared modules in a
//! fixed order, then the entry file. Every variant is validated with naga in tests.

use super::layout;
use crate::scene::ShadowMode;

/// Shared modules before the accelerator's, in dependency order.
const MODULES: [(&str, &str); 6] = [
    ("types.wgsl", include_str!("../../shaders/types.wgsl")),
    ("scene.wgsl", include_str!("../../shaders/scene.wgsl")),
    ("texture.wgsl", include_str!("../../shaders/texture.wgsl")),
    ("intersect.wgsl", include_str!("../../shaders/intersect.wgsl")),
    ("volume.wgsl", include_str!("../../shaders/volume.wgsl")),
    ("patch.wgsl", include_str!("../../shaders/patch.wgsl")),
];
/// The accelerators' walks: a variant compiles the one its scene was packed with
/// (`Variant::accel`; the test kernels always have the grid's, whose DDA they step).
const GRID: (&str, &str) = ("grid.wgsl", include_str!("../../shaders/grid.wgsl"));
const BVH: (&str, &str) = ("bvh.wgsl", include_str!("../../shaders/bvh.wgsl"));
/// Shared modules after the accelerator's.
const SHADING: [(&str, &str); 3] = [
    ("accel.wgsl", include_str!("../../shaders/accel.wgsl")),
    ("shading.wgsl", include_str!("../../shaders/shading.wgsl")),
    ("shadows.wgsl", include_str!("../../shaders/shadows.wgsl")),
];

/// A shader program: the entry files a compiled module holds besides the shared modules.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Program {
    /// `trace.wgsl`: the `render` entry point (the bands).
    Render,
    /// `trace.wgsl` + `modes.wgsl`: the queue, slice and resolve entry points as well. Kept apart
    /// from `Render` so that a session in the bands mode compiles no more than it runs.
    Modes,
    /// `trace.wgsl` + `tests.wgsl`: readback kernels that call single shader functions.
    Tests,
}

impl Program {
    /// Its name, for labels.
    pub fn name(self) -> &'static str {
        match self {
            Program::Render => "render",
            Program::Modes => "modes",
            Program::Tests => "tests",
        }
    }
}

const TRACE: &str = include_str!("../../shaders/trace.wgsl");
const TESTS: &str = include_str!("../../shaders/tests.wgsl");
const MODES: &str = include_str!("../../shaders/modes.wgsl");

/// The features a pipeline is specialised for: code for what is off is compiled out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    pub spheres: bool,
    pub triangles: bool,
    pub cones: bool,
    /// Volumes' isosurfaces (`shaders/volume.wgsl`).
    pub volumes: bool,
    /// Spline patches (`shaders/patch.wgsl`): 0 for none, else the pieces' degree (1 to
    /// `patch::MAX_DEGREE`, a constant the loops unroll by), or `layout::patch::PATCH_ANY`.
    pub patches: u32,
    /// Count rays by kind into the stats buffer (costs four atomics per pixel).
    pub count_rays: bool,
    /// The shadow mode compiled in (`ShadowMode::kind_index`), or [`SHADOWS_ANY`]: chosen at run
    /// time from `Params::shadow`.
    pub shadows: u32,
    /// Material kinds compiled in: bit `layout::material_code(kind)` per kind.
    pub materials: u32,
    /// Ray–primitive intersection and grid traversal in f64 (`real` in the shaders); needs the
    /// device's SHADER_F64. Scene data stay f32.
    pub f64: bool,
    /// Base-colour textures: texture coordinates at hits and texture sampling.
    pub textures: bool,
    /// The scene texture is a 2D array of `layout::SCENE_LAYER_ROWS`-row layers (the scene's rows
    /// exceed the device's largest texture side). Set by the dispatcher from the uploaded scene: on
    /// lavapipe an array fetch costs ~5% of a triangle scene's frame (callgrind, SPD gears), so
    /// scenes that fit one layer keep a plain 2D texture.
    pub layered: bool,
    /// Shell shadows walk the grid to find the mesh a shadow ray is inside of: some mesh is too
    /// large to test triangle by triangle (`scene::shells_walk_grid`). Off, the walk is compiled
    /// out; its result is only ever used for such meshes, so the image is the same either way.
    pub shell_walk: bool,
    /// The accelerator and its walk (`layout::ACCEL_GRID`, `ACCEL_BVH`, `ACCEL_BVH_STACKLESS`).
    /// Set by the dispatcher from the uploaded scene (`layout::accel_code`), like `layered`: the
    /// kernel walks what was packed.
    pub accel: u32,
    /// Count each loop's SIMD efficiency (`layout::SIMD_LOOPS`: lane-iterations active against
    /// iterations run) into the stats buffer: a measuring variant (`irt bench --simd`) that needs
    /// the device's subgroup operations.
    pub simd_stats: bool,
}

/// Every material kind.
pub const ALL_MATERIALS: u32 = 0b1111;

/// Shadow-mode slot of the uber-shader: every mode compiled in, picked by a uniform.
pub const SHADOWS_ANY: u32 = 3;

impl Variant {
    /// Everything on: the uber-shader.
    pub const FULL: Variant = Variant {
        spheres: true,
        triangles: true,
        cones: true,
        volumes: true,
        patches: layout::patch::PATCH_ANY,
        count_rays: true,
        shadows: SHADOWS_ANY,
        materials: ALL_MATERIALS,
        f64: false,
        textures: true,
        layered: false,
        shell_walk: true,
        accel: layout::ACCEL_GRID,
        simd_stats: false,
    };

    pub fn for_scene(scene: &crate::scene::Scene, count_rays: bool) -> Self {
        Variant {
            spheres: !scene.spheres.is_empty(),
            triangles: scene.triangle_count() > 0,
            cones: !scene.cones.is_empty(),
            volumes: !scene.volumes.is_empty(),
            patches: scene.patches.iter().flat_map(|p| p.degree).max().unwrap_or(0) as u32,
            count_rays,
            shadows: scene.trace.shadows.kind_index(),
            materials: scene.materials.iter().fold(0, |m, mat| m | 1 << layout::material_code(&mat.kind)),
            f64: false,
            textures: scene.materials.iter().any(|m| m.texture.is_some()),
            layered: false,
            shell_walk: matches!(scene.trace.shadows, ShadowMode::Shell { .. })
                && crate::scene::shells_walk_grid(scene),
            accel: layout::ACCEL_GRID,
            simd_stats: false,
        }
    }

    /// Every variant that can be built, as far as validation can tell them apart (validated by
    /// a test): every primitive/shadow combination with every material kind, and every set of
    /// material kinds with everything else on.
    pub fn all() -> Vec<Variant> {
        let mut v = Vec::new();
        for bits in 0..16u32 {
            for shadows in 0..=SHADOWS_ANY {
                v.push(Variant {
                    spheres: bits & 1 != 0,
                    triangles: bits & 2 != 0,
                    cones: bits & 8 != 0,
                    volumes: bits & 8 != 0,
                    patches: if bits & 8 != 0 { 3 } else { 0 },
                    count_rays: bits & 4 != 0,
                    shadows,
                    materials: ALL_MATERIALS,
                    f64: false,
                    textures: bits & 2 != 0,
                    layered: bits & 1 != 0,
                    shell_walk: bits & 6 == 6,
                    accel: layout::ACCEL_GRID,
                    simd_stats: false,
                });
                // The BVH walks with every primitive/shadow combination too.
                let last = *v.last().expect("pushed");
                v.push(Variant { accel: layout::ACCEL_BVH, ..last });
            }
        }
        v.extend((0..ALL_MATERIALS).map(|materials| Variant { materials, ..Variant::FULL }));
        v.extend([false, true].map(|count_rays| Variant { f64: true, count_rays, ..Variant::FULL }));
        v.extend(
            (1..=crate::scene::patch::MAX_DEGREE as u32).map(|patches| Variant { patches, ..Variant::FULL }),
        );
        v.push(Variant { textures: false, ..Variant::FULL });
        v.push(Variant { shell_walk: false, ..Variant::FULL });
        v.push(Variant { simd_stats: true, ..Variant::FULL });
        for accel in [layout::ACCEL_BVH, layout::ACCEL_BVH_STACKLESS] {
            v.push(Variant { accel, ..Variant::FULL });
            v.push(Variant { accel, simd_stats: true, ..Variant::FULL });
            v.extend([false, true].map(|count_rays| Variant {
                f64: true,
                count_rays,
                accel,
                ..Variant::FULL
            }));
        }
        v
    }

    fn prelude(&self) -> String {
        let b = |name: &str, on: bool| format!("const {name}: bool = {on};\n");
        let mut s = String::from("// generated by src/gpu/shaders.rs\n");
        s += &layout::wgsl_constants();
        s += &b("HAS_SPHERES", self.spheres);
        s += &b("HAS_TRIANGLES", self.triangles);
        s += &b("HAS_CONES", self.cones);
        s += &b("HAS_VOLUMES", self.volumes);
        s += &b("HAS_PATCHES", self.patches != 0);
        s += &format!("const PATCH_DEGREE: u32 = {}u;\n", self.patches);
        s += &b("COUNT_RAYS", self.count_rays);
        s += &b("SIMD_STATS", self.simd_stats);
        // The lane that counts a SIMD group's iteration (shaders/trace.wgsl, `loop_tick`): the
        // first active one, the one whose pixel (unique in a dispatch) the broadcast returns.
        // naga 30 has no subgroupElect, and takes subgroup built-ins without `enable subgroups;`
        // (it rejects the directive), checking them against the device's capabilities instead.
        s += &format!(
            "fn simd_elect() -> bool {{\n    return {};\n}}\n",
            if self.simd_stats { "subgroupBroadcastFirst(pixel_id) == pixel_id" } else { "false" }
        );
        s += &b("HAS_TEXTURES", self.textures);
        s += &b("SHELL_WALK", self.shell_walk);
        s += &format!("const SHADOW_MODE: u32 = {}u;\n", self.shadows);
        s += &format!("const MATERIAL_KINDS: u32 = {}u;\n", self.materials);
        let walk = match self.accel {
            layout::ACCEL_BVH => "bvh_walk_stack",
            layout::ACCEL_BVH_STACKLESS => "bvh_walk_stackless",
            _ => "grid_walk",
        };
        s += &format!(
            "fn accel_walk(o: vec3f, d: vec3f, t_min: f32, t_max: f32, any_hit: bool, triangles_only: bool) -> Hit {{\n\
             \x20   return {walk}(o, d, t_min, t_max, any_hit, triangles_only);\n}}\n"
        );
        let real = if self.f64 { "f64" } else { "f32" };
        s += &format!("alias real = {real};\nalias vec3r = vec3<{real}>;\n");
        s += if self.layered {
            "@group(0) @binding(1) var scene_tex: texture_storage_2d_array<rgba32uint, read>;\n\
             fn scene_load(column: u32, row: u32) -> vec4u {\n\
             \x20   let layer_row = row & ((1u << SCENE_LAYER_SHIFT) - 1u);\n\
             \x20   return textureLoad(scene_tex, vec2u(column, layer_row), row >> SCENE_LAYER_SHIFT);\n}\n"
        } else {
            "@group(0) @binding(1) var scene_tex: texture_storage_2d<rgba32uint, read>;\n\
             fn scene_load(column: u32, row: u32) -> vec4u {\n\
             \x20   return textureLoad(scene_tex, vec2u(column, row));\n}\n"
        };
        s
    }
}

/// The complete WGSL source of `program` specialised to `variant`.
pub fn compose(program: Program, variant: Variant) -> String {
    let mut src = variant.prelude();
    let entries: &[(&str, &str)] = match program {
        Program::Render => &[("trace.wgsl", TRACE)],
        Program::Modes => &[("trace.wgsl", TRACE), ("modes.wgsl", MODES)],
        Program::Tests => &[("trace.wgsl", TRACE), ("tests.wgsl", TESTS)],
    };
    let bvh = variant.accel != layout::ACCEL_GRID;
    let accel = [
        (!bvh || program == Program::Tests).then_some(GRID),
        (bvh || program == Program::Tests).then_some(BVH),
    ];
    for (name, text) in MODULES.iter().chain(accel.iter().flatten()).chain(&SHADING).chain(entries) {
        src += &format!("\n// ---- {name} ----\n");
        src += text;
    }
    src
}

/// WGSL naga does not accept ([`validate`]): naga's error text, rendered against the composed
/// source while it is at hand (it names positions in it).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ShaderError {
    #[error("{0}")]
    Parse(String),
    #[error("{0}")]
    Invalid(String),
}

/// Parses and validates `src` as naga does inside wgpu; the error text names file positions
/// in the composed source.
pub fn validate(src: &str) -> Result<(naga::Module, naga::valid::ModuleInfo), ShaderError> {
    let module = naga::front::wgsl::parse_str(src).map_err(|e| ShaderError::Parse(e.emit_to_string(src)))?;
    let info = validator().validate(&module).map_err(|e| ShaderError::Invalid(e.emit_to_string(src)))?;
    Ok((module, info))
}

/// naga's validator as [`validate`] runs it: every check, every capability.
pub fn validator() -> naga::valid::Validator {
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
}
