//! glTF 2.0 scenes: the Khronos samples load with what their files declare and render on the
//! GPU as the CPU reference does; each class of bad input gives an error that names the file,
//! the JSON object and what was expected; mutated files never panic.
use crate::common;

use glam::{DVec2, DVec3};
use image::ImageEncoder;
use irt::io::{gltf::parse, load, LoadError};
use irt::scene::{Filter, MaterialKind, Scene, Wrap};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

fn sample(name: &str) -> PathBuf {
    common::shared_scene("gltf").join(name)
}

fn load_sample(name: &str) -> Scene {
    load(&sample(name)).unwrap_or_else(|e| panic!("{e}"))
}

fn tmp_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gltf");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `doc` as `name` (in the test's temporary directory) and loads it.
fn load_json(name: &str, doc: &Value) -> Result<Scene, LoadError> {
    let path = tmp_dir().join(name);
    std::fs::write(&path, serde_json::to_vec_pretty(doc).unwrap()).unwrap();
    load(&path)
}

/// Asserts that `doc` is refused with a message naming the file and containing every word.
fn refused(name: &str, doc: &Value, words: &[&str]) -> LoadError {
    let e = load_json(name, doc).expect_err("the file should be refused");
    assert!(e.to_string().starts_with(&tmp_dir().join(name).display().to_string()), "{e}");
    for w in words {
        assert!(e.message.contains(w), "message lacks '{w}': {e}");
    }
    e
}

// ---- What the files declare ----------------------------------------------------------------

/// Triangle and material counts as the JSON declares them, read without irt's loader: every
/// node's mesh counted once per instance (these files have no strips or fans).
fn declared(path: &Path) -> (usize, usize) {
    let bytes = std::fs::read(path).unwrap();
    let json: Value = if bytes.starts_with(b"glTF") {
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        serde_json::from_slice(&bytes[20..20 + len]).unwrap()
    } else {
        serde_json::from_slice(&bytes).unwrap()
    };
    let accessors = json["accessors"].as_array().unwrap();
    let triangles = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|n| n["mesh"].as_u64())
        .flat_map(|m| json["meshes"][m as usize]["primitives"].as_array().unwrap().clone())
        .map(|p| accessors[p["indices"].as_u64().unwrap() as usize]["count"].as_u64().unwrap() as usize / 3)
        .sum();
    (triangles, json["materials"].as_array().map_or(0, Vec::len))
}

#[test]
fn every_sample_loads_with_the_declared_counts() {
    for name in ["Box.gltf", "BoxTextured.gltf", "Duck.gltf", "Duck.glb"] {
        let scene = load_sample(name);
        let (triangles, materials) = declared(&sample(name));
        assert_eq!(scene.triangle_count(), triangles, "{name}");
        assert_eq!(scene.materials.len(), materials, "{name}");
        assert!(scene.meshes.iter().all(|m| m.normals.is_some()), "{name}: the samples have normals");
        // No lights in the samples: the default light is added, and the ambient.
        assert_eq!(scene.lights.len(), 1, "{name}");
        assert!(scene.ambient.sky.max_element() > 0.0);
    }
    assert_eq!(load_sample("Box.gltf").triangle_count(), 12);
    assert_eq!(load_sample("Duck.glb").triangle_count(), 4212);
}

#[test]
fn the_duck_is_the_same_scene_as_gltf_and_as_glb() {
    let (a, b) = (load_sample("Duck.gltf"), load_sample("Duck.glb"));
    assert_eq!(format!("{a:?}"), format!("{b:?}"), "bit for bit");
}

#[test]
fn the_duck_uses_its_camera_and_its_texture() {
    let s = load_sample("Duck.glb");
    // cameras[0]: yfov 0.6605925559997559 rad, aspectRatio 1.5 → 640 wide.
    assert!((s.camera.vfov_deg - 0.6605925559997559f64.to_degrees()).abs() < 1e-12);
    assert_eq!((s.camera.width, s.camera.height), (640, 427));
    // The node at (400.113, 463.264, -431.078) under the root's 0.01 scale.
    assert!((s.camera.eye - DVec3::new(4.00113, 4.63264, -4.31078)).length() < 1e-5, "{}", s.camera.eye);
    // metallicFactor 0, no roughness (1): diffuse, white factor times the texture.
    assert_eq!(s.materials[0].kind, MaterialKind::Diffuse { color: DVec3::ONE });
    assert_eq!(s.materials[0].name, "blinn3-fx");
    assert_eq!(s.materials[0].texture, Some(0));
    let t = &s.textures[0];
    assert_eq!((t.width, t.height, t.texels.len()), (512, 512, 512 * 512));
    assert_eq!((t.wrap, t.filter), ([Wrap::Repeat; 2], Filter::Linear), "the default sampler");
    // Its mean colour, read where the surface reads it, is the duck's yellow.
    let uvs = s.meshes[0].uvs.as_ref().expect("TEXCOORD_0");
    assert_eq!(uvs.len(), s.meshes[0].positions.len());
    let mean = uvs.iter().map(|&uv| irt::reference::sample_texture(t, uv)).sum::<DVec3>() / uvs.len() as f64;
    assert!(mean.x > 0.5 && mean.y > 0.3 && mean.z < 0.1, "yellow: {mean}");
}

#[test]
fn the_box_is_framed_and_its_root_rotation_applied() {
    let s = load_sample("Box.gltf");
    // Box.gltf's root turns z-up into y-up; the box is the unit cube either way, centred.
    let (lo, hi) = s.meshes[0]
        .positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    assert_eq!((lo, hi), (DVec3::splat(-0.5), DVec3::splat(0.5)));
    // No camera: the framing camera looks at the centre from the front, right and above.
    assert_eq!(s.camera.look_at, DVec3::ZERO);
    assert!(s.camera.eye.x > 0.0 && s.camera.eye.y > 0.0 && s.camera.eye.z > 0.0);
    // baseColorFactor (0.8, 0, 0) with the default metallic 1 and roughness 1: a rough metal,
    // which irt draws diffuse.
    assert_eq!(s.materials[0].kind, MaterialKind::Diffuse { color: DVec3::new(0.800000011920929, 0.0, 0.0) });
    // The normals went through the same rotation: +z normals of the file now point -y or +y.
    let normals = s.meshes[0].normals.as_ref().unwrap();
    assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-12));
    for (t, p) in s.meshes[0].indices.iter().zip(0..) {
        let [a, b, c] = t.map(|i| s.meshes[0].positions[i as usize]);
        let face = (b - a).cross(c - a);
        assert!(face.dot(normals[t[0] as usize]) > 0.0, "triangle {p} is wound against its normal");
    }
}

// ---- GPU against the CPU reference ---------------------------------------------------------

fn golden(name: &str) {
    let mut scene = load_sample(name);
    scene.camera.width = 96;
    scene.camera.height = 72;
    let ctx = common::gpu();
    let gpu = common::render_gpu(&ctx, &scene);
    common::assert_matches_reference(&format!("gltf-{name}"), &gpu, &common::reference_image(&scene));
}

#[test]
fn golden_box() {
    golden("Box.gltf");
}

#[test]
fn golden_duck() {
    golden("Duck.glb");
}

#[test]
fn golden_box_textured() {
    let s = load_sample("BoxTextured.gltf");
    assert!(s.materials[0].texture.is_some() && s.meshes[0].uvs.is_some(), "sampled, not averaged");
    golden("BoxTextured.gltf");
}

// ---- A small valid file to break -----------------------------------------------------------

fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk.iter().enumerate().fold(0u32, |n, (i, &b)| n | (b as u32) << (16 - 8 * i));
        for k in 0..=chunk.len() {
            out.push(ABC[(n >> (18 - 6 * k) & 63) as usize] as char);
        }
    }
    out
}

fn data_uri(bin: &[u8]) -> String {
    format!("data:application/octet-stream;base64,{}", base64(bin))
}

/// Three positions (VEC3 FLOAT) and their indices (UNSIGNED_SHORT), 44 bytes with padding.
fn triangle_bin(positions: [f32; 9], indices: [u16; 3]) -> Vec<u8> {
    let mut bin: Vec<u8> = positions.iter().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    bin.extend([0, 0]);
    bin
}

const POSITIONS: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// One grey triangle facing +z.
fn triangle() -> Value {
    json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1, "material": 0 }] }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0 } }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] },
            { "bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR" }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 36 },
            { "buffer": 0, "byteOffset": 36, "byteLength": 6 }
        ],
        "buffers": [{ "byteLength": 44, "uri": data_uri(&triangle_bin(POSITIONS, [0, 1, 2])) }]
    })
}

fn with(mut doc: Value, edit: impl FnOnce(&mut Value)) -> Value {
    edit(&mut doc);
    doc
}

#[test]
fn the_small_file_loads() {
    let s = load_json("triangle.gltf", &triangle()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((s.triangle_count(), s.materials.len()), (1, 1));
    assert_eq!(s.materials[0].kind, MaterialKind::Diffuse { color: DVec3::splat(0.5) });
}

#[test]
fn materials_map_onto_the_papers_models() {
    let kind = |material: Value| {
        let doc = with(triangle(), |d| d["materials"][0] = material);
        load_json("material.gltf", &doc).unwrap_or_else(|e| panic!("{e}")).materials[0].kind.clone()
    };
    let smooth_metal =
        json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.6, 0.2, 1], "roughnessFactor": 0.5 } });
    assert_eq!(
        kind(smooth_metal),
        MaterialKind::Metal { color: DVec3::new(0.9, 0.6, 0.2).as_vec3().as_dvec3(), exponent: 30.0 }
    );
    let glass = json!({ "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_ior": { "ior": 1.33 } },
                        "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.0 } });
    assert_eq!(kind(glass), MaterialKind::Dielectric { eta: 1.33f32 as f64, exponent: 10_000.0 });
    let coated = json!({ "extensions": { "KHR_materials_clearcoat": { "clearcoatFactor": 1.0, "clearcoatRoughness": 1.0 } },
                         "pbrMetallicRoughness": { "baseColorFactor": [0.1, 0.2, 0.7, 1], "metallicFactor": 0.0 } });
    let color = DVec3::new(0.1, 0.2, 0.7).as_vec3().as_dvec3();
    assert_eq!(kind(coated), MaterialKind::Polished { color, eta: 1.5, exponent: 1.0 });
    let rough_metal = json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.25, 0.5, 0.75, 1], "roughnessFactor": 0.9 } });
    assert_eq!(kind(rough_metal), MaterialKind::Diffuse { color: DVec3::new(0.25, 0.5, 0.75) });
    // No material at all: glTF's default (white, metallic 1, roughness 1) → white diffuse.
    let doc = with(triangle(), |d| {
        d["meshes"][0]["primitives"][0].as_object_mut().unwrap().remove("material");
    });
    let s = load_json("no_material.gltf", &doc).unwrap();
    assert_eq!(
        (s.materials[0].name.as_str(), &s.materials[0].kind),
        ("default", &MaterialKind::Diffuse { color: DVec3::ONE })
    );
}

#[test]
fn lights_cameras_and_hierarchy_are_read() {
    let doc = with(triangle(), |d| {
        d["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        d["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
            { "type": "point", "color": [1.0, 0.5, 0.25], "intensity": 123.0 },
            { "type": "directional", "intensity": 1.0 }
        ] } });
        d["cameras"] = json!([{ "type": "perspective", "perspective": { "yfov": 0.5, "znear": 0.1 } }]);
        d["nodes"] = json!([
            { "children": [1, 2, 3], "translation": [0.0, 0.0, -1.0] },
            { "mesh": 0, "scale": [2.0, 2.0, 2.0] },
            { "translation": [0.0, 0.0, 11.0], "extensions": { "KHR_lights_punctual": { "light": 0 } } },
            { "translation": [0.0, 0.0, 5.0], "children": [4] },
            { "camera": 0, "extensions": { "KHR_lights_punctual": { "light": 1 } } }
        ]);
    });
    let s = load_json("lights.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    // Transforms compose down the tree: scale 2 under a translation of -1 in z.
    assert_eq!(s.meshes[0].positions[1], DVec3::new(2.0, 0.0, -1.0));
    assert_eq!((s.camera.eye, s.camera.look_at), (DVec3::new(0.0, 0.0, 4.0), DVec3::new(0.0, 0.0, 3.0)));
    assert_eq!((s.camera.width, s.camera.height), (640, 480), "no aspectRatio: the default size");
    assert!((s.camera.vfov_deg - 0.5f64.to_degrees()).abs() < 1e-12);
    assert_eq!(s.lights.len(), 2);
    assert_eq!(s.lights[0].position, DVec3::new(0.0, 0.0, 10.0));
    // Illuminance at the scene's centre (1, 1, -1), √123 away: 123 cd / 123 = 1 lux, as much as
    // the directional light's 1 lux; the strongest channel of each becomes 1.
    assert!((s.lights[0].color - DVec3::new(1.0, 0.5, 0.25)).length() < 0.01, "{}", s.lights[0].color);
    assert!((s.lights[1].color - DVec3::ONE).length() < 0.01, "{}", s.lights[1].color);
    // The directional light shines along its node's -z: it sits far out on +z from the centre.
    let l = s.lights[1].position;
    assert!(l.x == 1.0 && l.y == 1.0 && l.z > 100.0, "{l}");
}

#[test]
fn strips_fans_and_mirrors_keep_triangles_facing_out() {
    // A unit square, two triangles facing +z: as a strip (zigzag order) and as a fan (around),
    // each also under a mirroring scale.
    let strip = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
    let fan = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
    for (mode, scale) in [(5, 1.0), (5, -1.0), (6, 1.0), (6, -1.0)] {
        let bin: Vec<u8> =
            (if mode == 5 { strip } else { fan }).iter().flat_map(|x| x.to_le_bytes()).collect();
        let doc = with(triangle(), |d| {
            d["nodes"][0]["scale"] = json!([scale, 1.0, 1.0]);
            d["meshes"][0]["primitives"][0] = json!({ "attributes": { "POSITION": 0 }, "mode": mode });
            d["accessors"] = json!([{ "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                                      "min": [0, 0, 0], "max": [1, 1, 0] }]);
            d["bufferViews"] = json!([{ "buffer": 0, "byteLength": 48 }]);
            d["buffers"] = json!([{ "byteLength": 48, "uri": data_uri(&bin) }]);
        });
        let s = load_json("strip.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.triangle_count(), 2, "mode {mode}");
        for t in s.triangles() {
            let n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
            assert!(n.z > 0.0, "mode {mode}, scale {scale}: triangle {t:?} faces away from +z");
        }
    }
}

// ---- Bad input: one test per class ---------------------------------------------------------

#[test]
fn json_syntax_error_has_line_and_column() {
    let path = tmp_dir().join("syntax.gltf");
    std::fs::write(&path, "{\n  \"asset\": { \"version\": \"2.0\" },\n  \"scenes\": [}\n").unwrap();
    let e = load(&path).unwrap_err();
    assert_eq!((e.line, e.column), (Some(3), Some(14)), "{e}");
    assert!(e.message.contains("invalid glTF JSON"), "{e}");
}

#[test]
fn wrong_type_in_json_names_the_position() {
    let e = refused("type.gltf", &with(triangle(), |d| d["accessors"][0]["count"] = json!(-3)), &["invalid"]);
    assert!(e.line.is_some(), "{e}");
}

#[test]
fn gltf_1_is_refused_by_version() {
    refused(
        "version.gltf",
        &with(triangle(), |d| d["asset"]["version"] = json!("1.0")),
        &["'1.0'", "glTF 2.0"],
    );
    // A real glTF 1.0 document fails JSON typing first; the version is still what is reported.
    refused("v1.gltf", &json!({ "asset": { "version": "1.0" }, "meshes": { "m": {} } }), &["'1.0'"]);
}

#[test]
fn unsupported_required_extension() {
    let doc = with(triangle(), |d| {
        d["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
        d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    });
    refused(
        "draco.gltf",
        &doc,
        &["extensionsRequired[0]", "KHR_draco_mesh_compression", "KHR_lights_punctual"],
    );
    // Used but not required: ignored.
    let doc = with(triangle(), |d| d["extensionsUsed"] = json!(["KHR_materials_sheen"]));
    load_json("used.gltf", &doc).unwrap();
}

#[test]
fn index_to_a_missing_object() {
    let doc = with(triangle(), |d| d["meshes"][0]["primitives"][0]["indices"] = json!(7));
    refused("index.gltf", &doc, &["meshes[0].primitives[0].indices", "does not exist"]);
}

#[test]
fn huge_counts_are_refused_before_allocating() {
    let doc = with(triangle(), |d| d["accessors"][0]["count"] = json!(1_000_000_000u64));
    refused("count.gltf", &doc, &["accessors[0]", "1000000000 vertices", "limit"]);
    let doc = with(triangle(), |d| d["accessors"][1]["count"] = json!(999_999_999u64));
    refused("indices.gltf", &doc, &["999999999 indices", "limit"]);
    let doc = with(triangle(), |d| d["buffers"][0]["byteLength"] = json!(1u64 << 40));
    refused("buffer.gltf", &doc, &["buffers[0]", "bytes"]);
}

#[test]
fn accessor_past_its_buffer_view() {
    let doc = with(triangle(), |d| d["accessors"][0]["count"] = json!(4));
    refused("view.gltf", &doc, &["accessors[0]", "do not fit in bufferViews[0]", "36 bytes"]);
    let doc = with(triangle(), |d| d["accessors"][1]["byteOffset"] = json!(2));
    refused("offset.gltf", &doc, &["accessors[1]", "bufferViews[1]"]);
}

#[test]
fn buffer_view_past_its_buffer() {
    let doc = with(triangle(), |d| d["bufferViews"][1]["byteOffset"] = json!(40));
    refused("past.gltf", &doc, &["bufferViews[1]", "buffers[0]", "44 bytes"]);
}

#[test]
fn missing_or_short_buffers() {
    let doc = with(triangle(), |d| d["buffers"][0]["uri"] = json!("missing.bin"));
    refused("missing.gltf", &doc, &["buffers[0]", "missing.bin", "No such file"]);
    let doc = with(triangle(), |d| d["buffers"][0]["byteLength"] = json!(1000));
    refused("short.gltf", &doc, &["buffers[0]", "byteLength 1000", "44 bytes"]);
    let doc =
        with(triangle(), |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,AA*A"));
    refused("base64.gltf", &doc, &["buffers[0]", "base64"]);
    let doc = with(triangle(), |d| d["buffers"][0]["uri"] = json!("https://example.com/x.bin"));
    refused("remote.gltf", &doc, &["buffers[0]", "relative file path"]);
    let glb_without_bin = with(triangle(), |d| {
        d["buffers"][0].as_object_mut().unwrap().remove("uri");
    });
    refused("nobin.gltf", &glb_without_bin, &["buffers[0]", "binary chunk"]);
}

#[test]
fn external_buffers_are_read_beside_the_file() {
    std::fs::write(tmp_dir().join("tri angle.bin"), triangle_bin(POSITIONS, [0, 1, 2])).unwrap();
    let doc = with(triangle(), |d| d["buffers"][0]["uri"] = json!("tri%20angle.bin"));
    assert_eq!(load_json("external.gltf", &doc).unwrap().triangle_count(), 1);
}

#[test]
fn vertex_index_out_of_range() {
    let doc =
        with(triangle(), |d| d["buffers"][0]["uri"] = json!(data_uri(&triangle_bin(POSITIONS, [0, 1, 9]))));
    refused("vertex.gltf", &doc, &["accessors[1]", "element 2 is vertex 9", "3 vertices"]);
}

#[test]
fn non_finite_numbers() {
    let mut nan = POSITIONS;
    nan[4] = f32::NAN;
    let doc = with(triangle(), |d| d["buffers"][0]["uri"] = json!(data_uri(&triangle_bin(nan, [0, 1, 2]))));
    refused("nan.gltf", &doc, &["accessors[0]", "POSITION", "element 1", "finite"]);
    // 1e39 is beyond f32: the JSON number becomes infinity.
    let doc = with(triangle(), |d| d["nodes"][0]["translation"] = json!([1e39, 0, 0]));
    refused("inf.gltf", &doc, &["nodes[0].translation", "inf", "finite"]);
    let doc = with(triangle(), |d| {
        d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([2, 0, 0, 1])
    });
    refused("color.gltf", &doc, &["materials[0].pbrMetallicRoughness.baseColorFactor", "[0, 1]"]);
}

#[test]
fn wrong_accessor_types() {
    let doc = with(triangle(), |d| d["accessors"][0]["componentType"] = json!(5123));
    refused(
        "position_type.gltf",
        &doc,
        &["accessors[0]", "POSITION", "is VEC3 of UNSIGNED_SHORT; expected VEC3 of FLOAT"],
    );
    let doc = with(triangle(), |d| d["accessors"][1]["componentType"] = json!(5126));
    refused(
        "index_type.gltf",
        &doc,
        &["accessors[1]", "indices", "expected SCALAR of UNSIGNED_BYTE or UNSIGNED_SHORT or UNSIGNED_INT"],
    );
    let doc = with(triangle(), |d| d["accessors"][1]["count"] = json!(2));
    refused("whole.gltf", &doc, &["meshes[0].primitives[0]", "whole triangles"]);
}

#[test]
fn node_cycles_are_refused() {
    let doc = with(triangle(), |d| d["nodes"] = json!([{ "children": [1] }, { "children": [0], "mesh": 0 }]));
    refused("cycle.gltf", &doc, &["reached twice", "tree"]);
}

#[test]
fn points_and_lines_are_skipped_and_nothing_left_is_an_error() {
    let doc = with(triangle(), |d| {
        let points = json!({ "attributes": { "POSITION": 0 }, "mode": 0 });
        d["meshes"][0]["primitives"].as_array_mut().unwrap().push(points);
    });
    assert_eq!(load_json("points.gltf", &doc).unwrap().triangle_count(), 1, "the triangles stay");
    let doc = with(triangle(), |d| d["meshes"][0]["primitives"][0]["mode"] = json!(1));
    refused("lines.gltf", &doc, &["no triangles"]);
}

#[test]
fn without_a_scene_every_root_node_is_shown_and_orthographic_cameras_are_replaced() {
    let doc = with(triangle(), |d| {
        let o = d.as_object_mut().unwrap();
        o.remove("scene");
        o.remove("scenes");
        d["cameras"] = json!([{ "type": "orthographic", "orthographic": { "xmag": 1, "ymag": 1, "zfar": 10, "znear": 0.1 } }]);
        d["nodes"] =
            json!([{ "mesh": 0 }, { "mesh": 0, "translation": [5, 0, 0], "children": [2] }, { "camera": 0 }]);
    });
    let s = load_json("no_scene.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.meshes.len(), 2, "both roots, the mesh instanced twice");
    assert_eq!(s.camera.look_at, DVec3::new(3.0, 0.5, 0.0), "the framing camera, at the bounds' centre");
}

/// A triangle whose material's base-colour texture is a 2x1 PNG, red | blue, with texture
/// coordinates `uvs` (TEXCOORD_0) and the texture reference `info`.
fn textured_triangle(uvs: [f32; 6], info: Value) -> Value {
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&[255, 0, 0, 0, 0, 255], 2, 1, image::ExtendedColorType::Rgb8)
        .unwrap();
    let mut bin = triangle_bin(POSITIONS, [0, 1, 2]);
    bin.extend(uvs.iter().flat_map(|x| x.to_le_bytes()));
    with(triangle(), |d| {
        d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = info;
        d["textures"] = json!([{ "source": 0 }]);
        d["images"] = json!([{ "uri": format!("data:image/png;base64,{}", base64(&png)), "name": "rb" }]);
        d["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(2);
        d["accessors"]
            .as_array_mut()
            .unwrap()
            .push(json!({ "bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2" }));
        d["bufferViews"]
            .as_array_mut()
            .unwrap()
            .push(json!({ "buffer": 0, "byteOffset": 44, "byteLength": 24 }));
        d["buffers"][0] = json!({ "byteLength": 68, "uri": data_uri(&bin) });
    })
}

#[test]
fn base_colour_textures_keep_their_texels_sampler_and_coordinates() {
    let uvs = [0.1f32, 0.2, 0.4, 0.2, -0.1, 1.9];
    let doc = with(textured_triangle(uvs, json!({ "index": 0 })), |d| {
        // CLAMP_TO_EDGE along u, MIRRORED_REPEAT along v, NEAREST magnification.
        d["samplers"] = json!([{ "wrapS": 33071, "wrapT": 33648, "magFilter": 9728 }]);
        d["textures"][0]["sampler"] = json!(0);
    });
    let s = load_json("textured.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.materials[0].kind, MaterialKind::Diffuse { color: DVec3::splat(0.5) }, "the factor");
    assert_eq!(s.materials[0].texture, Some(0));
    let t = &s.textures[0];
    assert_eq!((t.name.as_str(), t.width, t.height), ("rb", 2, 1));
    assert_eq!(t.texels, vec![[255, 0, 0, 255], [0, 0, 255, 255]]);
    assert_eq!((t.wrap, t.filter), ([Wrap::Clamp, Wrap::Mirror], Filter::Nearest));
    let want: Vec<DVec2> = uvs.chunks(2).map(|c| DVec2::new(c[0] as f64, c[1] as f64)).collect();
    assert_eq!(s.meshes[0].uvs.as_ref(), Some(&want));
    // Without texture coordinates the texture stays; the surface reads it at (0, 0).
    let doc = with(doc, |d| {
        d["meshes"][0]["primitives"][0]["attributes"].as_object_mut().unwrap().remove("TEXCOORD_0");
    });
    let s = load_json("no_uvs.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((s.materials[0].texture, s.meshes[0].uvs.as_ref()), (Some(0), None));
    // A dielectric has no colour to texture.
    let doc = with(doc, |d| {
        d["extensionsUsed"] = json!(["KHR_materials_transmission"]);
        d["materials"][0]["extensions"] =
            json!({ "KHR_materials_transmission": { "transmissionFactor": 1.0 } });
    });
    let s = load_json("glass.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(s.materials[0].kind, MaterialKind::Dielectric { .. }));
    assert_eq!((s.materials[0].texture, s.textures.len()), (None, 0));
}

/// The textured triangle with a KHR_texture_transform (`transform`) on its texture reference.
fn transformed_triangle(transform: Value) -> Value {
    let info = json!({ "index": 0, "extensions": { "KHR_texture_transform": transform } });
    with(textured_triangle([0.0, 0.0, 0.25, 0.5, 1.0, 0.75], info), |d| {
        d["extensionsUsed"] = json!(["KHR_texture_transform"]);
        d["extensionsRequired"] = json!(["KHR_texture_transform"]);
    })
}

#[test]
fn texture_transform_moves_the_coordinates() {
    // offset (0.5, 0), a quarter turn, scale (2, 1): (u, v) → (0.5 - v, 2u) (the extension's
    // matrix translation · rotation · scale, rotation counter-clockwise in uv space).
    let t = json!({ "offset": [0.5, 0.0], "rotation": std::f64::consts::FRAC_PI_2, "scale": [2.0, 1.0] });
    let s = load_json("transform.gltf", &transformed_triangle(t)).unwrap_or_else(|e| panic!("{e}"));
    let got = s.meshes[0].uvs.as_ref().expect("uvs");
    let want = [DVec2::new(0.5, 0.0), DVec2::new(0.0, 0.5), DVec2::new(-0.25, 2.0)];
    for (g, w) in got.iter().zip(want) {
        assert!((*g - w).length() < 1e-12, "{g} vs {w}");
    }
    // texCoord in the transform overrides the reference's: set 1 is missing here, so the
    // texture is read at (0, 0) (a warning), not from TEXCOORD_0.
    let s = load_json("set1.gltf", &transformed_triangle(json!({ "texCoord": 1 }))).unwrap();
    assert_eq!((s.materials[0].texture, s.meshes[0].uvs.as_ref()), (Some(0), None));
    // Bad values name the property.
    for (t, key) in [
        (json!({ "offset": [0.5] }), "KHR_texture_transform.offset"),
        (json!({ "scale": [1.0, "x"] }), "KHR_texture_transform.scale"),
        (json!({ "rotation": "quarter" }), "KHR_texture_transform.rotation"),
        (json!({ "texCoord": -1 }), "KHR_texture_transform.texCoord"),
    ] {
        refused(
            "bad_transform.gltf",
            &transformed_triangle(t),
            &["materials[0].pbrMetallicRoughness.baseColorTexture.extensions", key],
        );
    }
}

#[test]
fn broken_glb_containers() {
    let duck = std::fs::read(sample("Duck.glb")).unwrap();
    let path = tmp_dir().join("broken.glb");
    let check = |bytes: &[u8], words: &[&str]| {
        std::fs::write(&path, bytes).unwrap();
        let e = load(&path).unwrap_err();
        for w in words {
            assert!(e.message.contains(w), "message lacks '{w}': {e}");
        }
    };
    check(&duck[..100], &["header declares", "the file has 100"]);
    check(&duck[..6], &["12-byte header"]);
    let mut v1 = duck.clone();
    v1[4] = 1;
    check(&v1, &["GLB version 1"]);
    let mut chunk = duck.clone();
    chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    check(&chunk, &["not a valid GLB", "JSON chunk"]);
}

/// CRC-32 (PNG's) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

#[test]
fn huge_texture_is_refused_from_its_header() {
    // A PNG signature and a valid IHDR chunk claiming 100000 x 100000 pixels, nothing else.
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(100_000u32.to_be_bytes());
    ihdr.extend(100_000u32.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32(&ihdr).to_be_bytes());
    let doc = with(triangle(), |d| {
        d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": 0 });
        d["textures"] = json!([{ "source": 0 }]);
        d["images"] = json!([{ "uri": format!("data:image/png;base64,{}", base64(&png)) }]);
    });
    refused("huge_texture.gltf", &doc, &["images[0]", "100000x100000"]);
}

#[test]
fn textures_too_large_together_are_refused_before_decoding_the_next() {
    // Three materials, each with its own 4096x4096 image (a solid colour: 50 KiB of PNG, 64 MiB
    // decoded). The first two fit the scene's budget of 2^25 pixels; the third is refused from
    // its header, before it is decoded.
    let texels = vec![[200u8, 100, 50, 255]; 4096 * 4096];
    let png = irt::io::png::encode(4096, 4096, &texels).unwrap();
    let uri = format!("data:image/png;base64,{}", base64(&png));
    let doc = with(triangle(), |d| {
        let primitive = d["meshes"][0]["primitives"][0].clone();
        let material = d["materials"][0].clone();
        let (mut materials, mut primitives) = (vec![], vec![]);
        for i in 0..3 {
            let mut m = material.clone();
            m["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": i });
            materials.push(m);
            let mut p = primitive.clone();
            p["material"] = json!(i);
            primitives.push(p);
        }
        d["materials"] = json!(materials);
        d["meshes"][0]["primitives"] = json!(primitives);
        d["textures"] = json!([{ "source": 0 }, { "source": 1 }, { "source": 2 }]);
        d["images"] = json!([{ "uri": uri }, { "uri": uri }, { "uri": uri }]);
    });
    refused("many_textures.gltf", &doc, &["images[2]", "50331648 pixels together", "at most 33554432"]);
}

// ---- Mutated files never panic -------------------------------------------------------------

fn check_no_panic(result: Result<Scene, LoadError>) {
    match result {
        Ok(scene) => {
            scene.validate().expect("what the loader returns is valid");
            assert!(scene.triangle_count() > 0);
        }
        Err(e) => assert!(!e.message.is_empty()),
    }
}

#[test]
fn mutated_box_files_never_panic() {
    const VALUES: &[f64] = &[
        0.0,
        -1.0,
        1.0,
        2.0,
        3.0,
        7.0,
        36.0,
        255.0,
        65535.0,
        4294967295.0,
        1e9,
        1e20,
        1e39,
        -1e39,
        0.5,
        5121.0,
        5125.0,
    ];
    let text = std::fs::read_to_string(sample("Box.gltf")).unwrap();
    let original: Value = serde_json::from_str(&text).unwrap();
    let mut pointers = Vec::new();
    common::number_pointers(&original, String::new(), &mut pointers);
    let bin = {
        let uri = original["buffers"][0]["uri"].as_str().unwrap();
        let payload = uri.split_once(',').unwrap().1;
        // Decode with irt's own loader's view of the file: the buffer is the 648 bytes it declares.
        let mut bytes = Vec::new();
        let digits: Vec<u32> = payload
            .trim_end_matches('=')
            .bytes()
            .map(|c| {
                b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"
                    .iter()
                    .position(|&a| a == c)
                    .unwrap() as u32
            })
            .collect();
        for q in digits.chunks(4) {
            let n = q.iter().enumerate().fold(0u32, |n, (i, &d)| n | d << (18 - 6 * i));
            bytes.extend(&n.to_be_bytes()[1..q.len()]);
        }
        bytes
    };
    assert_eq!(bin.len(), 648);
    let origin = tmp_dir().join("mutated.gltf").display().to_string();
    let mut rng = common::Rng::new(5);
    for _ in 0..400 {
        let mut doc = original.clone();
        for _ in 0..1 + rng.below(3) {
            let p = &pointers[rng.below(pointers.len())];
            *doc.pointer_mut(p).unwrap() = json!(VALUES[rng.below(VALUES.len())]);
        }
        if rng.below(3) == 0 {
            // Break the binary data too: any byte, often inside an index or a float's exponent.
            let mut b = bin.clone();
            for _ in 0..1 + rng.below(4) {
                let i = rng.below(b.len());
                b[i] = [0x00, 0xff, 0x7f, 0x80, rng.below(256) as u8][rng.below(5)];
            }
            doc["buffers"][0]["uri"] = json!(data_uri(&b));
        }
        check_no_panic(parse(&serde_json::to_vec(&doc).unwrap(), &origin));
    }
}

#[test]
fn mutated_glb_files_never_panic() {
    let duck = std::fs::read(sample("Duck.glb")).unwrap();
    let origin = tmp_dir().join("mutated.glb").display().to_string();
    let mut rng = common::Rng::new(9);
    for round in 0..120 {
        let mut bytes = duck.clone();
        match round % 3 {
            // Header and chunk headers.
            0 => {
                let i = rng.below(24);
                bytes[i] = rng.below(256) as u8;
            }
            // Anywhere.
            1 => {
                for _ in 0..1 + rng.below(8) {
                    let i = rng.below(bytes.len());
                    bytes[i] = rng.below(256) as u8;
                }
            }
            // Truncated.
            _ => bytes.truncate(rng.below(bytes.len())),
        }
        check_no_panic(parse(&bytes, &origin));
    }
}
