//! glTF animations (docs/gltf.md, "Animations"): every sampler kind on every property poses the
//! meshes at the key values and between them as the interpolation says, clamped outside; node
//! paths become motion stages; bad channels are refused with their JSON path; an animated model
//! keeps its motions in a TOML scene; and each pose renders on the GPU as the CPU reference does.
use crate::common;

use glam::{DMat4, DQuat, DVec3};
use irt::io::{load, stage, LoadError};
use irt::scene::{Scene, Stage, Target};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

fn tmp_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gltf_animation");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn animated(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/models/animated").join(name)
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A glTF file under construction: one buffer, a bufferView and accessor per array.
struct Gltf {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Gltf {
    /// A file whose accessor 0 is one triangle, (0,0,0) (1,0,0) (0,1,0): mesh 0.
    fn new() -> Self {
        let mut g = Gltf { bin: vec![], views: vec![], accessors: vec![] };
        g.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        g.accessors[0]["min"] = json!([0.0, 0.0, 0.0]);
        g.accessors[0]["max"] = json!([1.0, 1.0, 0.0]);
        g
    }

    fn bytes(&mut self, type_: &str, component: u32, count: usize, data: &[u8]) -> usize {
        self.views.push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": data.len()}));
        self.bin.extend_from_slice(data);
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.accessors.push(json!({
            "bufferView": self.views.len() - 1, "componentType": component, "count": count, "type": type_
        }));
        self.accessors.len() - 1
    }

    /// An accessor of FLOAT `type_` elements holding `data`.
    fn floats(&mut self, type_: &str, data: &[f32]) -> usize {
        let n = match type_ {
            "SCALAR" => 1,
            "VEC3" => 3,
            _ => 4,
        };
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        self.bytes(type_, 5126, data.len() / n, &bytes)
    }

    fn doc(&self, nodes: Value, animations: Value) -> Value {
        let roots: Vec<usize> = (0..nodes.as_array().unwrap().len()).collect();
        let mut doc = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": roots}],
            "nodes": nodes,
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{
                "byteLength": self.bin.len(),
                "uri": format!("data:application/octet-stream;base64,{}", base64(&self.bin)),
            }],
            "animations": animations,
        });
        // Roots are listed in "scenes"; a test that builds a hierarchy sets its own.
        if doc["nodes"].as_array().unwrap().iter().any(|n| n.get("children").is_some()) {
            doc["scenes"] = json!([{"nodes": [0]}]);
        }
        doc
    }
}

fn animation(input: usize, output: usize, interpolation: &str, node: usize, path: &str) -> Value {
    json!({
        "samplers": [{"input": input, "output": output, "interpolation": interpolation}],
        "channels": [{"sampler": 0, "target": {"node": node, "path": path}}],
    })
}

fn write(name: &str, doc: &Value) -> PathBuf {
    let path = tmp_dir().join(name);
    std::fs::write(&path, serde_json::to_vec_pretty(doc).unwrap()).unwrap();
    path
}

fn load_json(name: &str, doc: &Value) -> Result<Scene, LoadError> {
    load(&write(name, doc))
}

fn refused(name: &str, doc: &Value, words: &[&str]) {
    let e = load_json(name, doc).expect_err("the file should be refused");
    assert!(e.to_string().starts_with(&tmp_dir().join(name).display().to_string()), "{e}");
    for w in words {
        assert!(e.message.contains(w), "message lacks '{w}': {e}");
    }
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-6
}

/// The three sampler kinds, one per node: STEP translation, LINEAR rotation, CUBICSPLINE scale
/// (each other property held at the node's rest value).
fn kinds() -> Value {
    let mut g = Gltf::new();
    let t3 = g.floats("SCALAR", &[0.0, 1.0, 2.0]);
    let step = g.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 2.0, 0.0]);
    let t2 = g.floats("SCALAR", &[0.0, 2.0]);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let turn = g.floats("VEC4", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, h, h]);
    // In-tangent, value, out-tangent per key: 1 → 3 with slope 1/s on x leaving key 0.
    #[rustfmt::skip]
    let spline = g.floats("VEC3", &[
        0.0, 0.0, 0.0,  1.0, 1.0, 1.0,  1.0, 0.0, 0.0,
        0.0, 0.0, 0.0,  3.0, 3.0, 3.0,  0.0, 0.0, 0.0,
    ]);
    let nodes = json!([
        {"mesh": 0, "translation": [0.0, 0.0, -1.0]},
        {"mesh": 0, "translation": [5.0, 0.0, 0.0]},
        {"mesh": 0, "translation": [0.0, 5.0, 0.0], "scale": [7.0, 7.0, 7.0]},
    ]);
    g.doc(
        nodes,
        json!([
            animation(t3, step, "STEP", 0, "translation"),
            animation(t2, turn, "LINEAR", 1, "rotation"),
            animation(t2, spline, "CUBICSPLINE", 2, "scale"),
        ]),
    )
}

/// Where vertex `v` of mesh `m` is at time `t`.
fn at(scene: &Scene, t: f64, m: usize, v: usize) -> DVec3 {
    scene.at(t).meshes[m].positions[v]
}

#[test]
fn every_sampler_kind_poses_at_its_keys_between_them_and_clamps_outside() {
    let s = load_json("kinds.gltf", &kinds()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.motions.len(), 3);
    assert_eq!(s.duration(), 2.0);
    assert!(s.motions.iter().zip(0..).all(|(a, i)| a.target == Target::Mesh(i)));
    // Meshes of animated nodes are kept in their own coordinates.
    assert_eq!(s.meshes[1].positions, vec![DVec3::ZERO, DVec3::X, DVec3::Y]);

    // STEP translation (rest z = -1 is replaced by the keys: translation is the keyed property).
    let v = |t| at(&s, t, 0, 1);
    assert_eq!(v(0.0), DVec3::X);
    assert_eq!(v(0.999), DVec3::X, "STEP holds the earlier key");
    assert_eq!(v(1.0), DVec3::new(2.0, 0.0, 0.0));
    assert_eq!(v(1.5), DVec3::new(2.0, 0.0, 0.0));
    assert_eq!(v(2.0), DVec3::new(2.0, 2.0, 0.0));
    assert_eq!(v(-3.0), DVec3::X, "before the first key: the first value");
    assert_eq!(v(30.0), DVec3::new(2.0, 2.0, 0.0), "after the last key: the last value");

    // LINEAR rotation about z by 0 → 90°; the rest translation (5, 0, 0) is held.
    let v = |t| at(&s, t, 1, 1);
    let r = std::f64::consts::FRAC_1_SQRT_2;
    assert!(close(v(0.0), DVec3::new(6.0, 0.0, 0.0)), "{}", v(0.0));
    assert!(close(v(1.0), DVec3::new(5.0 + r, r, 0.0)), "slerp midpoint is 45°: {}", v(1.0));
    assert!(close(v(2.0), DVec3::new(5.0, 1.0, 0.0)), "{}", v(2.0));
    assert!(close(v(-1.0), v(0.0)) && close(v(9.0), v(2.0)));

    // CUBICSPLINE scale 1 → 3 over 2 s, x leaving key 0 at slope 1/s: at s = 1/2 the Hermite
    // basis gives 0.5·1 + 0.5·3 + (s³ − 2s² + s)·Δt·1 = 2 + 0.125·2 on x, 2 on y. The rest
    // scale 7 is replaced by the keys.
    let x = |t| at(&s, t, 2, 1) - DVec3::new(0.0, 5.0, 0.0);
    let y = |t| at(&s, t, 2, 2) - DVec3::new(0.0, 5.0, 0.0);
    assert!(close(x(0.0), DVec3::X), "the spline passes through key 0: {}", x(0.0));
    assert!(close(x(2.0), 3.0 * DVec3::X), "and key 1: {}", x(2.0));
    assert!(close(x(1.0), DVec3::new(2.25, 0.0, 0.0)), "{}", x(1.0));
    assert!(close(y(1.0), DVec3::new(0.0, 2.0, 0.0)), "{}", y(1.0));
    assert!(close(x(-1.0), DVec3::X) && close(x(5.0), 3.0 * DVec3::X));
}

#[test]
fn every_sampler_kind_on_every_property() {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let r = std::f64::consts::FRAC_1_SQRT_2;
    // (property, key values, where vertex (1, 0, 0) is at the keys and half way between)
    type Case<'a> = (&'a str, [&'a [f32]; 2], [DVec3; 3]);
    let cases: [Case; 3] = [
        (
            "translation",
            [&[0.0, 0.0, 0.0], &[2.0, 0.0, 0.0]],
            [DVec3::X, DVec3::new(2.0, 0.0, 0.0), 3.0 * DVec3::X],
        ),
        ("rotation", [&[0.0, 0.0, 0.0, 1.0], &[0.0, 0.0, h, h]], [DVec3::X, DVec3::new(r, r, 0.0), DVec3::Y]),
        (
            "scale",
            [&[1.0, 1.0, 1.0], &[3.0, 3.0, 3.0]],
            [DVec3::X, DVec3::new(2.0, 0.0, 0.0), 3.0 * DVec3::X],
        ),
    ];
    for (property, keys, [first, middle, last]) in cases {
        for interpolation in ["STEP", "LINEAR", "CUBICSPLINE"] {
            let mut g = Gltf::new();
            let times = g.floats("SCALAR", &[0.0, 2.0]);
            let (n, kind) = if property == "rotation" { (4, "VEC4") } else { (3, "VEC3") };
            let zero = vec![0.0f32; n];
            let values: Vec<f32> = if interpolation == "CUBICSPLINE" {
                // Zero tangents: half way is the average, as for LINEAR (nlerp = slerp there).
                [&zero[..], keys[0], &zero[..], &zero[..], keys[1], &zero[..]].concat()
            } else {
                keys.concat()
            };
            let output = g.floats(kind, &values);
            let doc =
                g.doc(json!([{"mesh": 0}]), json!([animation(times, output, interpolation, 0, property)]));
            let name = format!("{property}-{interpolation}.gltf");
            let s = load_json(&name, &doc).unwrap_or_else(|e| panic!("{e}"));
            let half = if interpolation == "STEP" { first } else { middle };
            for (t, want) in [(-1.0, first), (0.0, first), (1.0, half), (2.0, last), (3.0, last)] {
                assert!(close(at(&s, t, 0, 1), want), "{name} at {t}: {} vs {want}", at(&s, t, 0, 1));
            }
        }
    }
}

#[test]
fn an_animated_scene_is_framed_on_the_poses_it_takes() {
    // The STEP node rests at z = -1 but is at z = 0 at time 0, and moves on.
    let s = load_json("framed.gltf", &kinds()).unwrap();
    assert_eq!(s.camera, stage::framing_camera(&stage::swept_meshes(&s)));
    assert_ne!(s.camera, stage::framing_camera(&s.at(0.0).meshes), "time 0 alone frames less");
    let unposed = stage::framing_camera(&s.meshes);
    assert_ne!(s.camera, unposed, "framing the meshes' own coordinates would differ");
}

#[test]
fn a_node_path_becomes_keyed_and_merged_fixed_stages_and_still_meshes_bake_as_before() {
    let mut g = Gltf::new();
    let t = g.floats("SCALAR", &[0.0, 1.0]);
    let lift = g.floats("VEC3", &[1.0, 0.0, 0.0, 1.0, 4.0, 0.0]);
    let q = DQuat::from_rotation_y(0.3);
    let nodes = json!([
        // root: unanimated, scaled; child 1 animated; 2 and 3 unanimated below it (one fixed
        // stage); 4 a still sibling of the animated branch, mirrored.
        {"children": [1, 4], "scale": [2.0, 2.0, 2.0]},
        {"children": [2], "translation": [1.0, 0.0, 0.0]},
        {"children": [3], "translation": [0.0, 0.0, 3.0]},
        {"mesh": 0, "rotation": [q.x, q.y, q.z, q.w]},
        {"mesh": 0, "scale": [-1.0, 1.0, 1.0], "translation": [0.5, 0.25, 0.0]},
    ]);
    let doc = g.doc(nodes.clone(), json!([animation(t, lift, "LINEAR", 1, "translation")]));
    let s = load_json("path.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.motions.len(), 1);
    let stages = &s.motions[0].motion.stages;
    assert!(
        matches!(stages.as_slice(), [Stage::Fixed(_), Stage::Keyed { .. }, Stage::Fixed(_)]),
        "{stages:?}"
    );
    let local = |p: DVec3, t: f64| {
        DMat4::from_scale(DVec3::splat(2.0))
            * DMat4::from_translation(DVec3::new(1.0, 4.0 * t.clamp(0.0, 1.0), 0.0))
            * DMat4::from_translation(DVec3::new(0.0, 0.0, 3.0))
            * DMat4::from_quat(q)
            * p.extend(1.0)
    };
    for t in [-1.0, 0.0, 0.25, 0.5, 1.0, 2.0] {
        for (v, p) in [DVec3::ZERO, DVec3::X, DVec3::Y].into_iter().enumerate() {
            let want = local(p, t).truncate();
            assert!(
                (at(&s, t, 0, v) - want).length() < 1e-5,
                "t {t} vertex {v}: {} vs {want}",
                at(&s, t, 0, v)
            );
        }
    }
    // The still sibling is baked exactly as the same file without animations bakes it.
    let mut still = doc.clone();
    still.as_object_mut().unwrap().remove("animations");
    let baked = load_json("path_still.gltf", &still).unwrap();
    assert_eq!(s.meshes[1], baked.meshes[1]);
    assert!(baked.motions.is_empty());
    // And the pose at time 0 of the animated branch is where the still file bakes it.
    for (a, b) in s.at(0.0).meshes[0].positions.iter().zip(&baked.meshes[0].positions) {
        assert!((*a - *b).length() < 1e-12, "{a} vs {b}");
    }
}

#[test]
fn normalized_integer_quaternions_and_several_animations_on_one_property() {
    let mut g = Gltf::new();
    let t = g.floats("SCALAR", &[0.0, 1.0]);
    // SHORT normalized: (0, 0, 0, 1) and (0, 0, 1, 0), a half turn about z.
    let q: Vec<u8> = [0i16, 0, 0, 32767, 0, 0, 32767, 0].iter().flat_map(|v| v.to_le_bytes()).collect();
    let quats = g.bytes("VEC4", 5122, 2, &q);
    let move_ = g.floats("VEC3", &[0.0, 0.0, 0.0, 9.0, 9.0, 9.0]);
    let mut doc = g.doc(
        json!([{"mesh": 0}]),
        json!([animation(t, quats, "STEP", 0, "rotation"), animation(t, move_, "LINEAR", 0, "rotation"),]),
    );
    doc["accessors"][quats]["normalized"] = json!(true);
    // The second animation's channel has the wrong type for rotation: refused even though it
    // would be ignored, since it is read before the rule applies. Give it a quaternion instead.
    refused("quat_types.gltf", &doc, &["output of animations[1].samplers[0]", "VEC3"]);
    doc["animations"][1]["samplers"][0]["output"] = json!(quats);
    doc["animations"][1]["samplers"][0]["interpolation"] = json!("LINEAR");
    let s = load_json("quat_short.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    // The first animation wins: STEP, so at 0.5 still the identity, at 1 the half turn.
    assert!(close(at(&s, 0.5, 0, 1), DVec3::X));
    assert!(close(at(&s, 1.0, 0, 1), -DVec3::X), "{}", at(&s, 1.0, 0, 1));
    // Within one animation two channels on one property are an error.
    let mut twice = doc.clone();
    let channel = twice["animations"][0]["channels"][0].clone();
    twice["animations"][0]["channels"].as_array_mut().unwrap().push(channel);
    refused(
        "twice.gltf",
        &twice,
        &["animations[0].channels[1]", "animations[0].channels[0]", "same node property"],
    );
    // Morph weights are ignored (a warning), and so is the rest of the file.
    let mut weights = doc.clone();
    weights["animations"][1]["channels"][0]["target"]["path"] = json!("weights");
    assert_eq!(load_json("weights.gltf", &weights).unwrap().motions.len(), 1);
}

#[test]
fn bad_animations_are_refused_with_their_json_path() {
    let good = kinds();
    let bad = |name: &str, edit: &dyn Fn(&mut Value), words: &[&str]| {
        let mut doc = good.clone();
        edit(&mut doc);
        refused(name, &doc, words);
    };
    bad(
        "node.gltf",
        &|d| d["animations"][1]["channels"][0]["target"]["node"] = json!(99),
        &["animations[1].channels[0].target.node", "nodes[99]", "3 nodes"],
    );
    bad(
        "sampler.gltf",
        &|d| d["animations"][0]["channels"][0]["sampler"] = json!(4),
        &["animations[0].channels[0].sampler"],
    );
    bad(
        "path.gltf",
        &|d| d["animations"][0]["channels"][0]["target"]["path"] = json!("colour"),
        &["animations[0].channels[0].target.path"],
    );
    // Accessor 1 holds 3 times, accessor 3 the 2 rotation times: 3 times, 2 quaternions.
    bad(
        "counts.gltf",
        &|d| d["animations"][1]["samplers"][0]["input"] = json!(1),
        &["animations[1].channels[0]", "nodes[1].rotation", "3 times but 2 values"],
    );
    // CUBICSPLINE needs three outputs per key: the STEP translation's keys are one per key.
    bad(
        "cubic.gltf",
        &|d| d["animations"][0]["samplers"][0]["interpolation"] = json!("CUBICSPLINE"),
        &["animations[0].channels[0]", "3 times but 3 values", "3 per key"],
    );
    bad(
        "input_type.gltf",
        &|d| d["animations"][0]["samplers"][0]["input"] = json!(2),
        &["accessors[2] (input of animations[0].samplers[0]) is VEC3", "SCALAR of FLOAT"],
    );
    bad(
        "interpolation.gltf",
        &|d| d["animations"][0]["samplers"][0]["interpolation"] = json!("SMOOTH"),
        &["animations[0].samplers[0].interpolation"],
    );
    bad(
        "matrix.gltf",
        &|d| d["nodes"][1]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
        &["animations[1].channels[0]", "nodes[1]", "matrix"],
    );

    // Numbers: each edit writes one float into the buffer (re-encoded).
    let numbers = |name: &str, accessor: usize, element: usize, value: f32, words: &[&str]| {
        let mut v = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 2.0, 0.0];
        let mut q = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0];
        let mut times = [0.0f32, 1.0, 2.0];
        match accessor {
            1 => times[element] = value,
            2 => v[element] = value,
            _ => q[element] = value,
        }
        let mut g2 = Gltf::new();
        let t3b = g2.floats("SCALAR", &times);
        let vb = g2.floats("VEC3", &v);
        let t2b = g2.floats("SCALAR", &[0.0, 2.0]);
        let qb = g2.floats("VEC4", &q);
        assert_eq!((t3b, vb, qb), (1, 2, 4));
        let doc = g2.doc(
            json!([{"mesh": 0}, {"mesh": 0}]),
            json!([
                animation(t3b, vb, "LINEAR", 0, "translation"),
                animation(t2b, qb, "LINEAR", 1, "rotation")
            ]),
        );
        refused(name, &doc, words);
    };
    numbers("decreasing.gltf", 1, 2, 0.5, &["animations[0].channels[0]", "key 2", "times must increase"]);
    numbers("equal.gltf", 1, 1, 0.0, &["animations[0].channels[0]", "times must increase"]);
    numbers("nan_time.gltf", 1, 1, f32::NAN, &["animations[0].channels[0]", "key 1", "not finite"]);
    numbers("inf_value.gltf", 2, 4, f32::INFINITY, &["animations[0].channels[0]", "value 1", "not finite"]);
    numbers("zero_quat.gltf", 4, 3, 0.0, &["animations[1].channels[0]", "key 0", "zero quaternion"]);
    numbers("nan_quat.gltf", 4, 6, f32::NAN, &["animations[1].channels[0]", "value 1", "not finite"]);
}

#[test]
fn the_khronos_animated_triangle_turns_about_z() {
    let s = load(&animated("AnimatedTriangle.gltf")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.motions.len(), 1);
    assert_eq!(s.duration(), 1.0);
    // Keys every quarter second: a quarter turn each (0, 90, 180, 270, 360 degrees about z).
    for (t, want) in [(0.0, DVec3::X), (0.25, DVec3::Y), (0.5, -DVec3::X), (0.75, -DVec3::Y), (1.0, DVec3::X)]
    {
        assert!((at(&s, t, 0, 1) - want).length() < 1e-3, "t {t}: {}", at(&s, t, 0, 1));
    }
    // Linear between: 45 degrees at t = 0.125.
    let r = std::f64::consts::FRAC_1_SQRT_2;
    assert!((at(&s, 0.125, 0, 1) - DVec3::new(r, r, 0.0)).length() < 1e-3);
}

/// Corners of the box around a mesh's vertices.
fn extent(mesh: &irt::scene::Mesh) -> (DVec3, DVec3) {
    mesh.positions.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
}

#[test]
fn the_khronos_box_animated_rises_turns_over_and_sinks() {
    let s = load(&animated("BoxAnimated.gltf")).unwrap_or_else(|e| panic!("{e}"));
    // Scene roots 3 (the outer box, still: baked) and 0 → 1 → 2 (the inner box): node 0's
    // translation and node 2's rotation are keyed; node 1 is the identity (no fixed stage).
    assert_eq!(s.motions.len(), 1);
    assert_eq!(s.motions[0].target, Target::Mesh(1));
    let stages = &s.motions[0].motion.stages;
    assert!(matches!(stages.as_slice(), [Stage::Keyed { .. }, Stage::Keyed { .. }]), "{stages:?}");
    assert!((s.duration() - 3.708329916000366).abs() < 1e-9);
    let inner = |t: f64| extent(&s.at(t).meshes[1]);
    let (r, h, lift) = (0.33504000306129458, 0.5, 2.5199999809265137);
    let near = |(lo, hi): (DVec3, DVec3), want_lo: DVec3, want_hi: DVec3| {
        (lo - want_lo).abs().max_element() < 1e-5 && (hi - want_hi).abs().max_element() < 1e-5
    };
    let upright = |y: f64| (DVec3::new(-r, y - h, -r), DVec3::new(r, y + h, r));
    // Rests in the outer box, rises by 1.25 s (not yet turned: the rotation starts there), has
    // turned over by 2.5 s (upside down: the same box), and is back down at the end.
    for (t, y) in [(0.0, 0.0), (1.25, lift), (2.5, lift), (3.708329916000366, 0.0), (9.0, 0.0)] {
        let (lo, hi) = upright(y);
        assert!(near(inner(t), lo, hi), "t {t}: {:?}", inner(t));
    }
    // Half way through the turn (1.875 s): a quarter turn about x, the box on its side.
    assert!(
        near(inner(1.875), DVec3::new(-r, lift - r, -h), DVec3::new(r, lift + r, h)),
        "{:?}",
        inner(1.875)
    );
    // Translation is linear: half way up half way through its first key interval.
    let (lo, _) = inner(0.625);
    assert!((lo.y - (lift / 2.0 - h)).abs() < 1e-5, "{lo}");
    // The outer box never moves.
    assert_eq!(s.at(2.0).meshes[0], s.meshes[0]);
}

#[test]
fn an_animated_model_in_a_toml_scene_keeps_its_motion_outside_its_placement() {
    let dir = tmp_dir().join("toml");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("kinds.gltf"), serde_json::to_vec(&kinds()).unwrap()).unwrap();
    let src = "[camera]\neye = [0, 1, 9]\nlook_at = [0, 0, 0]\nwidth = 32\nheight = 24\n\n\
               [[light]]\nposition = [3, 5, 4]\n\n\
               [[material]]\nname = \"red\"\ntype = \"diffuse\"\ncolor = [0.8, 0.1, 0.1]\n\n\
               [[mesh]]\nmaterial = \"red\"\npositions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\nindices = [[0, 1, 2]]\n\n\
               [[model]]\nfile = \"kinds.gltf\"\nscale = 2\nrotate = [0, 90, 0]\ntranslate = [1, 2, 3]\n";
    let path = dir.join("scene.toml");
    std::fs::write(&path, src).unwrap();
    let scene = load(&path).unwrap_or_else(|e| panic!("{e}"));
    let alone = load(&tmp_dir().join("toml/kinds.gltf")).unwrap();
    assert_eq!(scene.meshes.len(), 4);
    // Targets re-indexed past the scene's own mesh; the placement is the outermost stage.
    assert_eq!(
        scene.motions.iter().map(|a| a.target).collect::<Vec<_>>(),
        vec![Target::Mesh(1), Target::Mesh(2), Target::Mesh(3)]
    );
    let place =
        |p: DVec3| stage::rotation(DVec3::new(0.0, 90.0, 0.0)) * (2.0 * p) + DVec3::new(1.0, 2.0, 3.0);
    for t in [0.0, 0.5, 1.0, 1.7, 3.0] {
        for m in 0..3 {
            let (got, want) = (at(&scene, t, m + 1, 1), place(at(&alone, t, m, 1)));
            assert!((got - want).length() < 1e-9, "t {t} mesh {m}: {got} vs {want}");
        }
    }
    // The scene's own mesh does not move.
    assert_eq!(scene.at(1.0).meshes[0], scene.meshes[0]);
}

#[test]
fn gpu_matches_the_reference_on_poses_of_box_animated() {
    let mut s = load(&animated("BoxAnimated.gltf")).unwrap();
    // Framed on exactly the poses rendered, tighter than the file's framing of the whole
    // animation.
    let times = [0.6, 1.875, 2.5];
    let all: Vec<_> = times.iter().flat_map(|&t| s.at(t).meshes).collect();
    s.camera = stage::framing_camera(&all);
    s.lights = vec![stage::headlight(&s.camera, DVec3::new(0.0, 1.2, 0.0), 2.0)];
    s.camera.width = 64;
    s.camera.height = 64;
    let ctx = common::gpu();
    for t in times {
        let still = s.at(t);
        let gpu = common::render_gpu(&ctx, &still);
        // Kept to look at: target/tmp/gltf_animation/box-animated-<t>.png.
        gpu.save_png(&tmp_dir().join(format!("box-animated-{t}.png"))).unwrap();
        common::assert_matches_reference(
            &format!("gltf-box-animated-{t}"),
            &gpu,
            &common::reference_image(&still),
        );
    }
}

#[test]
fn gpu_matches_the_reference_on_poses_of_an_animated_scene() {
    let mut s = load_json("golden.gltf", &kinds()).unwrap();
    s.camera.width = 64;
    s.camera.height = 48;
    let ctx = common::gpu();
    for t in [0.0, 0.75, 1.5] {
        let still = s.at(t);
        let gpu = common::render_gpu(&ctx, &still);
        common::assert_matches_reference(&format!("gltf-anim-{t}"), &gpu, &common::reference_image(&still));
    }
}
