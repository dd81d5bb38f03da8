//! glTF 2.0 scenes (`.gltf` with embedded or external buffers, `.glb`) → [`Scene`].
//!
//! docs/gltf.md says what is read and how it maps onto the paper's materials and lights. The
//! `gltf` crate parses the JSON (or splits the GLB container) and checks that every index
//! refers to an object that exists; this module reads the binary data itself, so that every
//! count, offset and size is checked against its buffer before anything is allocated, and every
//! problem names the JSON object it comes from (`accessors[3]`, `meshes[0].primitives[1]`).

use super::png::{self, Unusable};
use super::stage::{self, Model};
use super::toml::{DEFAULT_HEIGHT, DEFAULT_WIDTH};
use super::{
    read_limited, unique_name, LoadError, MAX_MATERIALS, MAX_SCENE_FILE_BYTES, MAX_TRIANGLES, MAX_VERTICES,
};
use crate::scene::{
    Animated, Camera, Channel, Filter, Interpolation, Light, Material, MaterialKind, Mesh, Motion, Rotation,
    Scene, Stage, Target, Texture, Trs, Wrap, MAX_LIGHTS, MAX_TEXTURES,
};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::json;
use ::gltf::khr_lights_punctual::Kind as LightKind;
use ::gltf::mesh::Mode;
use ::gltf::scene::Transform;
use ::gltf::texture::{MagFilter, WrappingMode};
use ::gltf::{Accessor, Document, Semantic};
use glam::{DAffine3, DMat3, DMat4, DQuat, DVec2, DVec3};
use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Extensions irt reads (docs/gltf.md); a file that *requires* any other is refused, since it
/// could not be shown as meant. Extensions that are only used are ignored.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_clearcoat",
    "KHR_texture_transform",
];
/// All buffers of one file together; external buffer files are limited like scene files.
pub const MAX_BUFFER_BYTES: u64 = MAX_SCENE_FILE_BYTES;
/// A metal rougher than this reflects a blur that looks matte, not the paper's mirror, so it
/// becomes diffuse in its base colour.
pub const METAL_MAX_ROUGHNESS: f64 = 0.5;
/// Range of the Blinn–Phong exponent made from a roughness ([`blinn_exponent`]).
pub const MIN_EXPONENT: f64 = 1.0;
pub const MAX_EXPONENT: f64 = 10_000.0;
/// Most numbers' worth of animation data one file may hold: keys read (every sampler's input
/// and output counts, summed over the channels that use them), and keys copied into the
/// meshes' motions (a mesh under an animated node carries that node's channels). Both are known
/// from declared counts before anything is allocated.
pub const MAX_ANIMATION_KEYS: usize = 1 << 22;

/// A loader step's result: the message alone, which [`parse`] puts after the file's name
/// (`LoadError::new(origin, …)`) and nothing inspects on the way; a type around the text would
/// only wrap some 60 `format!`s.
type Res<T> = Result<T, String>;

/// Parses and validates a glTF or GLB file. `origin` is its path: external buffers and images
/// are found relative to it, and it names the file in error messages.
pub fn parse(bytes: &[u8], origin: &str) -> Result<Scene, LoadError> {
    let fail = |message: String| LoadError::new(origin, message);
    let (doc, blob) = open(bytes, origin)?;
    let base = Path::new(origin).parent();
    let buffers = load_buffers(&doc, blob, base).map_err(fail)?;
    let scene = Builder::new(&doc, &buffers, base, origin).build().map_err(fail)?;
    // Everything is checked on the way in; this is the scene model's own guard.
    scene.validate().map_err(|e| fail(e.0))?;
    Ok(scene)
}

// ---- The container and the JSON ------------------------------------------------------------

/// The validated document and the GLB's binary chunk, if any.
fn open<'a>(bytes: &'a [u8], origin: &str) -> Result<(Document, Option<&'a [u8]>), LoadError> {
    let fail = |message: String| LoadError::new(origin, message);
    let glb = bytes.starts_with(b"glTF");
    let (text, blob): (Cow<[u8]>, Option<&[u8]>) = if glb {
        check_glb_header(bytes).map_err(fail)?;
        let glb = ::gltf::Glb::from_slice(bytes).map_err(|e| fail(format!("not a valid GLB file: {e}")))?;
        let bin = match glb.bin {
            Some(Cow::Borrowed(bin)) => Some(bin),
            // from_slice borrows; anything else would be a change in the crate.
            Some(Cow::Owned(_)) | None => None,
        };
        (glb.json, bin)
    } else {
        (Cow::Borrowed(bytes), None)
    };
    let mut root: json::Root =
        serde_json::from_slice(&text).map_err(|e| json_error(&e, &text, glb, origin))?;
    check_version(&root.asset.version).map_err(fail)?;
    for (i, ext) in root.extensions_required.iter().enumerate() {
        if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
            return Err(fail(format!(
                "extensionsRequired[{i}] is '{ext}', which irt does not support (it reads {})",
                SUPPORTED_EXTENSIONS.join(", ")
            )));
        }
    }
    // Checked just above. The crate would refuse KHR_materials_clearcoat, which it has no
    // type for; irt reads that one from the raw JSON.
    root.extensions_required.clear();
    check_position_accessors(&root).map_err(fail)?;
    let doc = Document::from_json(root).map_err(|e| fail(validation_message(e)))?;
    Ok((doc, blob))
}

/// The crate's validation reads each primitive's POSITION accessor (for its `min`/`max`) before
/// it checks that the index exists, and panics on one past the end (found by
/// tests/fuzz_loaders.rs; docs/fuzzing.md); this checks those indices first.
fn check_position_accessors(root: &json::Root) -> Res<()> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position =
                primitive.attributes.get(&json::validation::Checked::Valid(json::mesh::Semantic::Positions));
            if let Some(index) = position.filter(|i| i.value() >= root.accessors.len()) {
                return Err(format!(
                    "invalid glTF: meshes[{m}].primitives[{p}].attributes.POSITION refers to accessor {}, \
                     but the file has {} accessors",
                    index.value(),
                    root.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// The GLB header fields the crate trusts (it subtracts from the declared length).
fn check_glb_header(bytes: &[u8]) -> Res<()> {
    let word = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap()));
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!("a GLB file needs a 12-byte header; this one has {} bytes", bytes.len()));
    };
    if version != 2 {
        return Err(format!("GLB version {version}; irt reads version 2"));
    }
    if length < 20 || length as usize > bytes.len() {
        return Err(format!(
            "the GLB header declares {length} bytes, but the file has {} (and a GLB needs at least 20)",
            bytes.len()
        ));
    }
    Ok(())
}

fn check_version(version: &str) -> Res<()> {
    match version.split('.').next() {
        Some("2") => Ok(()),
        _ => Err(format!("asset.version is '{version}'; irt reads glTF 2.0")),
    }
}

/// A JSON error at its line and column. glTF 1.0 files fail here too, so a file that says it is
/// not 2.0 is told so instead of the first field that differs.
fn json_error(e: &serde_json::Error, text: &[u8], glb: bool, origin: &str) -> LoadError {
    #[derive(serde::Deserialize)]
    struct VersionOnly {
        asset: AssetVersion,
    }
    #[derive(serde::Deserialize)]
    struct AssetVersion {
        version: String,
    }
    if let Ok(v) = serde_json::from_slice::<VersionOnly>(text) {
        if let Err(m) = check_version(&v.asset.version) {
            return LoadError::new(origin, m);
        }
    }
    let full = e.to_string();
    let message = full.rsplit_once(" at line ").map_or(full.as_str(), |(m, _)| m);
    if e.line() == 0 {
        return LoadError::new(origin, format!("invalid glTF JSON: {message}"));
    }
    if glb {
        let at = format!("line {} column {}", e.line(), e.column());
        return LoadError::new(origin, format!("invalid JSON in the GLB's JSON chunk at {at}: {message}"));
    }
    // serde_json counts columns in bytes; LoadError counts characters.
    match std::str::from_utf8(text) {
        Ok(src) => {
            let line_start: usize = src.split_inclusive('\n').take(e.line() - 1).map(str::len).sum::<usize>();
            LoadError::at(
                origin,
                src,
                line_start + e.column().saturating_sub(1),
                format!("invalid glTF JSON: {message}"),
            )
        }
        Err(_) => LoadError::new(origin, format!("invalid glTF JSON: {full}")),
    }
}

/// The crate's validation errors, with the JSON path of each (at most a few).
fn validation_message(e: ::gltf::Error) -> String {
    use json::validation::Error as V;
    let ::gltf::Error::Validation(errors) = e else { return format!("invalid glTF: {e}") };
    const SHOWN: usize = 3;
    let mut parts: Vec<String> = errors
        .iter()
        .take(SHOWN)
        .map(|(path, error)| {
            let what = match error {
                V::IndexOutOfBounds => "refers to an object that does not exist (index out of range)",
                V::Invalid => "has an invalid value",
                V::Missing => "is required but missing",
                V::Oversize => "is too large",
                V::Unsupported => "names an unsupported extension",
            };
            format!("{path} {what}")
        })
        .collect();
    if errors.len() > SHOWN {
        parts.push(format!("and {} more problems", errors.len() - SHOWN));
    }
    format!("invalid glTF: {}", parts.join("; "))
}

// ---- Buffers -------------------------------------------------------------------------------

/// The bytes of every buffer: the GLB's binary chunk, a base64 data URI or an external file.
fn load_buffers<'a>(doc: &Document, blob: Option<&'a [u8]>, base: Option<&Path>) -> Res<Vec<Cow<'a, [u8]>>> {
    let mut total = 0u64;
    let mut out = Vec::with_capacity(doc.buffers().len());
    for b in doc.buffers() {
        let what = format!("buffers[{}]", b.index());
        let declared = b.length();
        total = total.saturating_add(declared as u64);
        if total > MAX_BUFFER_BYTES {
            return Err(format!(
                "{what}: the buffers declare more than {MAX_BUFFER_BYTES} bytes in all; irt's limit is that"
            ));
        }
        let data = match b.source() {
            ::gltf::buffer::Source::Bin => Cow::Borrowed(blob.ok_or_else(|| {
                format!("{what} has no uri, so it is the GLB binary chunk, but the file has none")
            })?),
            ::gltf::buffer::Source::Uri(uri) => Cow::Owned(read_uri(uri, base, &what)?),
        };
        if data.len() < declared {
            return Err(format!("{what} declares byteLength {declared} but holds {} bytes", data.len()));
        }
        out.push(data);
    }
    Ok(out)
}

/// A data URI's bytes or an external file's, relative to the glTF file.
fn read_uri(uri: &str, base: Option<&Path>, what: &str) -> Res<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((header, payload)) = rest.split_once(',') else {
            return Err(format!("{what}: the data URI has no ',' before its data"));
        };
        if !header.ends_with(";base64") {
            return Err(format!("{what}: only base64 data URIs are supported (found 'data:{header}')"));
        }
        return base64_decode(payload).map_err(|e| format!("{what}: the data URI is not valid base64: {e}"));
    }
    let scheme = uri.split_once(':').is_some_and(|(s, _)| !s.is_empty() && !s.contains(['/', '\\']));
    if scheme || uri.starts_with('/') {
        return Err(format!("{what}: '{uri}' is neither a relative file path nor a data URI"));
    }
    let relative = percent_decode(uri).ok_or_else(|| format!("{what}: '{uri}' has an invalid %-escape"))?;
    let path = base.unwrap_or(Path::new(".")).join(relative);
    read_limited(&path, MAX_SCENE_FILE_BYTES, "file")
        .map_err(|m| format!("{what} ('{}'): {m}", path.display()))
}

/// Why a data URI's payload is not base64.
#[derive(Debug, thiserror::Error)]
enum Base64Error {
    #[error("{0} characters cannot encode whole bytes")]
    Length(usize),
    #[error("byte {at} (0x{byte:02x}) is not a base64 character")]
    Byte { at: usize, byte: u8 },
}

/// Standard base64 (RFC 4648; `=` padding optional), as data URIs use.
fn base64_decode(text: &str) -> Result<Vec<u8>, Base64Error> {
    let body = text.trim_end_matches('=');
    if body.len() % 4 == 1 {
        return Err(Base64Error::Length(body.len()));
    }
    let mut out = Vec::with_capacity(body.len() / 4 * 3 + 2);
    let (mut acc, mut bits) = (0u32, 0u32);
    for (i, c) in body.bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return Err(Base64Error::Byte { at: i, byte: c }),
        };
        acc = (acc << 6) | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

/// `%XX` escapes in a relative URI; `None` for a broken escape or a result that is not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let mut out = Vec::with_capacity(uri.len());
    let mut bytes = uri.bytes();
    while let Some(b) = bytes.next() {
        if b == b'%' {
            let hex = [bytes.next()?, bytes.next()?];
            out.push(u8::from_str_radix(std::str::from_utf8(&hex).ok()?, 16).ok()?);
        } else {
            out.push(b);
        }
    }
    String::from_utf8(out).ok()
}

// ---- Accessors -----------------------------------------------------------------------------

/// The bytes of an accessor's elements, checked to lie inside its buffer view and buffer.
struct Elements<'b> {
    data: &'b [u8],
    stride: usize,
    size: usize,
    count: usize,
}

impl<'b> Elements<'b> {
    fn get(&self, i: usize) -> &'b [u8] {
        &self.data[i * self.stride..i * self.stride + self.size]
    }
}

fn accessor_name(a: &Accessor) -> String {
    format!("accessors[{}]", a.index())
}

fn elements<'b>(a: &Accessor, buffers: &'b [Cow<[u8]>]) -> Res<Elements<'b>> {
    let what = accessor_name(a);
    if a.sparse().is_some() {
        return Err(format!("{what} is sparse; irt does not read sparse accessors"));
    }
    let Some(view) = a.view() else {
        return Err(format!("{what} has no bufferView"));
    };
    let size = a.size();
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "{what}: bufferViews[{}] has byteStride {stride}, less than the {size}-byte element",
            view.index()
        ));
    }
    let count = a.count();
    let needed = match count {
        0 => Some(0),
        n => (n - 1).checked_mul(stride).and_then(|x| x.checked_add(size)),
    };
    let end = needed.and_then(|n| n.checked_add(a.offset()));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "{what}: {count} elements of {size} bytes (stride {stride}) from byteOffset {} do not fit in \
             bufferViews[{}] ({} bytes)",
            a.offset(),
            view.index(),
            view.length()
        ));
    }
    let buffer = view.buffer();
    let data = &buffers[buffer.index()];
    let start = view.offset();
    let view_end = start.checked_add(view.length()).filter(|&e| e <= data.len()).ok_or_else(|| {
        format!(
            "bufferViews[{}] (byteOffset {start}, byteLength {}) runs past the end of buffers[{}] ({} bytes)",
            view.index(),
            view.length(),
            buffer.index(),
            data.len()
        )
    })?;
    Ok(Elements { data: &data[start + a.offset()..view_end], stride, size, count })
}

/// Checks an accessor's element type against what its use allows.
fn expect(a: &Accessor, use_: &str, dims: Dimensions, types: &[DataType], normalized: bool) -> Res<()> {
    let ok = a.dimensions() == dims && types.contains(&a.data_type());
    let int_ok = a.data_type() == DataType::F32 || a.normalized() == normalized;
    if ok && int_ok {
        return Ok(());
    }
    let names: Vec<&str> = types.iter().map(|&t| component_name(t)).collect();
    Err(format!(
        "{} ({use_}) is {} of {}{}; expected {} of {}",
        accessor_name(a),
        type_name(a.dimensions()),
        component_name(a.data_type()),
        if a.normalized() { " (normalized)" } else { "" },
        type_name(dims),
        names.join(" or ")
    ))
}

/// glTF's names for accessor types and component types, as the file spells them.
fn type_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

fn component_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

fn f32_at(bytes: &[u8], k: usize) -> f32 {
    f32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap())
}

/// VEC3 of FLOAT, every number finite.
fn read_vec3(a: &Accessor, use_: &str, buffers: &[Cow<[u8]>]) -> Res<Vec<DVec3>> {
    expect(a, use_, Dimensions::Vec3, &[DataType::F32], false)?;
    let e = elements(a, buffers)?;
    let mut out = Vec::with_capacity(e.count);
    for i in 0..e.count {
        let b = e.get(i);
        let v = DVec3::new(f32_at(b, 0) as f64, f32_at(b, 1) as f64, f32_at(b, 2) as f64);
        if !v.is_finite() {
            return Err(format!(
                "{} ({use_}) element {i} is ({}, {}, {}); numbers must be finite",
                accessor_name(a),
                v.x,
                v.y,
                v.z
            ));
        }
        out.push(v);
    }
    Ok(out)
}

/// Texture coordinates: VEC2 of FLOAT, or normalized UNSIGNED_BYTE / UNSIGNED_SHORT.
fn read_uv(a: &Accessor, use_: &str, buffers: &[Cow<[u8]>]) -> Res<Vec<[f64; 2]>> {
    expect(a, use_, Dimensions::Vec2, &[DataType::F32, DataType::U8, DataType::U16], true)?;
    let e = elements(a, buffers)?;
    let mut out = Vec::with_capacity(e.count);
    for i in 0..e.count {
        let b = e.get(i);
        let uv = match a.data_type() {
            DataType::U8 => [b[0] as f64 / 255.0, b[1] as f64 / 255.0],
            DataType::U16 => [0, 2].map(|k| u16::from_le_bytes([b[k], b[k + 1]]) as f64 / 65535.0),
            _ => [f32_at(b, 0) as f64, f32_at(b, 1) as f64],
        };
        if !uv.iter().all(|x| x.is_finite()) {
            return Err(format!("{} ({use_}) element {i} is not finite", accessor_name(a)));
        }
        out.push(uv);
    }
    Ok(out)
}

/// Vertex indices (SCALAR of UNSIGNED_BYTE/SHORT/INT), each below `vertex_count`.
fn read_indices(a: &Accessor, vertex_count: usize, buffers: &[Cow<[u8]>]) -> Res<Vec<u32>> {
    expect(a, "indices", Dimensions::Scalar, &[DataType::U8, DataType::U16, DataType::U32], false)?;
    let e = elements(a, buffers)?;
    let mut out = Vec::with_capacity(e.count);
    for i in 0..e.count {
        let b = e.get(i);
        let k = match a.data_type() {
            DataType::U8 => b[0] as u32,
            DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
            _ => u32::from_le_bytes(b[..4].try_into().unwrap()),
        };
        if k as usize >= vertex_count {
            return Err(format!(
                "{} (indices) element {i} is vertex {k}, but POSITION has {vertex_count} vertices",
                accessor_name(a)
            ));
        }
        out.push(k);
    }
    Ok(out)
}

/// Triangles from the index list of a primitive in `mode` (TRIANGLES, _STRIP or _FAN), wound
/// counter-clockwise as glTF's front faces are.
fn triangulate(corners: &[u32], mode: Mode) -> Vec<[u32; 3]> {
    let n = corners.len();
    match mode {
        Mode::TriangleStrip => (0..n.saturating_sub(2))
            .map(|i| {
                // Every other triangle of a strip runs the other way round (glTF 3.7.2.1).
                if i % 2 == 0 {
                    [corners[i], corners[i + 1], corners[i + 2]]
                } else {
                    [corners[i + 1], corners[i], corners[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => {
            (0..n.saturating_sub(2)).map(|i| [corners[i + 1], corners[i + 2], corners[0]]).collect()
        }
        _ => corners.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    }
}

// ---- Nodes ---------------------------------------------------------------------------------

/// A node's transform in f64; non-finite numbers and zero quaternions are errors here, where the
/// node can still be named.
fn local_transform(node: &::gltf::Node) -> Res<DMat4> {
    let what = format!("nodes[{}]", node.index());
    let finite = |key: &str, v: &[f32]| match v.iter().find(|x| !x.is_finite()) {
        Some(x) => Err(format!("{what}.{key} contains {x}; numbers must be finite")),
        None => Ok(()),
    };
    Ok(match node.transform() {
        Transform::Matrix { matrix } => {
            finite("matrix", matrix.as_flattened())?;
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
        }
        Transform::Decomposed { translation, rotation, scale } => {
            finite("translation", &translation)?;
            finite("rotation", &rotation)?;
            finite("scale", &scale)?;
            let q = DQuat::from_array(rotation.map(f64::from));
            if q.length() == 0.0 {
                return Err(format!("{what}.rotation is the zero quaternion"));
            }
            let (s, t) =
                (DVec3::from_array(scale.map(f64::from)), DVec3::from_array(translation.map(f64::from)));
            DMat4::from_scale_rotation_translation(s, q.normalize(), t)
        }
    })
}

/// The nodes of the scene to show, depth first, each with its world transform (at rest) and the
/// position of its parent in the list (parents come before their children).
fn walk(doc: &Document) -> Res<Walk<'_>> {
    let roots: Vec<::gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        // No scene: every node that is nobody's child.
        None => {
            let children: HashSet<usize> =
                doc.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
            doc.nodes().filter(|n| !children.contains(&n.index())).collect()
        }
    };
    let mut seen = vec![false; doc.nodes().len()];
    let mut stack: Vec<(::gltf::Node, DMat4, Option<usize>)> =
        roots.into_iter().rev().map(|n| (n, DMat4::IDENTITY, None)).collect();
    let mut out = Walk { nodes: Vec::new(), parents: Vec::new() };
    // An explicit stack: a hierarchy may be deeper than the thread's stack.
    while let Some((node, parent, parent_at)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(format!(
                "nodes[{}] is reached twice: the node hierarchy must be a tree (a node with two parents, or a cycle)",
                node.index()
            ));
        }
        let world = parent * local_transform(&node)?;
        let at = Some(out.nodes.len());
        let children: Vec<::gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world, at)));
        out.nodes.push((node, world));
        out.parents.push(parent_at);
    }
    Ok(out)
}

/// What [`walk`] finds.
struct Walk<'d> {
    nodes: Vec<(::gltf::Node<'d>, DMat4)>,
    /// Position in `nodes` of each node's parent (None for a root).
    parents: Vec<Option<usize>>,
}

// ---- Animations ----------------------------------------------------------------------------

/// The keyed properties of one node, from every animation that targets it, each with the
/// (animation, channel) it came from.
#[derive(Default)]
struct Keyed {
    translation: Option<(Channel<DVec3>, (usize, usize))>,
    rotation: Option<(Channel<DQuat>, (usize, usize))>,
    scale: Option<(Channel<DVec3>, (usize, usize))>,
}

impl Keyed {
    fn keys(&self) -> usize {
        let n = |c: Option<usize>| c.unwrap_or(0);
        n(self.translation.as_ref().map(|(c, _)| c.times.len() + c.values.len()))
            + n(self.rotation.as_ref().map(|(c, _)| c.times.len() + c.values.len()))
            + n(self.scale.as_ref().map(|(c, _)| c.times.len() + c.values.len()))
    }
}

/// Component `k` of an element as a number: floats as they are, normalized integers mapped to
/// [0, 1] or [-1, 1] (glTF 3.11).
fn component(b: &[u8], t: DataType, k: usize) -> f64 {
    let two = |k: usize| [b[2 * k], b[2 * k + 1]];
    match t {
        DataType::F32 => f32_at(b, k) as f64,
        DataType::I8 => (b[k] as i8 as f64 / 127.0).max(-1.0),
        DataType::U8 => b[k] as f64 / 255.0,
        DataType::I16 => (i16::from_le_bytes(two(k)) as f64 / 32767.0).max(-1.0),
        DataType::U16 => u16::from_le_bytes(two(k)) as f64 / 65535.0,
        DataType::U32 => u32::from_le_bytes(b[4 * k..4 * k + 4].try_into().unwrap()) as f64,
    }
}

/// `N` numbers per element, as [`component`] reads them; finiteness is the channel's check.
fn read_numbers<const N: usize>(a: &Accessor, buffers: &[Cow<[u8]>]) -> Res<Vec<[f64; N]>> {
    let e = elements(a, buffers)?;
    Ok((0..e.count).map(|i| std::array::from_fn(|k| component(e.get(i), a.data_type(), k))).collect())
}

/// The interpolation of a sampler (the crate's validation refuses unknown names).
fn interpolation(s: &json::animation::Sampler, at: &str) -> Res<Interpolation> {
    use json::animation::Interpolation as I;
    match s.interpolation {
        json::validation::Checked::Valid(I::Step) => Ok(Interpolation::Step),
        json::validation::Checked::Valid(I::Linear) => Ok(Interpolation::Linear),
        json::validation::Checked::Valid(I::CubicSpline) => Ok(Interpolation::CubicSpline),
        json::validation::Checked::Invalid => {
            Err(format!("{at}.interpolation is not one of STEP, LINEAR, CUBICSPLINE"))
        }
    }
}

/// Puts `channel` (from animations[a].channels[c], `at`) in its node's `slot`. Two channels of
/// one animation may not target the same property (glTF 3.11); across animations, which all
/// play together, the first animation's channel is kept and the later one ignored: a warning.
fn keep<T>(
    slot: &mut Option<(Channel<T>, (usize, usize))>,
    channel: Channel<T>,
    (a, c): (usize, usize),
    at: &str,
) -> Res<Option<String>> {
    match slot {
        None => {
            *slot = Some((channel, (a, c)));
            Ok(None)
        }
        Some((_, (first_a, first_c))) if *first_a == a => Err(format!(
            "{at} targets the same node property as animations[{a}].channels[{first_c}]; \
             the channels of one animation must have different targets"
        )),
        Some((_, (first_a, first_c))) => Ok(Some(format!(
            "{at} targets the same node property as animations[{first_a}].channels[{first_c}]; \
             all animations play together, so the first one's channel is kept and this one ignored"
        ))),
    }
}

impl Builder<'_> {
    /// Every channel of every animation, by the node it animates (docs/gltf.md, "Animations").
    /// Read from the raw JSON: the crate's validation does not check a channel's target, and its
    /// accessors unwrap it.
    fn animations(&mut self) -> Res<HashMap<usize, Keyed>> {
        use json::animation::Property;
        let doc = self.doc;
        let root = doc.as_json();
        let mut keyed: HashMap<usize, Keyed> = HashMap::new();
        let mut keys = 0usize;
        for (a, animation) in root.animations.iter().enumerate() {
            for (c, channel) in animation.channels.iter().enumerate() {
                let at = format!("animations[{a}].channels[{c}]");
                let node = channel.target.node.value();
                if node >= root.nodes.len() {
                    return Err(format!(
                        "{at}.target.node refers to nodes[{node}], but the file has {} nodes",
                        root.nodes.len()
                    ));
                }
                let property = match channel.target.path {
                    json::validation::Checked::Valid(p) => p,
                    json::validation::Checked::Invalid => {
                        return Err(format!(
                            "{at}.target.path is not one of translation, rotation, scale, weights"
                        ))
                    }
                };
                let name = match property {
                    Property::Translation => "translation",
                    Property::Rotation => "rotation",
                    Property::Scale => "scale",
                    Property::MorphTargetWeights => {
                        self.warn(format!("{at} animates morph target weights, which irt ignores"));
                        continue;
                    }
                };
                if root.nodes[node].matrix.is_some() {
                    return Err(format!(
                        "{at} animates nodes[{node}], which has a matrix: glTF animates only nodes \
                         given by translation, rotation and scale"
                    ));
                }
                let s = channel.sampler.value();
                let sat = format!("animations[{a}].samplers[{s}]");
                let sampler =
                    animation.samplers.get(s).ok_or_else(|| format!("{at}.sampler does not exist"))?;
                let interpolation = interpolation(sampler, &sat)?;
                let accessor = |index: usize, use_: &str| {
                    doc.accessors().nth(index).ok_or_else(|| format!("{sat}.{use_} does not exist"))
                };
                let (input, output) =
                    (accessor(sampler.input.value(), "input")?, accessor(sampler.output.value(), "output")?);
                keys = keys.saturating_add(input.count()).saturating_add(output.count());
                if keys > MAX_ANIMATION_KEYS {
                    return Err(format!(
                        "{at}: the animations hold more than {MAX_ANIMATION_KEYS} keys in all; irt's limit is that"
                    ));
                }
                let in_use = format!("input of {sat}");
                expect(&input, &in_use, Dimensions::Scalar, &[DataType::F32], false)?;
                let times: Vec<f64> =
                    read_numbers::<1>(&input, self.buffers)?.into_iter().map(|[t]| t).collect();
                let what = format!("{at} (nodes[{node}].{name}, {sat})");
                let out_use = format!("output of {sat}");
                let from = (a, c);
                match property {
                    Property::Rotation => {
                        let types = [DataType::F32, DataType::I8, DataType::U8, DataType::I16, DataType::U16];
                        expect(&output, &out_use, Dimensions::Vec4, &types, true)?;
                        let values: Vec<DQuat> = read_numbers::<4>(&output, self.buffers)?
                            .into_iter()
                            .map(DQuat::from_array)
                            .collect();
                        let channel = Channel { interpolation, times, values };
                        channel.validate(&what).map_err(|e| e.0)?;
                        // A tangent may be zero; a key's value may not.
                        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                        let mut zero = channel.values.iter().skip(per_key / 2).step_by(per_key);
                        if let Some(k) = zero.position(|q| q.length_squared() == 0.0) {
                            return Err(format!(
                                "{what}: key {k} is the zero quaternion, which is no rotation"
                            ));
                        }
                        if let Some(w) =
                            keep(&mut keyed.entry(node).or_default().rotation, channel, from, &at)?
                        {
                            self.warn(w);
                        }
                    }
                    _ => {
                        expect(&output, &out_use, Dimensions::Vec3, &[DataType::F32], false)?;
                        let values: Vec<DVec3> = read_numbers::<3>(&output, self.buffers)?
                            .into_iter()
                            .map(DVec3::from_array)
                            .collect();
                        let channel = Channel { interpolation, times, values };
                        channel.validate(&what).map_err(|e| e.0)?;
                        let entry = keyed.entry(node).or_default();
                        let slot = if property == Property::Scale {
                            let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                            let mut flat = channel.values.iter().skip(per_key / 2).step_by(per_key);
                            if let Some(k) = flat.position(|v| v.abs().min_element() == 0.0) {
                                return Err(format!(
                                    "{what}: key {k} scales an axis by 0; irt needs transforms that stay invertible"
                                ));
                            }
                            &mut entry.scale
                        } else {
                            &mut entry.translation
                        };
                        if let Some(w) = keep(slot, channel, from, &at)? {
                            self.warn(w);
                        }
                    }
                }
            }
        }
        Ok(keyed)
    }
}
// ---- Materials -----------------------------------------------------------------------------

/// The Blinn–Phong exponent of a GGX roughness: α = roughness², N = 2/α² − 2 (Walter et al.
/// 2007, the exponent whose lobe matches GGX's near its peak), clamped between [`MIN_EXPONENT`]
/// and [`MAX_EXPONENT`].
pub fn blinn_exponent(roughness: f64) -> f64 {
    let alpha = roughness * roughness;
    (2.0 / (alpha * alpha) - 2.0).clamp(MIN_EXPONENT, MAX_EXPONENT)
}

/// A factor in [0, 1] (metallic, roughness, transmission, clearcoat).
fn unit(x: f64, what: &str) -> Res<f64> {
    if x.is_finite() && (0.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err(format!("{what} is {x}; it must be in [0, 1]"))
    }
}

/// KHR_texture_transform on a texture reference: texture coordinates become
/// `offset + R(rotation) · (scale ⊙ uv)`, R turning counter-clockwise in uv space (the
/// extension's matrix `translation * rotation * scale`). Applied to the coordinates as they are
/// read, so the scene keeps plain per-vertex coordinates.
struct TextureTransform {
    offset: DVec2,
    rotation: f64,
    scale: DVec2,
    /// Overrides the texture reference's `texCoord`.
    tex_coord: Option<u32>,
}

impl TextureTransform {
    /// The reference's transform; None without the extension (coordinates stay bit for bit).
    fn of(info: &::gltf::texture::Info, at: &str) -> Res<Option<TextureTransform>> {
        let Some(ext) = info.extension_value("KHR_texture_transform") else { return Ok(None) };
        let ext = Some(ext);
        let at = format!("{at}.extensions.KHR_texture_transform");
        let pair = |key: &str, default: DVec2| -> Res<DVec2> {
            match ext.and_then(|e| e.get(key)) {
                None => Ok(default),
                Some(v) => {
                    match v.as_array().map(|a| a.iter().map(json::Value::as_f64).collect::<Vec<_>>()) {
                        Some(n) if n.len() == 2 && n.iter().all(|x| x.is_some_and(f64::is_finite)) => {
                            Ok(DVec2::new(n[0].unwrap(), n[1].unwrap()))
                        }
                        _ => Err(format!("{at}.{key} must be two finite numbers, not {v}")),
                    }
                }
            }
        };
        let rotation = extension_number(ext, "rotation", 0.0, &at)?;
        if !rotation.is_finite() {
            return Err(format!("{at}.rotation is {rotation}; it must be finite"));
        }
        let tex_coord =
            match ext.and_then(|e| e.get("texCoord")) {
                None => None,
                Some(v) => Some(v.as_u64().and_then(|n| u32::try_from(n).ok()).ok_or_else(|| {
                    format!("{at}.texCoord must be a texture coordinate set number, not {v}")
                })?),
            };
        Ok(Some(TextureTransform {
            offset: pair("offset", DVec2::ZERO)?,
            rotation,
            scale: pair("scale", DVec2::ONE)?,
            tex_coord,
        }))
    }

    fn apply(&self, uv: DVec2) -> DVec2 {
        let s = self.scale * uv;
        let (sin, cos) = self.rotation.sin_cos();
        self.offset + DVec2::new(cos * s.x - sin * s.y, sin * s.x + cos * s.y)
    }
}

/// A number in an extension object that the crate does not type (KHR_materials_clearcoat).
fn extension_number(ext: Option<&json::Value>, key: &str, default: f64, what: &str) -> Res<f64> {
    match ext.and_then(|e| e.get(key)) {
        None => Ok(default),
        Some(v) => v.as_f64().ok_or_else(|| format!("{what}.{key} must be a number, not {v}")),
    }
}

/// The paper's material for a glTF material (docs/gltf.md has the table).
fn material_kind(m: &::gltf::Material) -> Res<MaterialKind> {
    let at = m.index().map_or("the default material".into(), |i| format!("materials[{i}]"));
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _alpha] = pbr.base_color_factor().map(f64::from);
    let color = DVec3::new(r, g, b);
    if !(color.is_finite() && color.min_element() >= 0.0 && color.max_element() <= 1.0) {
        return Err(format!(
            "{at}.pbrMetallicRoughness.baseColorFactor ({r}, {g}, {b}) must be in [0, 1] per channel"
        ));
    }
    let metallic = unit(pbr.metallic_factor() as f64, &format!("{at}.pbrMetallicRoughness.metallicFactor"))?;
    let roughness =
        unit(pbr.roughness_factor() as f64, &format!("{at}.pbrMetallicRoughness.roughnessFactor"))?;
    let transmission = match m.transmission() {
        Some(t) => unit(
            t.transmission_factor() as f64,
            &format!("{at}.KHR_materials_transmission.transmissionFactor"),
        )?,
        None => 0.0,
    };
    let eta = m.ior().map_or(1.5, f64::from);
    if !(eta.is_finite() && eta >= 1.0) {
        return Err(format!("{at}.KHR_materials_ior.ior is {eta}; irt needs a finite index of at least 1"));
    }
    let coat_at = format!("{at}.KHR_materials_clearcoat");
    let coat = m.extension_value("KHR_materials_clearcoat");
    let coat_factor = unit(
        extension_number(coat, "clearcoatFactor", 0.0, &coat_at)?,
        &format!("{coat_at}.clearcoatFactor"),
    )?;
    let coat_roughness = unit(
        extension_number(coat, "clearcoatRoughness", 0.0, &coat_at)?,
        &format!("{coat_at}.clearcoatRoughness"),
    )?;
    // The strongest lobe decides: each factor blends two models in glTF, irt picks one.
    Ok(if transmission >= 0.5 {
        MaterialKind::Dielectric { eta, exponent: blinn_exponent(roughness) }
    } else if metallic >= 0.5 && roughness <= METAL_MAX_ROUGHNESS {
        MaterialKind::Metal { color, exponent: blinn_exponent(roughness) }
    } else if coat_factor >= 0.5 {
        MaterialKind::Polished { color, eta, exponent: blinn_exponent(coat_roughness) }
    } else {
        MaterialKind::Diffuse { color }
    })
}

// ---- Building the scene --------------------------------------------------------------------

/// One primitive of one mesh instance, sized before anything is read.
struct Draw<'a> {
    primitive: ::gltf::Primitive<'a>,
    world: DMat4,
    at: String,
    /// Position of its node in the walk.
    node: usize,
}

struct Builder<'a> {
    doc: &'a Document,
    buffers: &'a [Cow<'a, [u8]>],
    base: Option<&'a Path>,
    origin: &'a str,
    materials: Vec<Material>,
    /// glTF material index (None: the default material) → scene material.
    slots: HashMap<Option<usize>, u32>,
    names: HashSet<String>,
    textures: Vec<Texture>,
    /// Declared pixels of the images decoded so far.
    texture_pixels: png::PixelBudget,
    /// (image, wrap, filter) → scene texture, or None for an image irt cannot decode.
    texture_slots: HashMap<(usize, [Wrap; 2], Filter), Option<u32>>,
    warned: HashSet<String>,
}

impl<'a> Builder<'a> {
    fn new(doc: &'a Document, buffers: &'a [Cow<'a, [u8]>], base: Option<&'a Path>, origin: &'a str) -> Self {
        Builder {
            doc,
            buffers,
            base,
            origin,
            materials: Vec::new(),
            slots: HashMap::new(),
            names: HashSet::new(),
            textures: Vec::new(),
            texture_pixels: png::PixelBudget::default(),
            texture_slots: HashMap::new(),
            warned: HashSet::new(),
        }
    }

    fn warn(&mut self, message: String) {
        if self.warned.insert(message.clone()) {
            log::warn!("{}: {message}", self.origin);
        }
    }

    fn build(mut self) -> Res<Scene> {
        let walk = walk(self.doc)?;
        let keyed = self.animations()?;
        // Whether each node, or one above it, is animated: its meshes move.
        let mut moving = vec![false; walk.nodes.len()];
        for k in 0..walk.nodes.len() {
            moving[k] =
                keyed.contains_key(&walk.nodes[k].0.index()) || walk.parents[k].is_some_and(|p| moving[p]);
        }
        let mut draws = self.plan(&walk.nodes)?;
        let mut meshes = Vec::with_capacity(draws.len());
        let mut motions = Vec::new();
        let mut copied = 0usize;
        for d in &mut draws {
            // A moving mesh stays in its own coordinates; its motion carries the node path.
            if moving[d.node] {
                d.world = DMat4::IDENTITY;
            }
            if let Some(mesh) = self.mesh(d)? {
                if moving[d.node] {
                    let motion = self.motion(&walk, d.node, &keyed, &mut copied)?;
                    motions.push(Animated { target: Target::Mesh(meshes.len() as u32), motion });
                }
                meshes.push(mesh);
            }
        }
        if meshes.is_empty() {
            return Err("the scene has no triangles to render".into());
        }
        // An animated scene is framed (and its directional lights placed) on the poses it
        // takes over its animation, so that nothing moves out of view.
        let posed = (!motions.is_empty()).then(|| {
            let still =
                Scene { meshes: meshes.clone(), motions: motions.clone(), ..stage::stage(Model::default()) };
            stage::swept_meshes(&still)
        });
        let framing = posed.as_deref().unwrap_or(&meshes);
        let (center, radius) = stage::bounds(framing);
        let mut camera = self.camera(&walk.nodes)?;
        let mut lights = self.lights(&walk.nodes, center, radius)?;
        if posed.is_some() {
            let c = camera.unwrap_or_else(|| stage::framing_camera(framing));
            if lights.is_empty() {
                lights.push(stage::headlight(&c, center, radius));
            }
            camera = Some(c);
        }
        let model = Model {
            meshes,
            materials: self.materials,
            textures: self.textures,
            motions,
            ..Default::default()
        };
        Ok(stage::stage_with(model, camera, lights))
    }

    /// The motion of a mesh on the node at walk position `at`: the path from its root down,
    /// each animated node a keyed stage, each run of other nodes one fixed stage. `copied`
    /// counts the keys and nodes copied into motions so far, against [`MAX_ANIMATION_KEYS`].
    fn motion(
        &self,
        walk: &Walk,
        at: usize,
        keyed: &HashMap<usize, Keyed>,
        copied: &mut usize,
    ) -> Res<Motion> {
        let mut path = vec![at];
        while let Some(p) = walk.parents[*path.last().expect("not empty")] {
            path.push(p);
        }
        *copied = copied.saturating_add(path.len());
        let mut stages = Vec::new();
        let mut fixed = DMat4::IDENTITY;
        for &k in path.iter().rev() {
            let node = &walk.nodes[k].0;
            let Some(channels) = keyed.get(&node.index()) else {
                fixed *= local_transform(node)?;
                continue;
            };
            if fixed != DMat4::IDENTITY {
                stages.push(Stage::Fixed(DAffine3::from_mat4(fixed)));
                fixed = DMat4::IDENTITY;
            }
            *copied = copied.saturating_add(channels.keys());
            let Transform::Decomposed { translation, rotation, scale } = node.transform() else {
                return Err(format!("nodes[{}] is animated but has a matrix", node.index()));
            };
            let v = |a: [f32; 3]| DVec3::from_array(a.map(f64::from));
            let rest = Trs {
                translation: v(translation),
                // Checked not zero by local_transform on the walk.
                rotation: DQuat::from_array(rotation.map(f64::from)).normalize(),
                scale: v(scale),
            };
            if rest.scale.abs().min_element() == 0.0 && channels.scale.is_none() {
                return Err(format!(
                    "nodes[{}] is animated with a scale of 0 on an axis; irt needs transforms that stay invertible",
                    node.index()
                ));
            }
            stages.push(Stage::keyed(
                channels.translation.as_ref().map(|(c, _)| c.clone()),
                channels.rotation.as_ref().map(|(c, _)| Rotation::Quaternion(c.clone())),
                channels.scale.as_ref().map(|(c, _)| c.clone()),
                rest,
            ));
        }
        if fixed != DMat4::IDENTITY {
            stages.push(Stage::Fixed(DAffine3::from_mat4(fixed)));
        }
        if *copied > MAX_ANIMATION_KEYS {
            return Err(format!(
                "the animated meshes' motions hold more than {MAX_ANIMATION_KEYS} keys and nodes in all \
                 (every mesh under an animated node carries its channels); irt's limit is that"
            ));
        }
        Ok(Motion { stages })
    }

    /// The primitives to draw, with their vertex and triangle counts checked against the
    /// limits from the accessors' declared counts, before any data is read.
    fn plan<'d>(&mut self, nodes: &[(::gltf::Node<'d>, DMat4)]) -> Res<Vec<Draw<'d>>> {
        let (mut vertices, mut triangles) = (0usize, 0usize);
        let mut draws = Vec::new();
        for (k, (node, world)) in nodes.iter().enumerate() {
            let Some(mesh) = node.mesh() else { continue };
            if node.skin().is_some() || mesh.weights().is_some() {
                self.warn(format!(
                    "nodes[{}]: skins and morph targets are ignored (rest pose)",
                    node.index()
                ));
            }
            for primitive in mesh.primitives() {
                let at = format!("meshes[{}].primitives[{}]", mesh.index(), primitive.index());
                let mode = primitive.mode();
                if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
                    self.warn(format!("{at}: mode {} has no surface to ray trace; skipped", mode_name(mode)));
                    continue;
                }
                let Some(positions) = primitive.get(&Semantic::Positions) else {
                    self.warn(format!("{at} has no POSITION attribute; skipped"));
                    continue;
                };
                let n = positions.count();
                if n > MAX_VERTICES {
                    return Err(format!(
                        "{} (POSITION of {at}) declares {n} vertices; irt's limit is {MAX_VERTICES}",
                        accessor_name(&positions)
                    ));
                }
                let corners = primitive.indices().map_or(n, |i| i.count());
                if corners > 3 * MAX_TRIANGLES {
                    return Err(format!(
                        "{at} declares {corners} indices; irt's limit is {MAX_TRIANGLES} triangles"
                    ));
                }
                let count = match mode {
                    Mode::Triangles if corners % 3 != 0 => {
                        return Err(format!(
                            "{at}: {corners} vertices do not make whole triangles (mode TRIANGLES needs a multiple of 3)"
                        ))
                    }
                    Mode::Triangles => corners / 3,
                    _ => corners.saturating_sub(2),
                };
                vertices += n;
                triangles += count;
                if vertices > MAX_VERTICES || triangles > MAX_TRIANGLES {
                    return Err(format!(
                        "the scene has more than {MAX_TRIANGLES} triangles or {MAX_VERTICES} vertices \
                         (counting every instance of every mesh); irt's limit is that"
                    ));
                }
                draws.push(Draw { primitive, world: *world, at, node: k });
            }
        }
        Ok(draws)
    }

    /// One primitive instance in world space, or None when it has no triangles.
    fn mesh(&mut self, d: &Draw) -> Res<Option<Mesh>> {
        let p = &d.primitive;
        let pos_accessor = p.get(&Semantic::Positions).expect("planned");
        let local = read_vec3(&pos_accessor, &format!("POSITION of {}", d.at), self.buffers)?;
        let corners = match p.indices() {
            Some(a) => read_indices(&a, local.len(), self.buffers)?,
            None => (0..local.len() as u32).collect(),
        };
        let mut indices = triangulate(&corners, p.mode());
        if indices.is_empty() {
            return Ok(None);
        }
        let linear = DMat3::from_mat4(d.world);
        // Normals go through the inverse transpose; the cofactor matrix is that times the
        // determinant, so it exists for every matrix and only its sign needs fixing.
        let det = linear.determinant();
        let cofactor = DMat3::from_cols(
            linear.y_axis.cross(linear.z_axis),
            linear.z_axis.cross(linear.x_axis),
            linear.x_axis.cross(linear.y_axis),
        );
        let normal_matrix = if det < 0.0 { -cofactor } else { cofactor };
        let positions: Vec<DVec3> = local.iter().map(|&v| d.world.transform_point3(v)).collect();
        let normals = match p.get(&Semantic::Normals) {
            None => None,
            Some(a) => {
                let n = read_vec3(&a, &format!("NORMAL of {}", d.at), self.buffers)?;
                if n.len() != positions.len() {
                    return Err(format!(
                        "{} (NORMAL of {}) has {} elements but POSITION has {}",
                        accessor_name(&a),
                        d.at,
                        n.len(),
                        positions.len()
                    ));
                }
                let world: Option<Vec<DVec3>> =
                    n.iter().map(|&v| (normal_matrix * v).try_normalize()).collect();
                if world.is_none() {
                    self.warn(format!("{}: a normal is zero (after the node transform); flat shading", d.at));
                }
                world
            }
        };
        // A mirroring transform turns the winding, and with it the outside, inside out (glTF
        // 3.7.4); swapping two corners turns it back.
        if det < 0.0 {
            indices.iter_mut().for_each(|t| t.swap(1, 2));
        }
        let material = self.material(&p.material())?;
        let uvs = self.uvs(p, material, positions.len(), d)?;
        Ok(Some(Mesh { positions, normals, uvs, indices, material }))
    }

    /// The scene material for a glTF material, made on first use.
    fn material(&mut self, m: &::gltf::Material) -> Res<u32> {
        if let Some(&slot) = self.slots.get(&m.index()) {
            return Ok(slot);
        }
        if self.materials.len() >= MAX_MATERIALS {
            return Err(format!("more than {MAX_MATERIALS} materials; irt's limit is that"));
        }
        let kind = material_kind(m)?;
        // A dielectric has no colour for a texture to modulate.
        let texture = match (&kind, m.pbr_metallic_roughness().base_color_texture()) {
            (MaterialKind::Dielectric { .. }, _) | (_, None) => None,
            (_, Some(info)) => self.texture(&info.texture())?,
        };
        let base = match (m.name(), m.index()) {
            (Some(name), _) if !name.is_empty() => name.to_string(),
            (_, Some(i)) => format!("material{i}"),
            (_, None) => "default".to_string(),
        };
        let name = unique_name(base, |n| self.names.contains(n));
        self.names.insert(name.clone());
        let slot = self.materials.len() as u32;
        self.materials.push(Material { name, kind, texture });
        self.slots.insert(m.index(), slot);
        Ok(slot)
    }

    /// The texture coordinates a textured material reads on this primitive (its `texCoord`
    /// set); None for untextured materials, or (with a warning) when the set is missing.
    fn uvs(
        &mut self,
        p: &::gltf::Primitive,
        material: u32,
        vertices: usize,
        d: &Draw,
    ) -> Res<Option<Vec<DVec2>>> {
        if self.materials[material as usize].texture.is_none() {
            return Ok(None);
        }
        let info = p.material().pbr_metallic_roughness().base_color_texture().expect("textured");
        let at = match p.material().index() {
            Some(i) => format!("materials[{i}].pbrMetallicRoughness.baseColorTexture"),
            None => "the default material".into(),
        };
        let transform = TextureTransform::of(&info, &at)?;
        let set = transform.as_ref().and_then(|t| t.tex_coord).unwrap_or(info.tex_coord());
        let Some(a) = p.get(&Semantic::TexCoords(set)) else {
            self.warn(format!(
                "{}: its material is textured but it has no TEXCOORD_{set}; read at (0, 0)",
                d.at
            ));
            return Ok(None);
        };
        let what = format!("TEXCOORD_{set} of {}", d.at);
        let uv = read_uv(&a, &what, self.buffers)?;
        if uv.len() != vertices {
            return Err(format!(
                "{} ({what}) has {} elements but POSITION has {vertices}",
                accessor_name(&a),
                uv.len()
            ));
        }
        let uv = uv.into_iter().map(DVec2::from);
        Ok(Some(match transform {
            Some(t) => uv.map(|uv| t.apply(uv)).collect(),
            None => uv.collect(),
        }))
    }

    /// The scene texture for a glTF texture (its image under its sampler's wrap and filter),
    /// decoded once; None (with a warning) for images irt cannot decode.
    fn texture(&mut self, texture: &::gltf::Texture) -> Res<Option<u32>> {
        let index = texture.source().index();
        let sampler = texture.sampler();
        let wrap = [sampler.wrap_s(), sampler.wrap_t()].map(|w| match w {
            WrappingMode::Repeat => Wrap::Repeat,
            WrappingMode::ClampToEdge => Wrap::Clamp,
            WrappingMode::MirroredRepeat => Wrap::Mirror,
        });
        // Magnification is what a ray tracer without footprints does everywhere; minification
        // filters (mip-maps) have nothing to choose from.
        let filter = match sampler.mag_filter() {
            Some(MagFilter::Nearest) => Filter::Nearest,
            _ => Filter::Linear,
        };
        let key = (index, wrap, filter);
        if let Some(&slot) = self.texture_slots.get(&key) {
            return Ok(slot);
        }
        let what = format!("images[{index}]");
        // The raw JSON: the crate's `source()` unwraps a `mimeType` or `uri` that validation
        // does not guarantee is there.
        let doc = self.doc;
        let json = &doc.as_json().images[index];
        let bytes: Cow<[u8]> = match (&json.buffer_view, &json.uri) {
            (Some(view), _) => {
                let view = doc.views().nth(view.value()).expect("validated index");
                let data = &self.buffers[view.buffer().index()];
                let range = view.offset()..view.offset().saturating_add(view.length());
                Cow::Borrowed(data.get(range).ok_or_else(|| {
                    format!("{what}: bufferViews[{}] runs past the end of its buffer", view.index())
                })?)
            }
            (None, Some(uri)) => Cow::Owned(read_uri(uri, self.base, &what)?),
            (None, None) => return Err(format!("{what} has neither a uri nor a bufferView")),
        };
        // Sizes add up from the headers before anything is decoded.
        let decoded = png::checked_size(&bytes, &what).and_then(|(w, h)| {
            self.texture_pixels.take(w, h).map_err(|m| Unusable::Refused(format!("{what}: {m}")))?;
            png::decode(&bytes, &what)
        });
        let slot = match decoded {
            Ok((width, height, texels)) => {
                if self.textures.len() >= MAX_TEXTURES {
                    return Err(format!("more than {MAX_TEXTURES} textures; irt's limit is that"));
                }
                let base = match json.name.as_deref() {
                    Some(n) if !n.is_empty() => n.to_string(),
                    _ => format!("image{index}"),
                };
                // One image under two samplers is two textures; names stay unique.
                let name = unique_name(base, |n| self.textures.iter().any(|t| t.name == n));
                self.textures.push(Texture { name, width, height, texels, wrap, filter });
                Some(self.textures.len() as u32 - 1)
            }
            Err(Unusable::Refused(m)) => return Err(m),
            Err(Unusable::NotPng(m)) => {
                self.warn(format!("{m}: the material uses its base colour factor alone"));
                None
            }
        };
        self.texture_slots.insert(key, slot);
        Ok(slot)
    }

    /// The first perspective camera in the scene (None: the stage's, which frames the scene).
    fn camera(&mut self, nodes: &[(::gltf::Node, DMat4)]) -> Res<Option<Camera>> {
        for (node, world) in nodes {
            let Some(camera) = node.camera() else { continue };
            let at = format!("cameras[{}]", camera.index());
            // The raw JSON: the crate's `projection()` unwraps the object `type` names, which
            // validation does not guarantee is there.
            let json = &self.doc.as_json().cameras[camera.index()];
            let p = match (&json.type_, &json.perspective) {
                (json::validation::Checked::Valid(json::camera::Type::Perspective), Some(p)) => p,
                (json::validation::Checked::Valid(json::camera::Type::Perspective), None) => {
                    return Err(format!("{at} is of type perspective but has no `perspective` object"));
                }
                _ => {
                    self.warn(format!(
                        "{at} is orthographic; irt frames the scene with a perspective camera instead"
                    ));
                    continue;
                }
            };
            let vfov = p.yfov as f64;
            if !(vfov.is_finite() && vfov > 0.0 && vfov < std::f64::consts::PI) {
                return Err(format!("{at}.perspective.yfov is {vfov}; it must be between 0 and π radians"));
            }
            let (width, height) = match p.aspect_ratio.map(f64::from) {
                None => (DEFAULT_WIDTH, DEFAULT_HEIGHT),
                Some(a) if a.is_finite() && a > 0.0 => {
                    let h =
                        (DEFAULT_WIDTH as f64 / a).round().clamp(1.0, crate::scene::MAX_IMAGE_SIDE as f64);
                    (DEFAULT_WIDTH, h as u32)
                }
                Some(a) => {
                    return Err(format!("{at}.perspective.aspectRatio is {a}; it must be greater than 0"))
                }
            };
            // A glTF camera looks down its local -z with +y up.
            let eye = world.transform_point3(DVec3::ZERO);
            let forward = world.transform_vector3(-DVec3::Z).normalize_or_zero();
            let up = world.transform_vector3(DVec3::Y).normalize_or_zero();
            if !(eye.is_finite() && forward != DVec3::ZERO && forward.cross(up).length() > 1e-9) {
                return Err(format!(
                    "nodes[{}] places {at} with a degenerate transform (no view or up direction)",
                    node.index()
                ));
            }
            return Ok(Some(Camera {
                eye,
                look_at: eye + forward,
                up,
                vfov_deg: vfov.to_degrees(),
                width,
                height,
            }));
        }
        Ok(None)
    }

    /// KHR_lights_punctual lights as irt's point lights (docs/gltf.md).
    fn lights(&mut self, nodes: &[(::gltf::Node, DMat4)], center: DVec3, radius: f64) -> Res<Vec<Light>> {
        // (position, colour × illuminance at the scene's centre)
        let mut found: Vec<(DVec3, DVec3)> = Vec::new();
        for (node, world) in nodes {
            let Some(light) = node.light() else { continue };
            let at = format!("KHR_lights_punctual.lights[{}]", light.index());
            if found.len() == MAX_LIGHTS {
                self.warn(format!(
                    "{at} and any later lights are dropped: irt shades with at most {MAX_LIGHTS}"
                ));
                break;
            }
            let color = DVec3::from_array(light.color().map(f64::from));
            let intensity = light.intensity() as f64;
            if !(color.is_finite() && color.min_element() >= 0.0) {
                return Err(format!(
                    "{at}.color ({}, {}, {}) must be finite and not negative",
                    color.x, color.y, color.z
                ));
            }
            if !(intensity.is_finite() && intensity >= 0.0) {
                return Err(format!("{at}.intensity is {intensity}; it must be finite and not negative"));
            }
            let position = world.transform_point3(DVec3::ZERO);
            let direction = world.transform_vector3(-DVec3::Z).normalize_or_zero();
            let (position, illuminance) = match light.kind() {
                LightKind::Directional => {
                    if direction == DVec3::ZERO {
                        return Err(format!("nodes[{}] gives {at} no direction", node.index()));
                    }
                    // Far enough that its rays are parallel across the scene; irt's lights do
                    // not fall off, so only the direction matters.
                    (center - direction * (1000.0 * radius), intensity)
                }
                kind => {
                    if matches!(kind, LightKind::Spot { .. }) {
                        self.warn(format!(
                            "{at} is a spot light; irt lights every direction (the cone is ignored)"
                        ));
                    }
                    let d2 = (position - center).length_squared().max((0.01 * radius).powi(2));
                    (position, intensity / d2)
                }
            };
            if !position.is_finite() {
                return Err(format!("{at} is placed at a position that is not finite"));
            }
            found.push((position, color * illuminance));
        }
        // Physical units (candela, lux) with an unknown exposure: keep the lights' ratios at the
        // scene's centre and make the strongest one 1.
        let strongest = found.iter().map(|(_, c)| c.max_element()).fold(0.0, f64::max);
        let scale = if strongest > 0.0 { 1.0 / strongest } else { 0.0 };
        Ok(found
            .into_iter()
            .map(|(position, c)| Light { position, color: (c * scale).min(DVec3::ONE), radius: 0.0 })
            .collect())
    }
}

/// Centre and radius of the bounding box of every vertex (radius 1 for a single point).
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_every_padding_and_refuses_junk() {
        assert_eq!(base64_decode("").unwrap(), b"");
        assert_eq!(base64_decode("TQ==").unwrap(), b"M");
        assert_eq!(base64_decode("TWE=").unwrap(), b"Ma");
        assert_eq!(base64_decode("TWFu").unwrap(), b"Man");
        assert_eq!(base64_decode("TWFuTQ").unwrap(), b"ManM");
        assert_eq!(base64_decode("+/+/").unwrap(), [0xfb, 0xff, 0xbf]);
        assert!(base64_decode("TW-u").unwrap_err().to_string().contains("byte 2"));
        assert!(base64_decode("TWFuT").is_err());
    }

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("a%20b.bin").unwrap(), "a b.bin");
        assert!(percent_decode("a%2").is_none());
        assert!(percent_decode("a%zz").is_none());
    }

    #[test]
    fn strips_and_fans_keep_the_winding() {
        // A quad (0,1,2,3 counter-clockwise) as a strip 0,1,3,2 and as a fan 0,1,2,3.
        assert_eq!(triangulate(&[0, 1, 3, 2], Mode::TriangleStrip), vec![[0, 1, 3], [3, 1, 2]]);
        assert_eq!(triangulate(&[0, 1, 2, 3], Mode::TriangleFan), vec![[1, 2, 0], [2, 3, 0]]);
        assert!(triangulate(&[0, 1], Mode::TriangleStrip).is_empty());
        assert_eq!(triangulate(&[0, 1, 2, 3, 4, 5, 6], Mode::Triangles).len(), 2);
    }

    #[test]
    fn normalized_components_map_to_the_unit_range() {
        // glTF 3.11: signed values clamp at -1 (the most negative integer has no positive twin).
        assert_eq!(component(&[0x80], DataType::I8, 0), -1.0);
        assert_eq!(component(&[0x81], DataType::I8, 0), -1.0);
        assert_eq!(component(&[0x7f], DataType::I8, 0), 1.0);
        assert_eq!(component(&[0, 0xff], DataType::U8, 1), 1.0);
        assert_eq!(component(&0x8000u16.to_le_bytes(), DataType::I16, 0), -1.0);
        assert_eq!(component(&32767i16.to_le_bytes(), DataType::I16, 0), 1.0);
        assert_eq!(component(&[0, 0, 0xff, 0xff], DataType::U16, 1), 1.0);
        assert_eq!(component(&0.25f32.to_le_bytes(), DataType::F32, 0), 0.25);
    }

    #[test]
    fn blinn_exponent_is_monotonic_and_clamped() {
        assert_eq!(blinn_exponent(0.0), MAX_EXPONENT);
        assert_eq!(blinn_exponent(1.0), MIN_EXPONENT);
        assert!((blinn_exponent(0.5) - 30.0).abs() < 1e-12);
        let mut last = f64::INFINITY;
        for i in 0..=100 {
            let n = blinn_exponent(i as f64 / 100.0);
            assert!(n <= last);
            last = n;
        }
    }
}
