//! The scene and its accelerator packed into the scene texture's whole-texel records, and the
//! frame constants that say where each section starts.

use super::bvh::{bvh_leaves, bvh_nodes, quantise_node, BvhLattice};
use super::*;
use crate::accel::bvh::NodeKind;
use crate::accel::{AccelRef, BvhWalk, PrimKind, PrimRef};
use crate::scene::{
    bundle_samples, scene_shells, LightShells, Scene, ShadowMode, ShellShape, MAX_BUNDLE, MAX_LIGHTS,
};
use glam::DVec3;

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
/// - shell sections (shell mode only), one per light (`scene::scene_shells`):
///   `[objects, first cell texel, first list texel, cells per face side]`, the depth slabs
///   (`scene::Slabs`) `[count, near (f32), 1 / log2(ratio) (f32), 0]`, then per object
///   `[bound centre.xyz, bound radius]`, `[prim, a, 0, 0]` where `prim` is the `PrimRef` of a
///   sphere or cone (its record is the bound for spheres) or of a mesh's first triangle, with
///   `a` its end triangle, and `[half.xyz, 0]`, a mesh's bounding box about the bound's centre
///   (zero for spheres and cones); then the edge pool: for each cell and each mesh it
///   lists, that mesh's contour edges listed in the cell, `[a.xyz, 0]`, `[b.xyz, 0]`; then the
///   light buffer's cells (`scene::shell_cell`), `[meshes, end, slabs, 0]`: its meshes from
///   `meshes` to `end` in the list, and the texel of its first depth slab; then the slabs, a
///   shared block of empty ones and `count` for each cell that lists a sphere or cone,
///   `[first, cones, end, 0]` (spheres from `first`, cones from `cones` to `end`); then the
///   list, four words per texel: sphere and cone object indices, and per mesh three words, its
///   object index and the first and end texel of its run in the edge pool.
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
    let (volume_texels, macrocells) = super::volume::volume_texels(scene);
    let (patch_texels, leaves) = super::patch::patch_texels(scene);
    let capacity = volume_texels
        + patch_texels
        + SPHERE_TEXELS as usize * scene.spheres.len()
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
        t.push(f32_bits(s.center - origin, (s.radius as f32).to_bits()));
        let anchor = f32_bits(sphere_anchor(s.center, s.radius, origin) - origin, 0);
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
        t.push(f32_bits(tri.p[0] - origin, tri.material));
        t.push(f32_bits(tri.p[1] - origin, normal_record));
        t.push(f32_bits(tri.p[2] - origin, uv_record));
    }
    let normal_base = t.len() as u32;
    for n in scene.triangles().filter_map(|tri| tri.n) {
        t.extend(n.iter().map(|v| f32_bits(*v, 0)));
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
        t.push(f32_bits(colour, code));
        let texture = m.texture.unwrap_or(NO_TEXTURE);
        t.push([(eta as f32).to_bits(), (exponent as f32).to_bits(), texture, 0]);
    }
    let cone_base = t.len() as u32;
    for c in &scene.cones {
        t.push(f32_bits(c.base - origin, (c.base_radius as f32).to_bits()));
        t.push(f32_bits(c.apex - c.base, (c.apex_radius as f32).to_bits()));
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
    let volume_base = super::volume::push_volumes(&mut t, scene, &macrocells, origin);
    let patch_base = super::patch::push_patches(&mut t, scene, &leaves, origin);
    let (accel_base, bvh_lattice) = push_accel(&mut t, accel, origin);
    let bundle_base = push_bundle(&mut t, scene.trace.shadows);
    let mut shell_sections = vec![];
    if let ShadowMode::Shell { .. } = scene.trace.shadows {
        for sh in scene_shells(scene) {
            let section = t.len() as u32;
            shell_sections.push(section);
            push_shells(&mut t, &sh, origin);
        }
    }
    PackedScene {
        texels: t,
        prim_base: [sphere_base, triangle_base, normal_base, material_base],
        aux_base: [cone_base, uv_base, texture_base, pixel_base],
        accel_base: [accel_base[0], accel_base[1], accel_base[2], bundle_base],
        shell_sections,
        bvh_lattice,
        volume_base,
        patch: [patch_base, leaves.leaves.len() as u32, leaves.degree as u32, 0],
    }
}

/// Appends one light's shell section (the layout in [`pack_scene`]'s comment) to `t`.
fn push_shells(t: &mut Vec<[u32; 4]>, sh: &LightShells, origin: DVec3) {
    let section = t.len() as u32;
    let is_mesh = |k: u32| matches!(sh.objects[k as usize].shape, ShellShape::Mesh { .. });
    // Each mesh listed in a cell: the part of its cell's edges that are the mesh's own
    // (`cell_edges` are in edge order, so a mesh's are one run).
    let mesh_edges = |cell: usize, k: u32| -> &[u32] {
        let ShellShape::Mesh { edges: [e0, e1], .. } = sh.objects[k as usize].shape else { return &[] };
        let list = &sh.cell_edges[cell];
        &list[list.partition_point(|&e| e < e0)..list.partition_point(|&e| e < e1)]
    };
    // Only meshes listed in a cell take their edges there (an edge's capsule can reach a cell
    // that its mesh's bounding sphere does not; no segment there comes within reach of it).
    let pool: u32 = (0..sh.cells.len())
        .map(|c| {
            sh.cells[c].iter().filter(|&&k| is_mesh(k)).map(|&k| mesh_edges(c, k).len() as u32).sum::<u32>()
        })
        .sum();
    let n_slabs = sh.slabs.count as usize;
    // A cell with no sphere or cone in any slab points at one shared block of empty slabs.
    let solid_cells: Vec<bool> =
        sh.slab_cells.chunks(n_slabs).map(|c| c.iter().any(|l| !l.is_empty())).collect();
    let slab_texels = n_slabs * (1 + solid_cells.iter().filter(|&&x| x).count());
    let listed: usize = sh.cells.iter().map(|c| 3 * c.len()).sum::<usize>()
        + sh.slab_cells.iter().map(Vec::len).sum::<usize>();
    let edge_base = section + SHELL_HEADER_TEXELS + SHELL_OBJECT_TEXELS * sh.objects.len() as u32;
    let cell_base = edge_base + SHELL_EDGE_TEXELS * pool;
    let slab_base = cell_base + sh.cells.len() as u32;
    let list_base = slab_base + slab_texels as u32;
    t.reserve_exact((list_base - section) as usize + listed.div_ceil(4));
    t.push([sh.objects.len() as u32, cell_base, list_base, sh.res]);
    let f32_word = |x: f64| (x as f32).to_bits();
    t.push([sh.slabs.count, f32_word(sh.slabs.near), f32_word(sh.slabs.inv_log2_ratio()), 0]);
    for o in &sh.objects {
        t.push(f32_bits(o.center - origin, (o.radius as f32).to_bits()));
        t.push(match o.shape {
            ShellShape::Sphere(i) => [PrimRef::new(PrimKind::Sphere, i).0, 0, 0, 0],
            ShellShape::Cone(i) => [PrimRef::new(PrimKind::Cone, i).0, 0, 0, 0],
            ShellShape::Mesh { triangles, .. } => {
                [PrimRef::new(PrimKind::Triangle, triangles[0]).0, triangles[1], 0, 0]
            }
        });
        // The box's half extent, grown by 10⁻⁶ of its size and distance from the origin (f32
        // rounding of camera-relative positions is 6·10⁻⁸ of them), well within the 10⁻⁴ by
        // which shadow rays start off their surface.
        let pad = 1e-6 * ((o.center - origin).abs().max_element() + o.half.max_element());
        let half = if o.half == DVec3::ZERO { o.half } else { o.half + pad };
        t.push(f32_bits(half, 0));
    }
    // The edge pool: each cell's edges of each mesh it lists, one run per (cell, mesh).
    let mut runs = vec![];
    let mut at = edge_base;
    for (c, cell) in sh.cells.iter().enumerate() {
        for &k in cell.iter().filter(|&&k| is_mesh(k)) {
            let edges = mesh_edges(c, k);
            for &e in edges {
                let [a, b] = sh.edges[e as usize];
                t.push(f32_bits(a - origin, 0));
                t.push(f32_bits(b - origin, 0));
            }
            runs.push([k, at, at + SHELL_EDGE_TEXELS * edges.len() as u32]);
            at += SHELL_EDGE_TEXELS * edges.len() as u32;
        }
    }
    debug_assert_eq!(at, cell_base, "the edge pool ends where the cells begin");
    // A cell: `[meshes, end, slabs, 0]`, its meshes (each three words: object index, its edges'
    // first and end texel) in the list from `meshes` to `end`, and the texel of its first slab.
    // A slab: `[first, cones, end, 0]`, its spheres from `first`, its cones from `cones` to
    // `end` (object indices). Each kind is visited by a loop of its own.
    let mut list: Vec<u32> = Vec::with_capacity(listed);
    let mut runs = runs.into_iter();
    let mut slab_at = slab_base + n_slabs as u32;
    for (cell, &solid) in sh.cells.iter().zip(&solid_cells) {
        debug_assert!(cell.windows(2).all(|w| w[0] < w[1]), "a cell's list in object order");
        let first = list.len() as u32;
        for _ in cell.iter().filter(|&&k| is_mesh(k)) {
            list.extend(runs.next().expect("a run per listed mesh"));
        }
        t.push([first, list.len() as u32, if solid { slab_at } else { slab_base }, 0]);
        slab_at += if solid { n_slabs as u32 } else { 0 };
    }
    t.extend(std::iter::repeat_n([0u32; 4], n_slabs));
    for (slabs, _) in sh.slab_cells.chunks(n_slabs).zip(&solid_cells).filter(|(_, &solid)| solid) {
        for slab in slabs {
            let kind = |k: &u32| sh.objects[*k as usize].shape;
            let first = list.len() as u32;
            list.extend(slab.iter().filter(|k| matches!(kind(k), ShellShape::Sphere(_))));
            let cones_from = list.len() as u32;
            list.extend(slab.iter().filter(|k| matches!(kind(k), ShellShape::Cone(_))));
            t.push([first, cones_from, list.len() as u32, 0]);
        }
    }
    debug_assert_eq!(t.len() as u32, list_base, "the slabs end where the list begins");
    for chunk in list.chunks(4) {
        let mut texel = [0u32; 4];
        texel[..chunk.len()].copy_from_slice(chunk);
        t.push(texel);
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
/// viewer's background BVH build packs it on its own thread): its texels, its `accel_base` words
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
    // Room for what [`swap_accel`] and the upload add around it in place, so that the swap never
    // copies the section (docs/large-models.md): the head of its first row (less than a row), the
    // bundle's sample pairs, and the padding of its last row.
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
    volume_base: u32,
    patch: [u32; 4],
}

impl PackedScene {
    /// What [`swap_accel`] needs to put another accelerator in this packing's place; `None` with
    /// shell shadows, whose sections follow the accelerator's and point at texels by index.
    pub fn prefix(&self) -> Option<Prefix> {
        if !self.shell_sections.is_empty() {
            return None;
        }
        let at = self.accel_base[0];
        let row = at / SCENE_TEX_WIDTH * SCENE_TEX_WIDTH;
        let head = self.texels[row as usize..at as usize].to_vec();
        Some(Prefix {
            head,
            at,
            prim_base: self.prim_base,
            aux_base: self.aux_base,
            volume_base: self.volume_base,
            patch: self.patch,
        })
    }
}

/// Rows that `packed` needs at most with a stackless BVH over its `prims` primitives in place of
/// its accelerator: a leaf holds at least one primitive, so there are at most 2n - 1 nodes of
/// one texel and n texels of references (SPD balls' SAH leaves hold one sphere each: 3n).
pub fn bvh_rows_bound(packed: &PackedScene, prims: usize) -> u32 {
    let bundle = packed.texels.len() - packed.accel_base[3] as usize;
    rows_of(packed.accel_base[0] as usize + 3 * prims.max(1) + bundle)
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
        accel_base: [prefix.at + a, prefix.at + b, third, bundle_base],
        shell_sections: vec![],
        bvh_lattice: section.lattice,
        volume_base: prefix.volume_base,
        patch: prefix.patch,
    };
    (row, packed)
}

/// Appends `accel`'s section to `t`: its `accel_base` words (texel indices into `t`; a BVH's
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
        accel_min: [0.0; 4],
        accel_max: [0.0; 4],
        cell: [0.0; 4],
        inv_cell: [0.0; 4],
        cells: [0; 4],
        macro_res: [0; 4],
        prim_base: packed.prim_base,
        aux_base: packed.aux_base,
        accel_base: packed.accel_base,
        image: [cam.width, cam.height, scene.trace.max_depth, scene.lights.len() as u32],
        eye_grid: eye_grid(cam.width, cam.height, false),
        trace: [scene.trace.weight_cutoff as f32, RAY_OFFSET_REL, 0.0, 0.0],
        shadow: match scene.trace.shadows {
            ShadowMode::Hard => [0; 4],
            ShadowMode::Bundle { samples, rotate } => [1, samples, rotate as u32, 0],
            ShadowMode::Shell { falloff, combine } => [2, 0, 0, falloff as u32 | (combine as u32) << 8],
        },
        lights,
        volume: [packed.volume_base, scene.volumes.len() as u32, super::volume::look_bits(scene), 0],
        iso: super::volume::iso_values(scene),
        patches: packed.patch,
    };
    match accel.into() {
        AccelRef::Grid(grid) => {
            let res = grid.res;
            p.accel_min = v4(grid.min - origin, 0.0);
            p.accel_max = v4(grid.max - origin, 0.0);
            p.cell = v4(grid.cell_size, 0.0);
            p.inv_cell = v4(grid.cell_size.recip(), 0.0);
            p.cells = [res[0], res[1], res[2], 0];
            p.macro_res = [grid.macro_res[0], grid.macro_res[1], grid.macro_res[2], ACCEL_GRID];
        }
        AccelRef::Bvh(bvh, walk) => {
            let lattice = packed.bvh_lattice.unwrap_or_else(|| BvhLattice::of(bvh, origin));
            p.accel_min = [lattice.base[0], lattice.base[1], lattice.base[2], 0.0];
            p.accel_max = [lattice.top[0], lattice.top[1], lattice.top[2], 0.0];
            p.cell = [lattice.step[0], lattice.step[1], lattice.step[2], 0.0];
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Bvh;
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
                    start <= before.accel_base[0] as usize && before.texels[..start] == whole.texels[..start]
                );
                assert!(swapped.texels == whole.texels[start..], "the texels from row {row}");
                assert_eq!(
                    (swapped.prim_base, swapped.aux_base, swapped.accel_base, swapped.bvh_lattice),
                    (whole.prim_base, whole.aux_base, whole.accel_base, whole.bvh_lattice)
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
}
