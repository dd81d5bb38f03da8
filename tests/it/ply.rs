//! PLY files: the three encodings read the same data as the same mesh; unknown elements and
//! properties are skipped in each; colours become materials by the documented rule; every class
//! of bad input gives an error at its line (header, ASCII) or byte (binary body); real files from
//! the field load and render on the GPU as the CPU reference does.
//!
//! The files here are written by a small encoder of the test's own (not `irt::io::ply::write`),
//! so that the reader is checked against an independent writer.
use crate::common;

use glam::{DVec2, DVec3};
use irt::image::srgb_to_linear;
use irt::io::ply::{parse, parse_model, write, Encoding, COLOUR_LEVELS};
use irt::io::stage::Model;
use irt::io::{LoadError, MAX_TRIANGLES, MAX_VERTICES};
use irt::scene::{MaterialKind, Mesh};
use std::path::PathBuf;

// ---- A PLY encoder for the tests ---------------------------------------------------------------

/// One value of a row, with its PLY type.
#[derive(Clone, Copy, Debug)]
pub(crate) enum V {
    I8(i8),
    U8(u8),
    I16(i16),
    U16(u16),
    I32(i32),
    U32(u32),
    F32(f32),
    F64(f64),
}

impl V {
    fn ascii(self) -> String {
        match self {
            V::I8(x) => x.to_string(),
            V::U8(x) => x.to_string(),
            V::I16(x) => x.to_string(),
            V::U16(x) => x.to_string(),
            V::I32(x) => x.to_string(),
            V::U32(x) => x.to_string(),
            V::F32(x) => x.to_string(),
            V::F64(x) => x.to_string(),
        }
    }

    fn bytes(self, big: bool) -> Vec<u8> {
        macro_rules! b {
            ($x:expr) => {
                if big {
                    $x.to_be_bytes().to_vec()
                } else {
                    $x.to_le_bytes().to_vec()
                }
            };
        }
        match self {
            V::I8(x) => b!(x),
            V::U8(x) => b!(x),
            V::I16(x) => b!(x),
            V::U16(x) => b!(x),
            V::I32(x) => b!(x),
            V::U32(x) => b!(x),
            V::F32(x) => b!(x),
            V::F64(x) => b!(x),
        }
    }
}

pub(crate) const ASCII: &str = "ascii";
pub(crate) const LE: &str = "binary_little_endian";
pub(crate) const BE: &str = "binary_big_endian";
pub(crate) const ENCODINGS: [&str; 3] = [ASCII, LE, BE];

/// A PLY file: `header` holds its element and property lines; each row is one element
/// instance (a list is its count followed by its items), one line in ASCII.
pub(crate) fn ply(format: &str, header: &str, rows: &[Vec<V>]) -> Vec<u8> {
    let mut out =
        format!("ply\nformat {format} 1.0\ncomment made by tests/ply.rs\n{header}end_header\n").into_bytes();
    for row in rows {
        if format == ASCII {
            let words: Vec<String> = row.iter().map(|v| v.ascii()).collect();
            out.extend(words.join(" ").bytes());
            out.push(b'\n');
        } else {
            row.iter().for_each(|v| out.extend(v.bytes(format == BE)));
        }
    }
    out
}

fn model(bytes: &[u8]) -> Model {
    parse_model(bytes, "test.ply").unwrap_or_else(|e| panic!("{e}"))
}

fn f(x: f32) -> V {
    V::F32(x)
}

/// A triangle list row.
fn tri(a: i32, b: i32, c: i32) -> Vec<V> {
    vec![V::U8(3), V::I32(a), V::I32(b), V::I32(c)]
}

/// Unit square (two triangles) in z = 0, as plain x y z and faces.
const PLAIN: &str = "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
                     element face 2\nproperty list uchar int vertex_indices\n";

fn plain_rows() -> Vec<Vec<V>> {
    vec![
        vec![f(0.0), f(0.0), f(0.0)],
        vec![f(1.0), f(0.0), f(0.0)],
        vec![f(1.0), f(1.0), f(0.0)],
        vec![f(0.0), f(1.0), f(0.0)],
        tri(0, 1, 2),
        tri(0, 2, 3),
    ]
}

fn square() -> Mesh {
    Mesh {
        positions: vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
        normals: None,
        uvs: None,
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: 0,
    }
}

// ---- The three encodings ---------------------------------------------------------------------

#[test]
fn the_three_encodings_give_the_same_mesh() {
    for format in ENCODINGS {
        let m = model(&ply(format, PLAIN, &plain_rows()));
        assert_eq!(m.meshes, vec![square()], "{format}");
        assert_eq!(m.materials.len(), 1);
        assert_eq!(m.materials[0].kind, MaterialKind::Diffuse { color: DVec3::splat(0.8) }, "{format}");
    }
}

/// A value of one PLY type from a small integer.
type Make = fn(i32) -> V;

/// Files written on Windows: `\r\n` line ends in the header (and in an ASCII body).
#[test]
fn crlf_line_ends_are_read() {
    for format in ENCODINGS {
        let bytes = ply(format, PLAIN, &plain_rows());
        let body = header_len(&bytes);
        let header = String::from_utf8(bytes[..body].to_vec()).unwrap().replace('\n', "\r\n");
        let rest = match format {
            ASCII => String::from_utf8(bytes[body..].to_vec()).unwrap().replace('\n', "\r\n").into_bytes(),
            _ => bytes[body..].to_vec(),
        };
        assert_eq!(model(&[header.into_bytes(), rest].concat()).meshes, vec![square()], "{format}");
    }
}

/// Every scalar type under both of its names, as coordinates and (the integer types) as list
/// count and index types.
#[test]
fn every_scalar_type_is_read_in_every_encoding() {
    let types: [(&str, &str, Make); 8] = [
        ("char", "int8", |x| V::I8(x as i8)),
        ("uchar", "uint8", |x| V::U8(x as u8)),
        ("short", "int16", |x| V::I16(x as i16)),
        ("ushort", "uint16", |x| V::U16(x as u16)),
        ("int", "int32", V::I32),
        ("uint", "uint32", |x| V::U32(x as u32)),
        ("float", "float32", |x| V::F32(x as f32)),
        ("double", "float64", |x| V::F64(x as f64)),
    ];
    for format in ENCODINGS {
        for (name, alias, make) in types {
            let integer = !name.starts_with("float") && name != "double";
            // Lists count and index in this type when it is an integer one, else uchar and int.
            let (count_type, index_type, count, index): (&str, &str, Make, Make) = if integer {
                (name, alias, make, make)
            } else {
                ("uchar", "int", |x| V::U8(x as u8), V::I32)
            };
            let header = format!(
                "element vertex 3\nproperty {name} x\nproperty {alias} y\nproperty {name} z\n\
                 element face 1\nproperty list {count_type} {index_type} vertex_indices\n"
            );
            let rows = vec![
                vec![make(0), make(0), make(7)],
                vec![make(100), make(0), make(7)],
                vec![make(0), make(100), make(7)],
                vec![count(3), index(0), index(1), index(2)],
            ];
            let m = model(&ply(format, &header, &rows));
            let want = [DVec3::new(0.0, 0.0, 7.0), DVec3::new(100.0, 0.0, 7.0), DVec3::new(0.0, 100.0, 7.0)];
            assert_eq!(m.meshes[0].positions, want, "{format} {name}");
            assert_eq!(m.meshes[0].indices, [[0, 1, 2]], "{format} {name}");
        }
    }
}

/// Float coordinates are read as floats in every encoding (the ASCII text as an f32), so all
/// three give the same bits; doubles keep theirs.
#[test]
fn float_and_double_coordinates_keep_their_bits_in_every_encoding() {
    let header = "element vertex 3\nproperty float x\nproperty double y\nproperty float z\n\
                  element face 1\nproperty list uchar uint vertex_indices\n";
    let rows = vec![
        vec![f(0.1), V::F64(0.1), f(-1e-30)],
        vec![f(1e30), V::F64(1.0 / 3.0), f(-0.0)],
        vec![f(16777217.0), V::F64(-5e-324), f(3.4028235e38)],
        vec![V::U8(3), V::U32(0), V::U32(1), V::U32(2)],
    ];
    let want = vec![
        DVec3::new(0.1f32 as f64, 0.1, -1e-30f32 as f64),
        DVec3::new(1e30f32 as f64, 1.0 / 3.0, -0.0),
        DVec3::new(16777217.0f32 as f64, -5e-324, 3.4028235e38f32 as f64),
    ];
    for format in ENCODINGS {
        let m = model(&ply(format, header, &rows));
        let bits = |v: &[DVec3]| v.iter().flat_map(|p| p.to_array().map(f64::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&m.meshes[0].positions), bits(&want), "{format}");
    }
}

/// Elements irt does not read (before, between and after), unknown scalar and list properties
/// on the vertices and the faces, and blank lines in ASCII: the mesh is the plain one.
#[test]
fn unknown_elements_and_properties_are_skipped_in_every_encoding() {
    let header = "obj_info a scanner\n\
                  element material 2\nproperty list ushort double weights\nproperty uchar id\n\
                  element vertex 4\nproperty double confidence\nproperty float x\nproperty list int short ring\n\
                  property float y\nproperty uchar flags\nproperty float z\nproperty list uchar float empty\n\
                  element edge 3\nproperty int vertex1\nproperty int vertex2\n\
                  element face 2\nproperty list uchar int texnumber\nproperty list uchar int vertex_indices\n\
                  property list uchar float texcoord\nproperty short label\n\
                  element custom 2\nproperty list uint uint stuff\n\
                  element nothing 1000000\n";
    let v = |x: f32, y: f32, z: f32| {
        vec![V::F64(0.5), f(x), V::I32(2), V::I16(-7), V::I16(300), f(y), V::U8(255), f(z), V::U8(0)]
    };
    let face = |a: i32, b: i32, c: i32| {
        let mut row = vec![V::U8(1), V::I32(9), V::U8(3), V::I32(a), V::I32(b), V::I32(c), V::U8(6)];
        row.extend([0.0, 0.5, 1.0, 0.25, 0.75, 1.0].map(f));
        row.push(V::I16(-1));
        row
    };
    let rows = vec![
        vec![V::U16(2), V::F64(1.0), V::F64(2.0), V::U8(1)],
        vec![V::U16(0), V::U8(2)],
        v(0.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(0.0, 1.0, 0.0),
        vec![V::I32(0), V::I32(1)],
        vec![V::I32(1), V::I32(2)],
        vec![V::I32(2), V::I32(3)],
        face(0, 1, 2),
        face(0, 2, 3),
        vec![V::U32(3), V::U32(1), V::U32(2), V::U32(3)],
        vec![V::U32(0)],
    ];
    for format in ENCODINGS {
        let mut bytes = ply(format, header, &rows);
        if format == ASCII {
            // Blank lines between instances mean nothing.
            let text = String::from_utf8(bytes).unwrap().replacen("end_header\n", "end_header\n\n  \n", 1);
            bytes = text.replace("\n0 1\n", "\n0 1\n\t\n").into_bytes();
        }
        assert_eq!(model(&bytes).meshes, vec![square()], "{format}");
    }
}

/// A `face` element may come before the `vertex` element.
#[test]
fn faces_before_vertices_are_read_once_the_vertices_are() {
    let header = "element face 2\nproperty list uchar int vertex_indices\n\
                  element vertex 4\nproperty float x\nproperty float y\nproperty float z\n";
    let mut rows = plain_rows();
    rows.rotate_left(4);
    for format in ENCODINGS {
        assert_eq!(model(&ply(format, header, &rows)).meshes, vec![square()], "{format}");
    }
}

/// Normals (unit length after reading), and texture coordinates under each of their names.
#[test]
fn normals_and_texture_coordinates_are_read() {
    for (u, v) in [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")] {
        let header = format!(
            "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\nproperty float {u}\nproperty float {v}\n\
             element face 1\nproperty list uchar int vertex_index\n"
        );
        let rows = vec![
            vec![f(0.0), f(0.0), f(0.0), f(0.0), f(0.0), f(2.0), f(0.0), f(0.0)],
            vec![f(1.0), f(0.0), f(0.0), f(0.0), f(3.0), f(4.0), f(1.0), f(0.0)],
            vec![f(0.0), f(1.0), f(0.0), f(0.0), f(0.0), f(1.0), f(0.25), f(0.5)],
            tri(0, 1, 2),
        ];
        for format in ENCODINGS {
            let mesh = &model(&ply(format, &header, &rows)).meshes[0];
            let n = mesh.normals.as_ref().expect("normals");
            let want = [DVec3::Z, DVec3::new(0.0, 0.6, 0.8), DVec3::Z];
            assert!(n.iter().zip(want).all(|(n, w)| (*n - w).length() < 1e-15), "{format} {u}: {n:?}");
            let uv = mesh.uvs.as_ref().expect("uvs");
            assert_eq!(uv, &[DVec2::ZERO, DVec2::X, DVec2::new(0.25, 0.5)], "{format} {u}");
        }
    }
}

#[test]
fn a_zero_normal_drops_the_normals() {
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                  property float nx\nproperty float ny\nproperty float nz\n\
                  element face 1\nproperty list uchar int vertex_indices\n";
    let n = |x: f32, y: f32, z: f32, nz: f32| vec![f(x), f(y), f(z), f(0.0), f(0.0), f(nz)];
    let rows = vec![n(0.0, 0.0, 0.0, 1.0), n(1.0, 0.0, 0.0, 0.0), n(0.0, 1.0, 0.0, 1.0), tri(0, 1, 2)];
    assert_eq!(model(&ply(LE, header, &rows)).meshes[0].normals, None);
}

/// Twice the signed area of triangle `t` seen along +z.
fn area2(p: &[DVec3], t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| p[i as usize]);
    (b - a).cross(c - a).z
}

/// Polygons go through irt's ear clipping: an L-shaped (concave) hexagon is covered exactly,
/// every triangle wound like the polygon; a fan from its first corner would not be (its
/// corner 0 sees the reflex corner from outside).
#[test]
fn concave_polygons_are_triangulated_exactly() {
    let header = "element vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
                  element face 1\nproperty list uchar int vertex_indices\n";
    // Counter-clockwise seen from +z: the 2 x 2 square without its top-right quarter (area 3);
    // the reflex corner is 4 = (1, 1).
    let corners = [(0.0, 2.0), (0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0)];
    let mut rows: Vec<Vec<V>> = corners.iter().map(|&(x, y)| vec![f(x), f(y), f(0.0)]).collect();
    rows.push(vec![V::U8(6), V::I32(0), V::I32(1), V::I32(2), V::I32(3), V::I32(4), V::I32(5)]);
    for format in ENCODINGS {
        let mesh = &model(&ply(format, header, &rows)).meshes[0];
        assert_eq!(mesh.indices.len(), 4, "{format}");
        let areas: Vec<f64> = mesh.indices.iter().map(|&t| area2(&mesh.positions, t)).collect();
        assert!(areas.iter().all(|&a| a > 0.0), "{format}: a triangle is wound the other way: {areas:?}");
        assert_eq!(areas.iter().sum::<f64>(), 6.0, "{format}: the triangles cover the polygon exactly");
    }
    // The fan from corner 0 would go outside (a negative triangle): the case is a real test.
    let fan_outside = (1..5).any(|i| {
        let p: Vec<DVec3> = corners.iter().map(|&(x, y)| DVec3::new(x as f64, y as f64, 0.0)).collect();
        area2(&p, [0, i, i + 1]) < 0.0
    });
    assert!(fan_outside);
}

/// Faces of fewer than 3 corners are skipped (with a warning); a file of nothing else has no
/// surface.
#[test]
fn faces_of_fewer_than_three_vertices_are_skipped() {
    let mut rows = plain_rows();
    rows.push(vec![V::U8(2), V::I32(0), V::I32(1)]);
    rows.push(vec![V::U8(0)]);
    let header = PLAIN.replace("face 2", "face 4");
    for format in ENCODINGS {
        assert_eq!(model(&ply(format, &header, &rows)).meshes, vec![square()], "{format}");
    }
    let rows = vec![vec![f(0.0), f(0.0), f(0.0)], vec![V::U8(1), V::I32(0)]];
    let header = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
                  element face 1\nproperty list uchar int vertex_indices\n";
    let e = parse_model(&ply(LE, header, &rows), "short.ply").unwrap_err();
    assert!(e.message.contains("no faces with 3 or more vertices"), "{e}");
}

// ---- Colours ---------------------------------------------------------------------------------

const COLOURED: &str = "element vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
                        property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n\
                        element face 2\nproperty list uchar int vertex_indices\n";

fn rgb(x: f32, y: f32, c: [u8; 3]) -> Vec<V> {
    vec![f(x), f(y), f(0.0), V::U8(c[0]), V::U8(c[1]), V::U8(c[2]), V::U8(7)]
}

fn linear(c: [f64; 3]) -> DVec3 {
    DVec3::from_array(c.map(srgb_to_linear))
}

fn diffuse(m: &Model, i: usize) -> DVec3 {
    match m.materials[i].kind {
        MaterialKind::Diffuse { color } => color,
        ref k => panic!("not diffuse: {k:?}"),
    }
}

/// Vertex colours: a face takes the mean of its corners' colours (as stored, sRGB-encoded), faces
/// are grouped by that colour quantised to 32 levels a channel, and each group is one mesh of the
/// vertices it uses with a diffuse material of the group's mean colour, decoded to linear.
#[test]
fn vertex_colours_group_faces_into_diffuse_materials() {
    let red = [200, 0, 0];
    let rows = vec![
        rgb(0.0, 0.0, red),
        rgb(1.0, 0.0, red),
        rgb(0.0, 1.0, [200, 0, 30]),
        rgb(5.0, 0.0, [0, 0, 255]),
        rgb(6.0, 0.0, [0, 0, 255]),
        rgb(5.0, 1.0, [0, 30, 255]),
        tri(0, 1, 2),
        tri(3, 4, 5),
    ];
    for format in ENCODINGS {
        let m = model(&ply(format, COLOURED, &rows));
        assert_eq!((m.meshes.len(), m.materials.len()), (2, 2), "{format}");
        // Groups in order of their colour: blue's (red level 0) first.
        assert_eq!(
            m.meshes[0].positions,
            [5.0, 6.0, 5.0]
                .iter()
                .zip([0.0, 0.0, 1.0])
                .map(|(&x, y)| DVec3::new(x, y, 0.0))
                .collect::<Vec<_>>()
        );
        assert_eq!(m.meshes[1].positions[2], DVec3::Y);
        assert_eq!(
            (m.meshes[0].indices.clone(), m.meshes[1].indices.clone()),
            (vec![[0, 1, 2]], vec![[0, 1, 2]])
        );
        assert_eq!((m.meshes[0].material, m.meshes[1].material), (0, 1));
        let mean = |a: f32, b: f32, c: f32| ((a / 255.0 + b / 255.0 + c / 255.0) / 3.0) as f64;
        let want_red = linear([mean(200.0, 200.0, 200.0), 0.0, mean(0.0, 0.0, 30.0)]);
        let want_blue = linear([0.0, mean(0.0, 0.0, 30.0), 1.0]);
        assert!((diffuse(&m, 1) - want_red).abs().max_element() < 1e-6, "{format}: {}", diffuse(&m, 1));
        assert!((diffuse(&m, 0) - want_blue).abs().max_element() < 1e-6, "{format}: {}", diffuse(&m, 0));
        assert!(m.materials[0].name != m.materials[1].name);
    }
}

/// One colour (to within a level) keeps the mesh whole: every vertex, in file order.
#[test]
fn one_colour_is_one_mesh() {
    let c = [128, 64, 32];
    let rows = vec![
        rgb(0.0, 0.0, c),
        rgb(1.0, 0.0, c),
        rgb(0.0, 1.0, c),
        rgb(9.0, 9.0, c),
        rgb(1.0, 1.0, [129, 65, 33]),
        rgb(2.0, 1.0, c),
        tri(0, 1, 2),
        tri(1, 4, 5),
    ];
    let m = model(&ply(BE, COLOURED, &rows));
    assert_eq!(m.meshes.len(), 1);
    assert_eq!(m.meshes[0].positions.len(), 6, "the unused vertex 3 is kept");
    assert_eq!(m.meshes[0].indices, [[0, 1, 2], [1, 4, 5]]);
    let want = linear([128.0 / 255.0, 64.0 / 255.0, 32.0 / 255.0]);
    // The group's mean is over both faces (one of them a little lighter).
    assert!((diffuse(&m, 0) - want).abs().max_element() < 3e-3, "{}", diffuse(&m, 0));
}

/// Face colours win over vertex colours; float colours are 0–1 and clamped to it; ushort colours
/// are scaled by 65535.
#[test]
fn face_colours_win_and_every_colour_type_is_scaled() {
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                  property ushort red\nproperty ushort green\nproperty ushort blue\n\
                  element face 2\nproperty list uchar int vertex_indices\n\
                  property float red\nproperty float green\nproperty float blue\n";
    let v = |x: f32, y: f32| vec![f(x), f(y), f(0.0), V::U16(65535), V::U16(0), V::U16(0)];
    let face = |a: i32, b: i32, c: i32, col: [f32; 3]| {
        let mut row = tri(a, b, c);
        row.extend(col.map(f));
        row
    };
    let rows = vec![
        v(0.0, 0.0),
        v(1.0, 0.0),
        v(0.0, 1.0),
        face(0, 1, 2, [0.0, 1.5, 0.0]),
        face(0, 2, 1, [0.0, 0.0, 0.5]),
    ];
    for format in ENCODINGS {
        let m = model(&ply(format, header, &rows));
        assert_eq!(m.materials.len(), 2, "{format}");
        assert_eq!(diffuse(&m, 0), linear([0.0, 0.0, 0.5]), "{format}");
        assert_eq!(diffuse(&m, 1), DVec3::Y, "{format}: 1.5 is clamped to 1");
    }
    // Vertex colours alone: ushort 65535 is 1.
    let header = header.replace("property float red\nproperty float green\nproperty float blue\n", "");
    let rows = vec![v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0), tri(0, 1, 2), tri(0, 2, 1)];
    assert_eq!(diffuse(&model(&ply(LE, &header, &rows)), 0), DVec3::X);
}

/// However many colours a file has, the groups stay within [`COLOUR_LEVELS`]³ (and so within
/// irt's material limit), and a colour a level apart is another group.
#[test]
fn colour_groups_are_bounded() {
    let n = 4096;
    let mut rows = Vec::new();
    for i in 0..n {
        let c = [(i % 256) as u8, (i / 16 % 256) as u8, (i * 7 % 256) as u8];
        rows.push(rgb(i as f32, 0.0, c));
        rows.push(rgb(i as f32, 1.0, c));
        rows.push(rgb(i as f32 + 0.5, 0.0, c));
    }
    for i in 0..n as i32 {
        rows.push(tri(3 * i, 3 * i + 1, 3 * i + 2));
    }
    let header =
        COLOURED.replace("vertex 6", &format!("vertex {}", 3 * n)).replace("face 2", &format!("face {n}"));
    let m = model(&ply(LE, &header, &rows));
    let distinct: std::collections::HashSet<[u32; 3]> = (0..n)
        .map(|i| {
            [(i % 256) as u32, (i / 16 % 256) as u32, (i * 7 % 256) as u32]
                .map(|c| c * COLOUR_LEVELS as u32 / 256)
        })
        .collect();
    assert_eq!(m.materials.len(), distinct.len());
    assert!(m.materials.len() <= COLOUR_LEVELS.pow(3));
    assert_eq!(m.meshes.iter().map(|m| m.indices.len()).sum::<usize>(), n);
}

// ---- Errors ----------------------------------------------------------------------------------

/// Asserts a header or ASCII error at the 1-based `line` and `column`, with every word.
fn fails_at(bytes: &[u8], line: usize, column: usize, words: &[&str]) -> LoadError {
    let e = parse_model(bytes, "bad.ply").expect_err("the file should be refused");
    assert_eq!((e.line, e.column), (Some(line), Some(column)), "wrong position for: {e}");
    assert!(e.to_string().starts_with(&format!("bad.ply:{line}:{column}: ")), "{e}");
    for w in words {
        assert!(e.message.contains(w), "message lacks '{w}': {e}");
    }
    e
}

/// Asserts a binary-body error at byte `offset`, with every word.
fn fails_at_byte(bytes: &[u8], offset: usize, words: &[&str]) -> LoadError {
    let e = parse_model(bytes, "bad.ply").expect_err("the file should be refused");
    assert_eq!((e.line, e.column), (None, None), "{e}");
    assert!(e.to_string().starts_with(&format!("bad.ply: at byte {offset}: ")), "{e}");
    for w in words {
        assert!(e.message.contains(w), "message lacks '{w}': {e}");
    }
    e
}

fn header_len(bytes: &[u8]) -> usize {
    let at = bytes.windows(11).position(|w| w == b"end_header\n").unwrap();
    at + 11
}

fn text(format: &str, header: &str, body: &str) -> Vec<u8> {
    format!("ply\nformat {format} 1.0\n{header}end_header\n{body}").into_bytes()
}

#[test]
fn header_errors_name_their_line_and_column() {
    fails_at(b"PLY\nformat ascii 1.0\n", 1, 1, &["not a PLY file"]);
    fails_at(b"", 1, 1, &["not a PLY file"]);
    fails_at(b"\x89PNG\r\n\x1a\n", 1, 1, &["not a PLY file"]);
    fails_at(
        b"ply\nformat binary_middle_endian 1.0\nend_header\n",
        2,
        8,
        &["unknown format `binary_middle_endian`", "ascii"],
    );
    fails_at(b"ply\nformat ascii 2.0\nend_header\n", 2, 14, &["version `2.0`", "1.0"]);
    fails_at(b"ply\nformat ascii\nend_header\n", 2, 1, &["format <encoding> 1.0"]);
    fails_at(b"ply\nformat ascii 1.0\nformat ascii 1.0\nend_header\n", 3, 1, &["second `format`", "line 2"]);
    fails_at(b"ply\nelement vertex 0\nend_header\n", 3, 1, &["no `format` line"]);
    fails_at(b"ply\nformat ascii 1.0\nelement vertex 3\n", 4, 1, &["no `end_header`"]);
    fails_at(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n\xff\xfe\x00", 4, 1, &["not text"]);
    let plain = |h: &str| text(ASCII, h, "");
    fails_at(&plain("element vertex -1\n"), 3, 16, &["`-1` is not a whole number"]);
    fails_at(&plain("element vertex 1e3\n"), 3, 16, &["`1e3`"]);
    fails_at(&plain("element vertex\n"), 3, 1, &["element <name> <count>"]);
    fails_at(&plain("property float x\n"), 3, 1, &["before any `element`"]);
    fails_at(
        &plain("element vertex 0\nproperty real x\n"),
        4,
        10,
        &["unknown property type `real`", "uint8"],
    );
    fails_at(
        &plain("element vertex 0\nproperty list float int x\n"),
        4,
        15,
        &["count must be an integer type, not float"],
    );
    fails_at(&plain("element vertex 0\nproperty list uchar x\n"), 4, 1, &["property list <count type>"]);
    fails_at(&plain("element vertex 0\nproperty float x y\n"), 4, 1, &["property <type> <name>"]);
    fails_at(
        &plain("element vertex 0\nproperty float x\nproperty double x\n"),
        5,
        1,
        &["second property `x`", "line 4"],
    );
    fails_at(&plain("element vertex 0\nelement vertex 0\n"), 4, 1, &["second element `vertex`", "line 3"]);
    fails_at(&plain("elements vertex 0\n"), 3, 1, &["unknown header line `elements`"]);
}

#[test]
fn what_irt_needs_is_checked_in_the_header() {
    let faces = "element face 0\nproperty list uchar int vertex_indices\n";
    let vertices = "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n";
    let plain = |h: &str| text(LE, h, "");
    fails_at(
        &plain(&format!("element vertex 0\nproperty float x\nproperty float z\n{faces}")),
        3,
        1,
        &["no property `y`", "x, y and z"],
    );
    fails_at(
        &plain(&format!(
            "element vertex 0\nproperty float x\nproperty float y\nproperty list uchar float z\n{faces}"
        )),
        6,
        1,
        &["`z` is a list"],
    );
    fails_at(
        &plain(&format!("{vertices}element face 0\nproperty list uchar int corners\n")),
        7,
        1,
        &["no list `vertex_indices`"],
    );
    fails_at(
        &plain(&format!("{vertices}element face 0\nproperty int vertex_indices\n")),
        8,
        1,
        &["single number", "must be a list"],
    );
    fails_at(
        &plain(&format!("{vertices}element face 0\nproperty list uchar float vertex_indices\n")),
        8,
        1,
        &["lists floats", "integers"],
    );
    // Points but no faces are particles (tests/it/particles.rs); none at all is an error at
    // the count.
    fails_at(&plain(vertices), 3, 16, &["holds no points"]);
    fails_at(&plain(faces), 5, 1, &["no `vertex` element"]);
}

/// Counts beyond irt's limits are refused from the header. A count larger than the file can
/// hold is not allocated for (the reader reserves at most what the bytes left could hold) and
/// ends where the data runs out, saying what the header declared.
#[test]
fn counts_are_checked_before_anything_is_allocated() {
    let big = "element vertex 4000000\nproperty float x\nproperty float y\nproperty float z\n\
               element face 0\nproperty list uchar int vertex_indices\n";
    let bytes = text(LE, big, "tiny");
    fails_at_byte(&bytes, bytes.len(), &["vertex 0 needs 8 more bytes", "the header declares 4000000"]);
    fails_at(
        &text(ASCII, big, "0 0 0\n"),
        11,
        1,
        &["the file ends before vertex 1; the header declares 4000000"],
    );
    let faces = "element vertex 3\nproperty char x\nproperty char y\nproperty char z\n\
                 element face 4000000\nproperty list uchar int vertex_indices\n";
    let bytes = text(BE, faces, "123456789\x03\0\0\0\0\0\0\0\x01\0\0\0\x02\x03");
    fails_at_byte(&bytes, bytes.len(), &["face 1 needs 12 more bytes"]);
    // At the limits: files large enough for the counts, refused by irt's limits.
    let n = MAX_VERTICES + 1;
    let mut bytes = text(LE, &format!("element vertex {n}\nproperty char x\nproperty char y\nproperty char z\nelement face 0\nproperty list uchar int vertex_indices\n"), "");
    bytes.resize(bytes.len() + 3 * n, 0);
    fails_at(&bytes, 3, 16, &[&format!("{n} vertices; irt's limit is {MAX_VERTICES}")]);
    let n = MAX_TRIANGLES + 1;
    let mut bytes = text(LE, &format!("element vertex 3\nproperty char x\nproperty char y\nproperty char z\nelement face {n}\nproperty list uchar int vertex_indices\n"), "");
    bytes.resize(bytes.len() + 9 + n, 0);
    fails_at(&bytes, 7, 14, &[&format!("{n} faces; irt's limit is {MAX_TRIANGLES} triangles")]);
}

#[test]
fn binary_body_errors_name_their_byte() {
    let full = ply(LE, PLAIN, &plain_rows());
    let body = header_len(&full);
    // Four vertices of 12 bytes, then faces of 13 bytes.
    let cut = |n: usize| full[..body + n].to_vec();
    fails_at_byte(
        &cut(40),
        body + 40,
        &["the file ends, and vertex 3 needs 8 more bytes", "each vertex has 12"],
    );
    fails_at_byte(&cut(48), body + 48, &["face 0 needs 1 more bytes (for vertex_indices)"]);
    fails_at_byte(&cut(48 + 13 + 6), body + 67, &["face 1 needs 7 more bytes (for vertex_indices)"]);
    let mut junk = full.clone();
    junk.extend(b"\n\0");
    fails_at_byte(&junk, full.len(), &["2 bytes follow the last element"]);
    // Index 99 in face 1 (its second index: byte 48 + 13 + 1 + 4).
    let mut bad = ply(BE, PLAIN, &plain_rows());
    let at = header_len(&bad) + 48 + 13 + 5;
    bad[at..at + 4].copy_from_slice(&99i32.to_be_bytes());
    fails_at_byte(&bad, at, &["face 1 has vertex index 99, but there are 4 vertices"]);
    bad[at..at + 4].copy_from_slice(&(-1i32).to_be_bytes());
    fails_at_byte(&bad, at, &["face 1 has vertex index -1"]);
    // A NaN and an infinite coordinate.
    for x in [f32::NAN, f32::INFINITY] {
        let mut bad = full.clone();
        let at = body + 12 * 2 + 4;
        bad[at..at + 4].copy_from_slice(&x.to_le_bytes());
        fails_at_byte(&bad, at, &["y of vertex 2 is", "must be finite"]);
    }
    // A list count past the polygon limit, and a negative one.
    let mut bad = ply(
        LE,
        &PLAIN.replace("uchar int", "int int"),
        &plain_rows()
            .into_iter()
            .map(|r| match r[0] {
                V::U8(3) => {
                    let mut r = r;
                    r[0] = V::I32(3);
                    r
                }
                _ => r,
            })
            .collect::<Vec<_>>(),
    );
    let at = header_len(&bad) + 48;
    bad[at..at + 4].copy_from_slice(&5000i32.to_le_bytes());
    fails_at_byte(&bad, at, &["face 0 has 5000 vertices", "at most 4096"]);
    bad[at..at + 4].copy_from_slice(&(-3i32).to_le_bytes());
    fails_at_byte(&bad, at, &["vertex_indices of face 0 has -3 items"]);
    // A skipped list whose count runs past the end.
    let header = format!("{PLAIN}element extra 1\nproperty list uint double values\n");
    let mut rows = plain_rows();
    rows.push(vec![V::U32(1000), V::F64(1.0)]);
    let bytes = ply(LE, &header, &rows);
    fails_at_byte(&bytes, bytes.len(), &["extra 0 needs 7992 more bytes (for values)"]);
}

#[test]
fn ascii_body_errors_name_their_line_and_column() {
    let h = PLAIN;
    let good = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
    assert_eq!(model(&text(ASCII, h, good)).meshes, vec![square()]);
    // Header: ply, format, 5 + 2 property lines, end_header: the body starts on line 10.
    let body = |b: &str| text(ASCII, h, b);
    fails_at(
        &body("0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n"),
        15,
        1,
        &["the file ends before face 1", "declares 2"],
    );
    fails_at(&body("0 0 0\n1 0\n"), 11, 4, &["the line ends before z of vertex 1"]);
    fails_at(&body("0 0 0\n1 0 0 7\n"), 11, 7, &["`7` is one value too many", "vertex 1 has 3 properties"]);
    fails_at(&body("0 0 0\n1 x 0\n"), 11, 3, &["y of vertex 1 is `x`, not a number (float)"]);
    fails_at(&body("0 0 0\n1 0 nan\n"), 11, 5, &["z of vertex 1 is NaN", "must be finite"]);
    fails_at(&body("0 0 0\n1 0 1e39\n"), 11, 5, &["z of vertex 1 is inf"]);
    fails_at(
        &body("0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 4\n"),
        15,
        7,
        &["face 1 has vertex index 4, but there are 4 vertices"],
    );
    fails_at(
        &body("0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n256 0 2 3\n"),
        15,
        1,
        &["`256`", "range 0 to 255 (uchar)"],
    );
    fails_at(
        &body("0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2.0 3\n"),
        15,
        5,
        &["`2.0`, not a whole number (int)"],
    );
    fails_at(
        &body("0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2\n"),
        15,
        6,
        &["the line ends before vertex_indices of face 1"],
    );
    fails_at(&body(&format!("{good}\n  junk\n")), 17, 3, &["data after the last element"]);
    fails_at(
        &format!("ply\nformat ascii 1.0\n{h}end_header\n0 0 \u{e9}\n").into_bytes(),
        10,
        5,
        &["z of vertex 0 is `é`"],
    );
    let mut bad = body("0 0 0\n");
    bad.push(0xff);
    fails_at(&bad, 11, 1, &["not valid UTF-8"]);
}

/// Mutated files never panic, take long or allocate by a declared count: tests/fuzz_loaders.rs
/// (`mutated_ply_scenes`). Here: a face list that claims 255 corners in a file that ends.
#[test]
fn a_list_count_past_the_end_of_an_ascii_line_is_an_error() {
    let e = fails_at(
        &text(ASCII, PLAIN, "0 0 0\n1 0 0\n1 1 0\n0 1 0\n255 0 1 2\n3 0 2 3\n"),
        14,
        10,
        &["the line ends before vertex_indices of face 0"],
    );
    assert!(e.to_string().starts_with("bad.ply:14:10: "));
}

// ---- Writing ---------------------------------------------------------------------------------

/// `write` gives a file that reads back as the same mesh, bit for bit, in each encoding; f32
/// values are written as floats, others as doubles.
#[test]
fn written_meshes_read_back_bit_for_bit() {
    let g = irt::io::shapes::icosphere(DVec3::new(0.1, -2.0, 1e-3), 1.0 / 3.0, 2);
    let mut mesh = g.into_mesh(0);
    mesh.uvs =
        Some(mesh.positions.iter().map(|p| DVec2::new(p.x as f32 as f64, p.y as f32 as f64)).collect());
    for encoding in Encoding::ALL {
        let mut bytes = Vec::new();
        write(&mesh, encoding, &mut bytes).unwrap();
        let text = String::from_utf8_lossy(&bytes[..header_len(&bytes)]).to_string();
        assert!(text.contains("property double x") && text.contains("property float u"), "{text}");
        let back = model(&bytes);
        assert_eq!(format!("{:?}", back.meshes), format!("{:?}", vec![mesh.clone()]), "{encoding:?}");
    }
}

// ---- Real files from the field ----------------------------------------------------------------

fn real(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/models").join(name)
}

fn load_real(name: &str) -> Model {
    let bytes = std::fs::read(real(name)).unwrap();
    parse_model(&bytes, name).unwrap_or_else(|e| panic!("{e}"))
}

/// Element counts as each header declares them, read without irt's loader.
fn declared(name: &str) -> (usize, usize) {
    let bytes = std::fs::read(real(name)).unwrap();
    let header = String::from_utf8_lossy(&bytes[..header_len(&bytes)]).to_string();
    let count = |e: &str| {
        header.lines().find_map(|l| l.strip_prefix(&format!("element {e} "))).unwrap().trim().parse().unwrap()
    };
    (count("vertex"), count("face"))
}

#[test]
fn real_files_load_with_their_declared_counts() {
    // (file, all faces triangles, normals, uvs, several colour groups)
    for (name, normals, uvs, coloured) in [
        ("bun_zipper_res4.ply", false, false, false),
        ("bun_zipper_res4_big_endian.ply", false, false, false),
        ("bunny_meshio.ply", false, false, false),
        ("fuze.ply", false, false, false),
        ("reference.ply", false, false, true),
        ("suzanne.ply", true, true, false),
    ] {
        let m = load_real(name);
        let (vertices, faces) = declared(name);
        let triangles: usize = m.meshes.iter().map(|m| m.indices.len()).sum();
        assert!(triangles >= faces, "{name}: {triangles} triangles from {faces} faces");
        if !coloured {
            assert_eq!(m.meshes.len(), 1, "{name}");
            assert_eq!(m.meshes[0].positions.len(), vertices, "{name}");
        }
        assert_eq!(m.meshes.iter().all(|m| m.normals.is_some()), normals, "{name}");
        assert_eq!(m.meshes.iter().all(|m| m.uvs.is_some()), uvs, "{name}");
        assert_eq!(m.materials.len() > 1, coloured, "{name}");
        assert!(parse(&std::fs::read(real(name)).unwrap(), name).is_ok());
    }
    // The bunny's faces are triangles; suzanne's are quads and triangles.
    assert_eq!(load_real("bun_zipper_res4.ply").meshes[0].indices.len(), 948);
    assert!(load_real("suzanne.ply").meshes[0].indices.len() > declared("suzanne.ply").1);
}

/// The big-endian bunny (made from the ASCII one, tests/data/models/LICENSES.md) is the same
/// mesh.
#[test]
fn the_big_endian_bunny_is_the_ascii_bunny() {
    assert_eq!(load_real("bun_zipper_res4_big_endian.ply"), load_real("bun_zipper_res4.ply"));
}

/// The fuze bottle has grey vertex colours and white face colours (its real colours are in a
/// texture, which irt does not read from PLY): the face colours win, one white material.
#[test]
fn the_fuze_bottle_takes_its_face_colours() {
    let m = load_real("fuze.ply");
    assert_eq!(m.materials.len(), 1);
    assert_eq!(diffuse(&m, 0), DVec3::ONE);
}

/// trimesh's reference object: grey with red and green vertex marks. Faces between colours take
/// their corners' mean, so there are more groups than vertex colours; each group is a mesh of
/// its own vertices, and every material is diffuse.
#[test]
fn vertex_colours_from_the_field_make_one_mesh_per_group() {
    let m = load_real("reference.ply");
    assert!(m.materials.len() > 4, "{} groups", m.materials.len());
    assert_eq!(m.meshes.len(), m.materials.len());
    assert_eq!(m.meshes.iter().map(|m| m.indices.len()).sum::<usize>(), declared("reference.ply").1);
    let grey = linear([192.0 / 255.0; 3]);
    assert!((0..m.materials.len()).any(|i| (diffuse(&m, i) - grey).abs().max_element() < 1e-6));
    for (i, mesh) in m.meshes.iter().enumerate() {
        assert_eq!(mesh.material, i as u32);
        let n = mesh.positions.len() as u32;
        assert!(mesh.indices.iter().flatten().all(|&k| k < n));
        assert!(
            mesh.indices.iter().flatten().max() == Some(&(n - 1)),
            "a mesh keeps only the vertices it uses"
        );
    }
}

fn render_check(name: &str, width: u32, height: u32) {
    let bytes = std::fs::read(real(name)).unwrap();
    let mut scene = parse(&bytes, name).unwrap_or_else(|e| panic!("{e}"));
    (scene.camera.width, scene.camera.height) = (width, height);
    let ctx = common::gpu();
    let gpu = common::render_gpu(&ctx, &scene);
    common::assert_matches_reference(&format!("ply-{name}"), &gpu, &common::reference_image(&scene));
}

/// The Stanford bunny on the default stage, GPU against the f64 reference per pixel.
#[test]
fn the_bunny_renders_as_the_reference_does() {
    render_check("bun_zipper_res4.ply", 160, 120);
}

/// Colour groups (many meshes and materials) and smooth normals, GPU against the reference.
#[test]
fn coloured_and_smooth_models_render_as_the_reference_does() {
    render_check("reference.ply", 120, 90);
    render_check("suzanne.ply", 120, 90);
}
