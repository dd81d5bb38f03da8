//! Wavefront OBJ models with their MTL material libraries → [`Model`] (and, staged, a [`Scene`]).
//! docs/obj.md says what is read, what is ignored and how MTL materials become the paper's four.
//!
//! A parser of its own rather than the `tobj` crate, which was tried first (4.0.5): it panics on
//! the MTL line `Kd 0.5` (legal: g and b default to r), fills polylines (`l 1 2 3`) as
//! triangles, accepts index 0 and texture or normal indices into empty lists, misaligns normals
//! when faces with and without them share vertices, and reports errors without a line; working
//! around all that needed a second full tokenizer of the file anyway.
//!
//! The file is read in two passes over the text: the first counts vertices and triangles so
//! that limits are checked and arrays allocated once, exactly; the second parses. Polygons are
//! triangulated by ear clipping ([`triangulate`]), so concave ones come out right. Every error
//! names the file, line and column of the offending token (for MTL files, the MTL's).

// `Ns` is clamped to glTF's exponent range: exporters write `Ns 0` for rough surfaces, and an
// exponent of 0 would be a highlight of constant strength.
use super::gltf::{MAX_EXPONENT, MIN_EXPONENT};
use super::nff::{coat_eta, METAL_KD_OVER_KS};
use super::png::{self, PixelBudget, Unusable};
use super::shapes::{triangulate, MAX_POLYGON_VERTICES};
use super::stage::{stage, Model};
use super::toml::{
    DEFAULT_COAT_EXPONENT, DEFAULT_DIFFUSE_COLOR, DEFAULT_ETA, DEFAULT_METAL_EXPONENT, MAX_TEXTURE_FILE_BYTES,
};
use super::{read_limited, unique_name, LoadError, MAX_MATERIALS, MAX_TRIANGLES, MAX_VERTICES};

mod freeform;
use crate::scene::{Filter, Material, MaterialKind, Mesh, Scene, Texture, Wrap, MAX_TEXTURES};
use glam::{DVec2, DVec3};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Bytes an OBJ file may have: what the largest mesh irt takes ([`MAX_TRIANGLES`]) needs as
/// text with normals and texture coordinates. A closed mesh has half as many vertices as
/// triangles; with 7-digit indices and 6-digit coordinates a triangle costs about 115 bytes
/// (an `f` line of three `v/vt/vn` triples, half a `v`, `vn` and `vt` line each).
pub const MAX_FILE_BYTES: u64 = MAX_TRIANGLES as u64 * 128;
/// Bytes an MTL file may have: [`MAX_MATERIALS`] materials of a few hundred bytes each.
pub const MAX_MTL_BYTES: u64 = 64 << 20;

/// `illum` models whose light goes through the surface (glass, refraction).
const TRANSPARENT_ILLUM: [u32; 4] = [4, 6, 7, 9];
/// `illum` models with a ray-traced reflection of strength Ks.
const REFLECTIVE_ILLUM: [u32; 3] = [3, 5, 8];
/// Grouping and display statements that change nothing irt draws.
const SILENT: &[&str] = &[
    "o",
    "g",
    "s",
    "mg",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "usemap",
    "maplib",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
];
/// An absent texture coordinate or normal in a vertex key.
const NONE: u32 = u32::MAX;

/// Parses an OBJ file and stages it ([`stage`]: a framing camera and a light).
pub fn parse(bytes: &[u8], origin: &str) -> Result<Scene, LoadError> {
    let scene = stage(parse_model(bytes, origin)?);
    // Everything is checked on the way in; this is the scene model's own guard.
    scene.validate().map_err(|e| LoadError::new(origin, e.0))?;
    Ok(scene)
}

/// Parses an OBJ file, its MTL libraries and their PNG textures (found relative to `origin`,
/// the OBJ's path, which also names it in messages) into meshes and materials.
pub fn parse_model(bytes: &[u8], origin: &str) -> Result<Model, LoadError> {
    // Keywords and numbers are ASCII; a name or comment from an old exporter in Latin-1 should
    // not refuse the file, and replacing its odd bytes keeps every line and column.
    let src = String::from_utf8_lossy(bytes);
    let text = Text { src: &src, origin };
    let counts = count(&text)?;
    let mut obj = Obj::new(text, counts);
    obj.run()?;
    obj.finish()
}

// ---- Text, tokens and numbers ----------------------------------------------------------------

/// A source text and its name, for positioned errors about its tokens.
#[derive(Clone, Copy)]
struct Text<'a> {
    src: &'a str,
    origin: &'a str,
}

/// One line: its statement keyword and the text after it.
struct Line<'a> {
    keyword: &'a str,
    rest: &'a str,
    /// 1-based.
    number: usize,
}

impl<'a> Text<'a> {
    /// Byte offset of `part`, a slice of the source.
    fn offset(&self, part: &str) -> usize {
        part.as_ptr() as usize - self.src.as_ptr() as usize
    }

    /// An error at the start of `part`, a slice of the source.
    fn error(&self, part: &str, message: impl Into<String>) -> LoadError {
        LoadError::at(self.origin, self.src, self.offset(part), message)
    }

    /// Every line with a statement (not blank, not a comment). A line ending in `\\` goes on
    /// in the next (what exporters do with long `surf` and `parm` lists): the statement's text
    /// spans both, and its number is its first line's.
    fn lines(&self) -> impl Iterator<Item = Line<'a>> {
        let mut rest = self.src;
        let mut number = 0;
        std::iter::from_fn(move || loop {
            if rest.is_empty() {
                return None;
            }
            let first = number + 1;
            let mut end = 0;
            let line = loop {
                let len = rest[end..].find('\n').map_or(rest.len() - end, |n| n + 1);
                number += 1;
                let piece = &rest[end..end + len];
                end += len;
                if !(piece.trim_end().ends_with('\\') && end < rest.len()) {
                    break &rest[..end];
                }
            };
            rest = &rest[end..];
            let mut words = args(line);
            if let Some(keyword) = words.next() {
                return Some(Line { keyword, rest: words.0, number: first });
            }
        })
    }

    /// A finite number; `what` names it in messages.
    fn number(&self, token: &str, what: &str) -> Result<f64, LoadError> {
        self.number_named(token, || what.to_string())
    }

    /// [`Text::number`], naming it only if there is an error (numbers are most of a file).
    fn number_named(&self, token: &str, what: impl FnOnce() -> String) -> Result<f64, LoadError> {
        match token.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(_) => Err(self.error(token, format!("{} is `{token}`; numbers must be finite", what()))),
            Err(_) => Err(self.error(token, format!("expected {} (a number), found `{token}`", what()))),
        }
    }

    /// The numbers of a statement: `min` to `max` (at most [`MAX_NUMBERS`]) finite numbers.
    fn numbers(&self, line: &Line<'a>, what: &str, min: usize, max: usize) -> Result<Numbers, LoadError> {
        let mut out = Numbers { values: [0.0; MAX_NUMBERS], len: 0 };
        let wrong_count = |at: &str| {
            let expected = if min == max { format!("{min}") } else { format!("{min} to {max}") };
            let found = args(line.rest).count();
            let message =
                format!("`{}` takes {expected} numbers ({what}); this one has {found}", line.keyword);
            self.error(at, message)
        };
        for token in args(line.rest) {
            if out.len == max {
                return Err(wrong_count(token));
            }
            out.values[out.len] = self.number_named(token, || format!("a `{}` value", line.keyword))?;
            out.len += 1;
        }
        if out.len < min {
            return Err(wrong_count(line.keyword));
        }
        Ok(out)
    }

    /// The text after the keyword as a name or file name (may contain spaces).
    fn name(&self, line: &Line<'a>) -> Result<&'a str, LoadError> {
        let name = line.rest.trim();
        if name.is_empty() {
            return Err(self.error(line.keyword, format!("`{}` needs a name after it", line.keyword)));
        }
        Ok(name)
    }
}

/// The most numbers a statement takes (`v x y z r g b a`).
const MAX_NUMBERS: usize = 7;

/// The numbers of one statement, without an allocation per line.
struct Numbers {
    values: [f64; MAX_NUMBERS],
    len: usize,
}

impl std::ops::Deref for Numbers {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.values[..self.len]
    }
}

/// The arguments of a numeric statement: words up to a `#`, which starts a comment.
fn args(rest: &str) -> Args<'_> {
    Args(rest)
}

/// A byte loop rather than `split_ascii_whitespace().take_while(..)`: the iterator adapters
/// cost a third of the load time of a large file.
struct Args<'a>(&'a str);

impl<'a> Iterator for Args<'a> {
    type Item = &'a str;

    fn next(&mut self) -> Option<&'a str> {
        let bytes = self.0.as_bytes();
        // A backslash is a line continuation (`Text::lines`), a space between words.
        let space = |b: &u8| b.is_ascii_whitespace() || *b == b'\\';
        let start = bytes.iter().position(|b| !space(b))?;
        if bytes[start] == b'#' {
            self.0 = "";
            return None;
        }
        let end = bytes[start..].iter().position(space).map_or(bytes.len(), |n| start + n);
        let word = &self.0[start..end];
        self.0 = &self.0[end..];
        Some(word)
    }
}

// ---- First pass: counts ----------------------------------------------------------------------

/// What the file declares, counted before anything is allocated.
#[derive(Default)]
struct Counts {
    positions: usize,
    texcoords: usize,
    normals: usize,
    /// At most this many: a polygon of n vertices makes n - 2 triangles or fewer.
    triangles: usize,
}

fn count(text: &Text) -> Result<Counts, LoadError> {
    let mut c = Counts::default();
    let over = |line: &Line, what: &str, limit: usize| {
        text.error(line.keyword, format!("more than {limit} {what} up to this line; irt's limit is {limit}"))
    };
    for line in text.lines() {
        match line.keyword {
            "v" => {
                c.positions += 1;
                if c.positions > MAX_VERTICES {
                    return Err(over(&line, "vertices (`v`)", MAX_VERTICES));
                }
            }
            "vt" => {
                c.texcoords += 1;
                if c.texcoords > MAX_VERTICES {
                    return Err(over(&line, "texture coordinates (`vt`)", MAX_VERTICES));
                }
            }
            "vn" => {
                c.normals += 1;
                if c.normals > MAX_VERTICES {
                    return Err(over(&line, "normals (`vn`)", MAX_VERTICES));
                }
            }
            "f" => {
                c.triangles += args(line.rest).count().saturating_sub(2);
                if c.triangles > MAX_TRIANGLES {
                    return Err(over(&line, "triangles", MAX_TRIANGLES));
                }
            }
            _ => {}
        }
    }
    Ok(c)
}

// ---- Second pass: geometry -------------------------------------------------------------------

/// One mesh in the making: the faces of one material, all with or all without vertex normals
/// and texture coordinates (a mesh has them for every vertex or not at all).
struct MeshBuilder {
    slot: usize,
    normals: bool,
    uvs: bool,
    positions: Vec<DVec3>,
    vertex_normals: Vec<DVec3>,
    /// As the file has them (v up); turned into irt's (v down) when the mesh is finished.
    texcoords: Vec<DVec2>,
    indices: Vec<[u32; 3]>,
}

/// (mesh, v, vt, vn) → vertex of that mesh: OBJ indexes positions, texture coordinates and
/// normals separately, irt's meshes have one index per vertex. Most positions are used with one
/// (vt, vn) in one mesh, so a short list per position (its head indexed by the position) finds
/// the vertex in a step or two, in file order and without hashing: a hash map here took half of
/// the load time of a large file, in cache misses. A position used in more than [`MAX_CHAIN`]
/// ways keeps the rest in a hash map, so that no input makes the lists long.
struct VertexIndex {
    /// Per position of the file: 1 + its first entry, or 0.
    head: Vec<u32>,
    entries: Vec<Entry>,
    overflow: HashMap<(u32, [u32; 3]), u32>,
}

struct Entry {
    mesh: u32,
    vt: u32,
    vn: u32,
    vertex: u32,
    /// 1 + the next entry of the same position, or 0.
    next: u32,
}

/// Entries per position before the rest go to [`VertexIndex::overflow`].
const MAX_CHAIN: usize = 8;

impl VertexIndex {
    /// The vertex of `mesh` for `key`, made by `make` the first time.
    fn vertex(&mut self, mesh: u32, key: [u32; 3], make: impl FnOnce() -> u32) -> u32 {
        let [v, vt, vn] = key;
        let (mut at, mut length) = (self.head[v as usize], 0);
        while at != 0 {
            let e = &self.entries[at as usize - 1];
            if (e.mesh, e.vt, e.vn) == (mesh, vt, vn) {
                return e.vertex;
            }
            (at, length) = (e.next, length + 1);
        }
        if length == MAX_CHAIN {
            return *self.overflow.entry((mesh, key)).or_insert_with(make);
        }
        let vertex = make();
        self.entries.push(Entry { mesh, vt, vn, vertex, next: self.head[v as usize] });
        self.head[v as usize] = self.entries.len() as u32;
        vertex
    }
}

/// A `usemtl` name (or none: faces before any `usemtl`), in order of first use by a face.
struct Slot {
    name: Option<String>,
    /// Line of the `usemtl` before the first face that uses it (of that face, without a name).
    line: usize,
}

/// A statement irt skips, with a warning saying how often and where first.
struct Skipped {
    count: usize,
    line: usize,
}

struct Obj<'a> {
    text: Text<'a>,
    base: PathBuf,
    positions: Vec<DVec3>,
    /// The `w` of `v x y z w` (rational surfaces' weights), filled in once a line has one.
    weights: Vec<f64>,
    freeform: freeform::FreeForm,
    texcoords: Vec<DVec2>,
    /// Unit length; `None` for a zero normal in the file.
    normals: Vec<Option<DVec3>>,
    /// `mtllib` names with their lines, in file order.
    libraries: Vec<(&'a str, usize)>,
    /// The current `usemtl` name and its line.
    current: Option<&'a str>,
    current_line: usize,
    /// The slot of `current`, once a face has used it (saves hashing its name per face).
    current_slot: Option<usize>,
    slots: Vec<Slot>,
    slot_of: HashMap<Option<&'a str>, usize>,
    meshes: Vec<MeshBuilder>,
    /// (slot, normals, uvs) → index into `meshes`.
    mesh_of: HashMap<(usize, bool, bool), usize>,
    index: VertexIndex,
    /// Vertices of all meshes so far.
    vertices: usize,
    skipped: HashMap<&'a str, Skipped>,
    /// Faces without area, faces that mix corners with and without normals or texture
    /// coordinates, faces with a zero normal, vertices with colours: counted for warnings.
    degenerate: usize,
    mixed: Option<usize>,
    zero_normal: Option<usize>,
    colours: Option<usize>,
    warnings: Warnings,
    // Scratch buffers reused by every face.
    corners: Vec<[u32; 3]>,
    points: Vec<DVec3>,
}

impl<'a> Obj<'a> {
    fn new(text: Text<'a>, c: Counts) -> Self {
        Obj {
            text,
            base: Path::new(text.origin).parent().unwrap_or(Path::new("")).to_path_buf(),
            positions: Vec::with_capacity(c.positions),
            weights: Vec::new(),
            freeform: freeform::FreeForm::default(),
            texcoords: Vec::with_capacity(c.texcoords),
            normals: Vec::with_capacity(c.normals),
            libraries: Vec::new(),
            current: None,
            current_line: 0,
            current_slot: None,
            slots: Vec::new(),
            slot_of: HashMap::new(),
            meshes: Vec::new(),
            mesh_of: HashMap::new(),
            index: VertexIndex { head: vec![0; c.positions], entries: Vec::new(), overflow: HashMap::new() },
            vertices: 0,
            skipped: HashMap::new(),
            degenerate: 0,
            mixed: None,
            zero_normal: None,
            colours: None,
            warnings: Warnings::default(),
            corners: Vec::new(),
            points: Vec::new(),
        }
    }

    fn run(&mut self) -> Result<(), LoadError> {
        let text = self.text;
        for line in text.lines() {
            match line.keyword {
                "v" => {
                    let n = text.numbers(&line, "x y z, and an optional w or colour r g b", 3, 7)?;
                    self.positions.push(DVec3::new(n[0], n[1], n[2]));
                    if n.len() >= 6 {
                        self.colours.get_or_insert(line.number);
                    } else if n.len() == 4 {
                        self.weights.resize(self.positions.len() - 1, 1.0);
                        self.weights.push(n[3]);
                    }
                }
                "vt" => {
                    let n = text.numbers(&line, "u, and optional v and w", 1, 3)?;
                    self.texcoords.push(DVec2::new(n[0], n.get(1).copied().unwrap_or(0.0)));
                }
                "vn" => {
                    let n = text.numbers(&line, "x y z", 3, 3)?;
                    self.normals.push(DVec3::new(n[0], n[1], n[2]).try_normalize());
                }
                "f" => self.face(&line)?,
                "usemtl" => {
                    (self.current, self.current_line) = (Some(text.name(&line)?), line.number);
                    self.current_slot = None;
                }
                "mtllib" => self.libraries.push((text.name(&line)?, line.number)),
                k if SILENT.contains(&k) => {}
                k if freeform::STATEMENTS.contains(&k) && !freeform::SKIPPED.contains(&k) => {
                    // A surface takes the current material, as a face does.
                    let slot = if k == "surf" { Some(self.slot(&line)?) } else { None };
                    self.freeform.statement(&text, &line, &self.positions, &self.weights, slot)?;
                }
                k => {
                    let s = self.skipped.entry(k).or_insert(Skipped { count: 0, line: line.number });
                    s.count += 1;
                }
            }
        }
        Ok(())
    }

    /// One face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, as 0-based indices (NONE if absent).
    fn corner(&self, token: &'a str) -> Result<[u32; 3], LoadError> {
        if token.split('/').count() > 3 {
            return Err(self.text.error(
                token,
                format!("`{token}` is not a face vertex: expected v, v/vt, v//vn or v/vt/vn"),
            ));
        }
        let mut parts = token.split('/');
        let mut key = [NONE; 3];
        let lists = [
            ("vertex", "`v`", self.positions.len()),
            ("texture coordinate", "`vt`", self.texcoords.len()),
            ("normal", "`vn`", self.normals.len()),
        ];
        for (k, (what, statement, count)) in lists.into_iter().enumerate() {
            let Some(part) = parts.next() else { break };
            if part.is_empty() && k > 0 {
                continue;
            }
            key[k] = index_in(&self.text, part, token, what, statement, count)?;
        }
        Ok(key)
    }

    fn face(&mut self, line: &Line<'a>) -> Result<(), LoadError> {
        let text = self.text;
        let mut corners = std::mem::take(&mut self.corners);
        corners.clear();
        for token in args(line.rest) {
            if corners.len() == MAX_POLYGON_VERTICES {
                return Err(text.error(
                    token,
                    format!("a face has more than {MAX_POLYGON_VERTICES} vertices; irt's limit is that"),
                ));
            }
            corners.push(self.corner(token)?);
        }
        if corners.len() < 3 {
            return Err(text.error(
                line.keyword,
                format!("a face needs at least 3 vertices; this one has {}", corners.len()),
            ));
        }
        // A face keeps normals (texture coordinates) only if every corner has one: a mesh
        // has them for all its vertices or none.
        let all = |k: usize| corners.iter().all(|c| c[k] != NONE);
        let any = |k: usize| corners.iter().any(|c| c[k] != NONE);
        let (uvs, mut normals) = (all(1), all(2));
        if (any(1) && !uvs) || (any(2) && !normals) {
            self.mixed.get_or_insert(line.number);
        }
        if normals && corners.iter().any(|c| self.normals[c[2] as usize].is_none()) {
            self.zero_normal.get_or_insert(line.number);
            normals = false;
        }
        for c in &mut corners {
            if !uvs {
                c[1] = NONE;
            }
            if !normals {
                c[2] = NONE;
            }
        }
        let mut points = std::mem::take(&mut self.points);
        points.clear();
        points.extend(corners.iter().map(|c| self.positions[c[0] as usize]));
        let triangles = triangulate(&points);
        self.points = points;
        if triangles.is_empty() {
            self.degenerate += 1;
            self.corners = corners;
            return Ok(());
        }
        let m = self.mesh(line, normals, uvs)?;
        let mesh = &mut self.meshes[m];
        let before = mesh.positions.len();
        for t in &triangles {
            let triangle = t.map(|k| {
                let key = corners[k];
                self.index.vertex(m as u32, key, || {
                    mesh.positions.push(self.positions[key[0] as usize]);
                    if uvs {
                        mesh.texcoords.push(self.texcoords[key[1] as usize]);
                    }
                    if normals {
                        mesh.vertex_normals.push(self.normals[key[2] as usize].expect("checked above"));
                    }
                    mesh.positions.len() as u32 - 1
                })
            });
            mesh.indices.push(triangle);
        }
        self.vertices += mesh.positions.len() - before;
        self.corners = corners;
        if self.vertices > MAX_VERTICES {
            return Err(text.error(
                line.keyword,
                format!(
                    "more than {MAX_VERTICES} mesh vertices up to this face (each distinct v/vt/vn is one); \
                     irt's limit is {MAX_VERTICES}"
                ),
            ));
        }
        Ok(())
    }

    /// The mesh for a face (on `line`) of the current material with or without normals and uvs.
    fn mesh(&mut self, line: &Line, normals: bool, uvs: bool) -> Result<usize, LoadError> {
        let slot = self.slot(line)?;
        let next = self.meshes.len();
        let m = *self.mesh_of.entry((slot, normals, uvs)).or_insert(next);
        if m == next {
            self.meshes.push(MeshBuilder {
                slot,
                normals,
                uvs,
                positions: Vec::new(),
                vertex_normals: Vec::new(),
                texcoords: Vec::new(),
                indices: Vec::new(),
            });
        }
        Ok(m)
    }

    /// The material slot of a face or surface (on `line`) of the current material.
    fn slot(&mut self, line: &Line) -> Result<usize, LoadError> {
        let next = self.slots.len();
        let slot =
            *self.current_slot.get_or_insert_with(|| *self.slot_of.entry(self.current).or_insert(next));
        if slot == next {
            // Here, before the slot's mesh is made: one face per material would take memory fast.
            if next == MAX_MATERIALS {
                return Err(self.text.error(
                    line.keyword,
                    format!("this face's material is one more than irt's limit of {MAX_MATERIALS}"),
                ));
            }
            let line = if self.current.is_some() { self.current_line } else { line.number };
            self.slots.push(Slot { name: self.current.map(str::to_string), line });
        }
        Ok(slot)
    }

    fn warn_at(&mut self, line: usize, message: String) {
        self.warnings.warn(format!("{}:{line}: {message}", self.text.origin));
    }

    fn finish(mut self) -> Result<Model, LoadError> {
        self.warn_skipped();
        self.freeform.finish(&self.text)?;
        if self.meshes.is_empty() && self.freeform.patches.is_empty() {
            return Err(LoadError::new(
                self.text.origin,
                "the file has no faces to render: add polygons (`f` lines) with an area, or surfaces (`surf`)",
            ));
        }
        let libraries = std::mem::take(&mut self.libraries);
        let definitions = Libraries::load(&libraries, &self.base, self.text.origin, &mut self.warnings)?;
        let mut materials = Materials::new(self.text.origin, &self.base, &mut self.warnings);
        let mut slot_material = Vec::with_capacity(self.slots.len());
        for slot in &self.slots {
            slot_material.push(materials.material(slot, &definitions)?);
        }
        let mut meshes = Vec::with_capacity(self.meshes.len());
        // Meshes in the order their materials were first used (stable: then in creation order).
        self.meshes.sort_by_key(|m| m.slot);
        for b in self.meshes {
            let (material, texture) = &slot_material[b.slot];
            let transform = texture.as_ref().map_or(UvTransform::IDENTITY, |t| t.transform);
            let uvs = b.uvs.then(|| b.texcoords.iter().map(|&uv| transform.apply(uv)).collect::<Vec<_>>());
            if let (Some(t), Some(uv)) =
                (texture, uvs.as_ref().and_then(|uvs| uvs.iter().find(|uv| !uv.is_finite())))
            {
                return Err(t.error(format!(
                    "the texture's -o/-s transform takes the texture coordinates to ({}, {}), which is not finite",
                    uv.x, uv.y
                )));
            }
            if uvs.is_none() && materials.out[*material as usize].texture.is_some() {
                let name = materials.out[*material as usize].name.clone();
                materials.warnings.warn(format!(
                    "{}: faces of the textured material '{name}' have no texture coordinates (`vt`); \
                     they read the texture at (0, 0)",
                    self.text.origin
                ));
            }
            meshes.push(Mesh {
                positions: b.positions,
                normals: b.normals.then_some(b.vertex_normals),
                uvs,
                indices: b.indices,
                material: *material,
            });
        }
        let patches = std::mem::take(&mut self.freeform.patches)
            .into_iter()
            .map(|(patch, slot)| crate::scene::patch::Patch { material: slot_material[slot].0, ..patch })
            .collect();
        Ok(Model {
            meshes,
            patches,
            materials: materials.out,
            textures: materials.textures,
            ..Default::default()
        })
    }

    fn warn_skipped(&mut self) {
        if self.degenerate > 0 {
            let n = self.degenerate;
            self.warnings.warn(format!("{}: skipped {n} faces without area", self.text.origin));
        }
        if let Some(line) = self.mixed {
            self.warn_at(
                line,
                "a face mixes corners with and without texture coordinates or normals; such faces drop them"
                    .into(),
            );
        }
        if let Some(line) = self.zero_normal {
            self.warn_at(line, "a face uses a zero normal (`vn 0 0 0`); such faces are flat-shaded".into());
        }
        if let Some(line) = self.colours {
            self.warn_at(line, "vertex colours (`v x y z r g b`) are ignored".into());
        }
        let mut skipped: Vec<_> = self.skipped.drain().collect();
        skipped.sort_by_key(|(_, s)| s.line);
        for (keyword, s) in skipped {
            let why = match keyword {
                "l" => "lines have no surface to ray trace",
                "p" => "points have no surface to ray trace",
                k if freeform::SKIPPED.contains(&k) => "free-form curves and points have no surface to trace",
                "call" => "irt does not include other files",
                "csh" => "irt runs no commands",
                _ => "an unknown statement",
            };
            let times = if s.count == 1 { String::new() } else { format!(" ({} times)", s.count) };
            self.warnings.warn(format!("{}:{}: `{keyword}` ignored{times}: {why}", self.text.origin, s.line));
        }
    }
}

/// A 1-based index, or a negative one counting back from the last defined so far: `part` of
/// `token`, into `count` items of `what` (defined by `statement` lines).
fn index_in(
    text: &Text,
    part: &str,
    token: &str,
    what: &str,
    statement: &str,
    count: usize,
) -> Result<u32, LoadError> {
    let bad = |m: String| Err(text.error(part, m));
    let Ok(i) = part.parse::<i64>() else {
        return bad(format!("expected a {what} index (a whole number) in `{token}`, found `{part}`"));
    };
    let k = match i {
        0 => return bad(format!("{what} index 0 in `{token}`: OBJ indices start at 1 (-1 is the last)")),
        i if i > 0 => i - 1,
        i => count as i64 + i,
    };
    if k < 0 || k >= count as i64 {
        return bad(format!(
            "{what} index {i} in `{token}` is out of range: {count} {statement} lines come before this line"
        ));
    }
    Ok(k as u32)
}

/// A control point's index (`v` of a `surf`).
fn vertex_index(text: &Text, part: &str, token: &str, count: usize) -> Result<u32, LoadError> {
    index_in(text, part, token, "vertex", "`v`", count)
}

/// Warnings, each logged once.
#[derive(Default)]
struct Warnings(HashSet<String>);

impl Warnings {
    fn warn(&mut self, message: String) {
        if self.0.insert(message.clone()) {
            log::warn!("{message}");
        }
    }
}

// ---- MTL material libraries ------------------------------------------------------------------

/// A base-colour texture reference (`map_Kd [options] file`).
#[derive(Clone, Debug, PartialEq)]
struct TextureRef {
    file: String,
    clamp: bool,
    /// `-o` and `-s`: the texture is read at `offset + scale ⊙ uv` (u and v; w is ignored).
    transform: UvTransform,
    /// The MTL file and line of the statement, for messages.
    mtl: String,
    line: usize,
}

impl TextureRef {
    fn at(&self) -> String {
        format!("{}:{}", self.mtl, self.line)
    }

    fn error(&self, message: String) -> LoadError {
        LoadError { line: Some(self.line), ..LoadError::new(&self.mtl, message) }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct UvTransform {
    offset: DVec2,
    scale: DVec2,
}

impl UvTransform {
    const IDENTITY: UvTransform = UvTransform { offset: DVec2::ZERO, scale: DVec2::ONE };

    /// The file's (u, v), v up from the bottom of the image, as irt's, v down from the top.
    fn apply(&self, uv: DVec2) -> DVec2 {
        let t = self.offset + self.scale * uv;
        DVec2::new(t.x, 1.0 - t.y)
    }
}

/// One `newmtl` and the statements irt reads from it.
#[derive(Clone, Debug, Default, PartialEq)]
struct Definition {
    kd: Option<DVec3>,
    ks: Option<DVec3>,
    ns: Option<f64>,
    ni: Option<f64>,
    d: Option<f64>,
    tr: Option<f64>,
    illum: Option<u32>,
    map_kd: Option<TextureRef>,
    /// The directory of the MTL file (textures are looked for there first).
    dir: PathBuf,
}

/// Every material defined by the file's `mtllib`s, by name (a later definition of a name
/// replaces an earlier one).
struct Libraries(HashMap<String, Definition>);

impl Libraries {
    fn load(
        libraries: &[(&str, usize)],
        base: &Path,
        origin: &str,
        warnings: &mut Warnings,
    ) -> Result<Libraries, LoadError> {
        let mut seen = HashSet::new();
        let mut out = HashMap::new();
        for &(names, line) in libraries {
            // `mtllib a.mtl b.mtl` names two files, but a file name may contain spaces: the
            // whole text is one name if such a file exists.
            let whole = find(base, &[], names);
            let files: Vec<&str> = if whole.is_some() { vec![names] } else { args(names).collect() };
            for name in files {
                let Some(path) = find(base, &[], name) else {
                    warnings.warn(format!(
                        "{origin}:{line}: material library '{}' not found; its materials are grey",
                        base.join(name).display()
                    ));
                    continue;
                };
                if !seen.insert(path.clone()) {
                    continue;
                }
                let bytes = match read_limited(&path, MAX_MTL_BYTES, "material library") {
                    Ok(b) => b,
                    Err(m) => {
                        warnings.warn(format!(
                            "{origin}:{line}: '{}': {m}; its materials are grey",
                            path.display()
                        ));
                        continue;
                    }
                };
                let file = path.display().to_string();
                let src = String::from_utf8_lossy(&bytes);
                let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
                parse_mtl(Text { src: &src, origin: &file }, &dir, warnings, &mut out)?;
            }
        }
        Ok(Libraries(out))
    }
}

/// The first of `name` (and, for files written on Windows, `name` with `\` as `/`) that exists
/// as a file in `dir` or one of `more` directories.
fn find(dir: &Path, more: &[&Path], name: &str) -> Option<PathBuf> {
    let slashed = name.replace('\\', "/");
    std::iter::once(dir)
        .chain(more.iter().copied())
        .flat_map(|d| [d.join(name), d.join(&slashed)])
        .find(|p| p.is_file())
}

/// Reads the materials of one MTL file into `out`.
fn parse_mtl(
    text: Text,
    dir: &Path,
    warnings: &mut Warnings,
    out: &mut HashMap<String, Definition>,
) -> Result<(), LoadError> {
    let mut current: Option<(String, Definition)> = None;
    let mut defined = 0usize;
    for line in text.lines() {
        if line.keyword == "newmtl" {
            let name = text.name(&line)?;
            defined += 1;
            if defined > MAX_MATERIALS {
                return Err(text.error(
                    line.keyword,
                    format!("more than {MAX_MATERIALS} materials; irt's limit is that"),
                ));
            }
            if let Some((name, d)) = current.take() {
                out.insert(name, d);
            }
            let d = Definition { dir: dir.to_path_buf(), ..Definition::default() };
            current = Some((name.to_string(), d));
            continue;
        }
        let Some((_, d)) = current.as_mut() else {
            return Err(text.error(line.keyword, format!("`{}` comes before any `newmtl`", line.keyword)));
        };
        let warn = |warnings: &mut Warnings, m: String| {
            warnings.warn(format!("{}:{}: {m}", text.origin, line.number));
        };
        match line.keyword {
            "Kd" | "Ks" => {
                let first = args(line.rest).next();
                if matches!(first, Some("spectral" | "xyz")) {
                    warn(
                        warnings,
                        format!("`{} {}` colours are ignored: irt reads r g b", line.keyword, first.unwrap()),
                    );
                    continue;
                }
                let n = text.numbers(&line, "r, and optional g b", 1, 3)?;
                if n.len() == 2 {
                    return Err(text.error(
                        line.keyword,
                        format!("`{}` takes r g b, or r alone; this one has 2 numbers", line.keyword),
                    ));
                }
                let c = if n.len() == 1 { DVec3::splat(n[0]) } else { DVec3::new(n[0], n[1], n[2]) };
                let at = args(line.rest).next().unwrap_or(line.keyword);
                if c.min_element() < 0.0 {
                    return Err(text.error(
                        at,
                        format!("`{}` ({}, {}, {}) must not be negative", line.keyword, c.x, c.y, c.z),
                    ));
                }
                if c.max_element() > 1.0 {
                    warn(
                        warnings,
                        format!("`{}` ({}, {}, {}) is brighter than 1; clamped", line.keyword, c.x, c.y, c.z),
                    );
                }
                let c = c.min(DVec3::ONE);
                if line.keyword == "Kd" {
                    d.kd = Some(c);
                } else {
                    d.ks = Some(c);
                }
            }
            "Ns" => d.ns = Some(ranged(&text, &line, "Ns", 0.0, f64::INFINITY)?),
            "Ni" => {
                let ni = single(&text, &line)?;
                if ni <= 0.0 {
                    return Err(text.error(
                        args(line.rest).next().unwrap(),
                        format!("`Ni` {ni} must be greater than 0"),
                    ));
                }
                d.ni = Some(ni);
            }
            "d" => {
                // `d -halo f`: the dissolve depends on the view; irt takes f.
                let tokens: Vec<&str> = args(line.rest).collect();
                let token = match tokens.as_slice() {
                    ["-halo", t] | [t] => *t,
                    _ => {
                        return Err(text.error(
                            tokens.first().copied().unwrap_or(line.keyword),
                            "`d` takes one number (or -halo and a number)",
                        ))
                    }
                };
                let x = text.number(token, "the `d` value")?;
                if !(0.0..=1.0).contains(&x) {
                    return Err(text.error(token, format!("`d` {x} is out of range: 0 to 1")));
                }
                d.d = Some(x);
            }
            "Tr" => d.tr = Some(ranged(&text, &line, "Tr", 0.0, 1.0)?),
            "illum" => {
                let token = args(line.rest).next().unwrap_or(line.keyword);
                match token.parse::<u32>() {
                    Ok(i) if i <= 10 && args(line.rest).count() == 1 => d.illum = Some(i),
                    _ => return Err(text.error(token, "`illum` takes one illumination model, 0 to 10")),
                }
            }
            "map_Kd" => d.map_kd = Some(texture_ref(&text, &line, warnings)?),
            // Everything else describes what irt does not draw (ambient, emission, other maps,
            // PBR extensions); docs/obj.md lists them.
            _ => {}
        }
    }
    if let Some((name, d)) = current {
        out.insert(name, d);
    }
    Ok(())
}

fn single(text: &Text, line: &Line) -> Result<f64, LoadError> {
    Ok(text.numbers(line, "one value", 1, 1)?[0])
}

fn ranged(text: &Text, line: &Line, what: &str, lo: f64, hi: f64) -> Result<f64, LoadError> {
    let x = single(text, line)?;
    if x < lo || x > hi {
        let range = if hi.is_infinite() { format!("at least {lo}") } else { format!("{lo} to {hi}") };
        return Err(
            text.error(args(line.rest).next().unwrap(), format!("`{what}` {x} is out of range: {range}"))
        );
    }
    Ok(x)
}

/// `map_Kd [options] file`: -clamp, -o and -s are read, the other options skipped; the file
/// name is the rest of the line (it may contain spaces).
fn texture_ref(text: &Text, line: &Line, warnings: &mut Warnings) -> Result<TextureRef, LoadError> {
    let tokens: Vec<&str> = line.rest.split_ascii_whitespace().collect();
    let mut t = TextureRef {
        file: String::new(),
        clamp: false,
        transform: UvTransform::IDENTITY,
        mtl: text.origin.to_string(),
        line: line.number,
    };
    let mut i = 0;
    // Options with a fixed number of arguments, and -o/-s/-t with 1 to 3 numbers.
    while i < tokens.len() && tokens[i].starts_with('-') {
        let option = tokens[i];
        i += 1;
        let fixed = match option {
            "-blendu" | "-blendv" | "-cc" | "-clamp" | "-texres" | "-bm" | "-boost" | "-imfchan"
            | "-type" => 1,
            "-mm" => 2,
            "-o" | "-s" | "-t" => {
                let numbers: Vec<f64> =
                    tokens[i..].iter().take(3).map_while(|s| s.parse::<f64>().ok()).collect();
                // The last token is the file name even if it looks like a number.
                let n = numbers.len().min(tokens.len().saturating_sub(i + 1));
                if n == 0 {
                    return Err(text.error(option, format!("`{option}` takes 1 to 3 numbers")));
                }
                for k in 0..n {
                    text.number(tokens[i + k], &format!("a `{option}` value"))?;
                }
                let (u, v) = (numbers[0], if n > 1 { numbers[1] } else { numbers[0] });
                match option {
                    "-o" => t.transform.offset = DVec2::new(u, v),
                    "-s" => t.transform.scale = DVec2::new(u, v),
                    _ => {}
                }
                i += n;
                continue;
            }
            _ => {
                warnings.warn(format!("{}: unknown `map_Kd` option `{option}` ignored", t.at()));
                0
            }
        };
        if i + fixed >= tokens.len() {
            return Err(
                text.error(option, format!("`{option}` needs {fixed} value(s) and a file name after it"))
            );
        }
        if option == "-clamp" {
            t.clamp = match tokens[i] {
                "on" => true,
                "off" => false,
                v => return Err(text.error(tokens[i], format!("`-clamp` is `on` or `off`, not `{v}`"))),
            };
        }
        i += fixed;
    }
    let Some(&first) = tokens.get(i) else {
        return Err(text.error(line.keyword, "`map_Kd` needs a file name"));
    };
    let start = text.offset(first);
    let end = text.offset(tokens[tokens.len() - 1]) + tokens[tokens.len() - 1].len();
    t.file = text.src[start..end].to_string();
    Ok(t)
}

// ---- MTL → irt materials ---------------------------------------------------------------------

/// The paper's material for an MTL definition (docs/obj.md has the table): transparent →
/// dielectric; no highlight → diffuse; a diffuse part under a tenth of the specular one → metal
/// (NFF's rule); a ray-traced reflection → polished with a coat as reflective as Ks; a
/// highlight only → polished under a plastic-like coat.
pub fn material_kind(
    kd: DVec3,
    ks: DVec3,
    ns: Option<f64>,
    ni: Option<f64>,
    dissolve: f64,
    illum: Option<u32>,
) -> MaterialKind {
    let exponent = |default: f64| ns.map_or(default, |n| n.clamp(MIN_EXPONENT, MAX_EXPONENT));
    let illum_in = |models: &[u32]| illum.is_some_and(|i| models.contains(&i));
    if illum_in(&TRANSPARENT_ILLUM) || dissolve < 1.0 {
        // Exporters write Ni 1 for anything; glass of index 1 would be invisible.
        let eta = ni.filter(|&n| n != 1.0).unwrap_or(DEFAULT_ETA);
        MaterialKind::Dielectric { eta, exponent: exponent(DEFAULT_COAT_EXPONENT) }
    } else if illum_in(&[0, 1]) || ks.max_element() == 0.0 {
        MaterialKind::Diffuse { color: kd }
    } else if kd.max_element() < METAL_KD_OVER_KS * ks.max_element() {
        MaterialKind::Metal { color: ks, exponent: exponent(DEFAULT_METAL_EXPONENT) }
    } else if illum_in(&REFLECTIVE_ILLUM) {
        MaterialKind::Polished {
            color: kd,
            eta: coat_eta(ks.max_element()),
            exponent: exponent(DEFAULT_COAT_EXPONENT),
        }
    } else {
        let eta = ni.filter(|&n| n > 1.0).unwrap_or(DEFAULT_ETA);
        MaterialKind::Polished { color: kd, eta, exponent: exponent(DEFAULT_COAT_EXPONENT) }
    }
}

/// The scene's materials and textures, made from the definitions the faces use.
struct Materials<'w> {
    origin: String,
    base: PathBuf,
    warnings: &'w mut Warnings,
    out: Vec<Material>,
    textures: Vec<Texture>,
    budget: PixelBudget,
    /// (file, clamp) → texture, or None for a file irt cannot use.
    texture_of: HashMap<(PathBuf, bool), Option<u32>>,
}

impl<'w> Materials<'w> {
    fn new(origin: &str, base: &Path, warnings: &'w mut Warnings) -> Self {
        Materials {
            origin: origin.to_string(),
            base: base.to_path_buf(),
            warnings,
            out: Vec::new(),
            textures: Vec::new(),
            budget: PixelBudget::default(),
            texture_of: HashMap::new(),
        }
    }

    /// The scene material of a `usemtl` slot, and its texture reference if it is textured.
    fn material(
        &mut self,
        slot: &Slot,
        libraries: &Libraries,
    ) -> Result<(u32, Option<TextureRef>), LoadError> {
        let default = Definition::default();
        let (base_name, definition) = match &slot.name {
            None => ("default".to_string(), &default),
            Some(name) => match libraries.0.get(name) {
                Some(d) => (name.clone(), d),
                None => {
                    self.warnings.warn(format!(
                        "{}:{}: material '{name}' is not defined in any material library; it is grey",
                        self.origin, slot.line
                    ));
                    (name.clone(), &default)
                }
            },
        };
        let d = definition;
        let kd = d.kd.unwrap_or(DVec3::splat(DEFAULT_DIFFUSE_COLOR));
        let dissolve = d.d.or(d.tr.map(|tr| 1.0 - tr)).unwrap_or(1.0);
        let kind = material_kind(kd, d.ks.unwrap_or(DVec3::ZERO), d.ns, d.ni, dissolve, d.illum);
        // A dielectric has no colour for a texture to modulate.
        let texture = match (&kind, &d.map_kd) {
            (MaterialKind::Dielectric { .. }, _) | (_, None) => None,
            (_, Some(t)) => self.texture(t, d)?.map(|i| (i, t.clone())),
        };
        let name = unique_name(base_name, |n| self.out.iter().any(|m| m.name == n));
        self.out.push(Material { name, kind, texture: texture.as_ref().map(|t| t.0) });
        Ok((self.out.len() as u32 - 1, texture.map(|t| t.1)))
    }

    /// A `map_Kd` texture, decoded once per file and wrap; None (with a warning) for a file
    /// that is missing or not a PNG.
    fn texture(&mut self, t: &TextureRef, d: &Definition) -> Result<Option<u32>, LoadError> {
        // Exporters write texture paths relative to the MTL file, or to the OBJ.
        let Some(path) = find(&d.dir, &[&self.base], &t.file) else {
            self.warnings.warn(format!(
                "{}: texture '{}' not found; the material uses its colour alone",
                t.at(),
                d.dir.join(&t.file).display()
            ));
            return Ok(None);
        };
        let key = (path.clone(), t.clamp);
        if let Some(&slot) = self.texture_of.get(&key) {
            return Ok(slot);
        }
        let what = format!("texture file '{}'", path.display());
        // The header first: a file that is not a PNG, or too big, is not read whole.
        let decoded = png::read_header(&path)
            .map_err(|e| Unusable::Refused(e.to_string()))
            .and_then(|header| png::checked_size(&header, &what))
            .and_then(|(w, h)| {
                self.budget.take(w, h).map_err(|m| Unusable::Refused(format!("{what}: {m}")))?;
                let bytes = read_limited(&path, MAX_TEXTURE_FILE_BYTES, "texture file")
                    .map_err(|m| Unusable::Refused(format!("{what}: {m}")))?;
                png::decode(&bytes, &what)
            });
        let slot = match decoded {
            Ok((width, height, texels)) => {
                if self.textures.len() >= MAX_TEXTURES {
                    return Err(t.error(format!("more than {MAX_TEXTURES} textures; irt's limit is that")));
                }
                let name = unique_name(t.file.clone(), |n| self.textures.iter().any(|x| x.name == n));
                let wrap = if t.clamp { [Wrap::Clamp; 2] } else { [Wrap::Repeat; 2] };
                self.textures.push(Texture { name, width, height, texels, wrap, filter: Filter::Linear });
                Some(self.textures.len() as u32 - 1)
            }
            Err(Unusable::Refused(m)) => return Err(t.error(m)),
            Err(Unusable::NotPng(m)) => {
                self.warnings.warn(format!("{}: {m}; the material uses its colour alone", t.at()));
                None
            }
        };
        self.texture_of.insert(key, slot);
        Ok(slot)
    }
}
