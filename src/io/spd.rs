//! Two of Eric Haines' Standard Procedural Databases at any size: the sphereflake (`balls`) and
//! the Sierpinski tetrahedron (`tetra`), the two whose primitive count grows without bound, so
//! irt can be measured on scenes larger than the ones in `scenes/spd/`.
//!
//! The output is NFF as SPD 3.14 writes it with `-r 1`, byte for byte: the same recursion, the
//! same f64 operations in the same order (so the same rounding) and C's `%g`. The tests hold the
//! generator to the shipped `balls_s1/s2/s4` and `tetra_s4`. Written from the generators'
//! description and the NFF the originals print (github.com/erich666/StandardProceduralDatabases).
use std::f64::consts::PI;
use std::fmt::Write;

/// A size a generator has no scene of that irt loads ([`Generator::nff`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "{} size {size} is out of range: 1 to {} (size {} has {} primitives, above what irt loads)",
    .generator.name(),
    .generator.max_size(),
    .generator.max_size() + 1,
    .generator.primitives(.generator.max_size() + 1).map_or("too many".into(), |n| n.to_string())
)]
pub struct SizeError {
    pub generator: Generator,
    pub size: u32,
}

/// A scalable SPD generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Generator {
    /// Sphereflake: a sphere with nine children, recursively; (9^(size+1) - 1) / 8 spheres on a floor.
    Balls,
    /// Sierpinski tetrahedron: 4^size triangles.
    Tetra,
}

impl Generator {
    pub fn name(self) -> &'static str {
        match self {
            Generator::Balls => "balls",
            Generator::Tetra => "tetra",
        }
    }

    /// Primitives at `size` (spheres, or triangles), floor polygon not counted; `None` past u64.
    pub fn primitives(self, size: u32) -> Option<u64> {
        match self {
            Generator::Balls => 9u64.checked_pow(size + 1).map(|n| (n - 1) / 8),
            Generator::Tetra => 4u64.checked_pow(size),
        }
    }

    /// The largest size whose scene irt loads (the loader's primitive and file-size limits).
    pub fn max_size(self) -> u32 {
        (1..64).take_while(|&s| self.fits(s)).last().unwrap_or(1)
    }

    fn fits(self, size: u32) -> bool {
        // Bytes per primitive of the NFF text, rounded up: "s x y z r" and "p 3" + 3 vertices;
        // a triangle's three vertices count against the vertex limit too (NFF shares none).
        let (limit, bytes) = match self {
            Generator::Balls => (super::MAX_SPHERES as u64, 48),
            Generator::Tetra => ((super::MAX_TRIANGLES as u64).min(super::MAX_VERTICES as u64 / 3), 100),
        };
        self.primitives(size)
            .is_some_and(|n| n <= limit && n.saturating_mul(bytes) <= super::nff::MAX_FILE_BYTES)
    }

    /// The NFF text of this database at `size` (SPD's `-s`), or why not.
    pub fn nff(self, size: u32) -> Result<String, SizeError> {
        if size == 0 || size > self.max_size() {
            return Err(SizeError { generator: self, size });
        }
        let mut out = Nff(String::new());
        match self {
            Generator::Balls => balls(&mut out, size),
            Generator::Tetra => tetra(&mut out, size),
        }
        Ok(out.0)
    }
}

type V4 = [f64; 4];
type M4 = [[f64; 4]; 4];

/// NFF output with C's `%g`.
struct Nff(String);

impl Nff {
    fn line(&mut self, tag: &str, values: &[f64]) {
        self.0.push_str(tag);
        self.0.push(' ');
        self.values(values);
    }

    fn values(&mut self, values: &[f64]) {
        for (i, &v) in values.iter().enumerate() {
            if i > 0 {
                self.0.push(' ');
            }
            push_g(&mut self.0, v);
        }
        self.0.push('\n');
    }

    fn header(&mut self, from: [f64; 3], at: [f64; 3], up: [f64; 3], hither: f64) {
        self.line("b", &[0.078, 0.361, 0.753]); // UNC sky blue, as every SPD scene
        self.0.push_str("v\n");
        self.line("from", &from);
        self.line("at", &at);
        self.line("up", &up);
        self.line("angle", &[45.0]);
        self.line("hither", &[hither]);
        self.0.push_str("resolution 512 512\n");
    }

    /// SPD's surface: its highlight angle becomes a Phong exponent (cos^n(angle) = 1/2).
    fn surface(&mut self, colour: [f64; 3], kd: f64, ks: f64, angle_deg: f64, kt: f64, ior: f64) {
        let a = PI * angle_deg / 180.0;
        let phong = if a <= 0.0 {
            100000.0
        } else if a >= PI / 2.0 {
            1.0
        } else {
            0.5f64.ln() / a.cos().ln()
        };
        self.line("f", &[colour[0], colour[1], colour[2], kd, ks, phong, kt, ior]);
    }

    fn polygon(&mut self, vertices: &[[f64; 3]]) {
        let _ = writeln!(self.0, "p {}", vertices.len());
        for v in vertices {
            self.values(v);
        }
    }
}

/// C's `printf("%g")`: six significant digits, trailing zeros dropped, scientific notation when
/// the exponent is below -4 or at least 6, at least two exponent digits. Rust's formatting and
/// glibc's both round the exact binary value to nearest, so the digits agree.
fn push_g(out: &mut String, v: f64) {
    if v == 0.0 {
        out.push_str(if v.is_sign_negative() { "-0" } else { "0" });
        return;
    }
    let sci = format!("{v:.5e}");
    let (mantissa, exp) = sci.split_once('e').expect("{:e} has an exponent");
    let exp: i32 = exp.parse().expect("{:e}'s exponent is an integer");
    let trim = |s: &str| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s.to_string()
        }
    };
    if !(-4..6).contains(&exp) {
        let sign = if exp < 0 { '-' } else { '+' };
        let _ = write!(out, "{}e{sign}{:02}", trim(mantissa), exp.abs());
    } else {
        out.push_str(&trim(&format!("{v:.*}", (5 - exp) as usize)));
    }
}

fn transform(v: V4, m: &M4) -> V4 {
    std::array::from_fn(|k| v[0] * m[0][k] + v[1] * m[1][k] + v[2] * m[2][k] + v[3] * m[3][k])
}

fn identity() -> M4 {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }))
}

/// Rotation about a coordinate axis (0 = x, 1 = y, 2 = z), row-vector convention.
fn rotate(axis: usize, angle: f64) -> M4 {
    let (c, s) = (angle.cos(), angle.sin());
    let (i, j) = [(1, 2), (2, 0), (0, 1)][axis];
    let mut m = [[0.0; 4]; 4];
    m[axis][axis] = 1.0;
    m[i][i] = c;
    m[j][j] = c;
    m[i][j] = s;
    m[j][i] = -s;
    m[3][3] = 1.0;
    m
}

/// Rotation by `angle` about the unit `axis`, row-vector convention.
fn rotate_about(a: [f64; 3], angle: f64) -> M4 {
    let (c, s) = (angle.cos(), angle.sin());
    let t = 1.0 - c;
    let sq = |x: f64| x * x;
    [
        [sq(a[0]) + (1.0 - sq(a[0])) * c, a[0] * a[1] * t + a[2] * s, a[0] * a[2] * t - a[1] * s, 0.0],
        [a[0] * a[1] * t - a[2] * s, sq(a[1]) + (1.0 - sq(a[1])) * c, a[1] * a[2] * t + a[0] * s, 0.0],
        [a[0] * a[2] * t + a[1] * s, a[1] * a[2] * t - a[0] * s, sq(a[2]) + (1.0 - sq(a[2])) * c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalise(mut v: [f64; 3]) -> [f64; 3] {
    let d = dot(v, v).sqrt();
    if d > 0.0 {
        v.iter_mut().for_each(|x| *x /= d);
    }
    v
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn xyz(v: V4) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

fn balls(out: &mut Nff, size: u32) {
    out.header([2.1, 1.3, 1.7], [0.0; 3], [0.0, 0.0, 1.0], 0.01);
    for light in [[4.0, 3.0, 2.0], [1.0, -4.0, 4.0], [-3.0, 1.0, 5.0]] {
        out.line("l", &light);
    }
    out.surface([1.0, 0.75, 0.33], 0.8, 0.0, 0.0, 0.0, 1.0);
    let (r, z) = (12.0, -0.5);
    out.polygon(&[[r, r, z], [-r, r, z], [-r, -r, z], [r, -r, z]]);
    out.surface([1.0, 0.9, 0.7], 0.5, 0.5, 37.0, 0.0, 1.0);
    flake(out, &children(), size, [0.0, 0.0, 0.0, 0.5], [0.0, 0.0, 1.0, 1.0 / 3.0]);
}

/// The nine child directions of a sphere pointing along +z: three trios, each a trio of a
/// cube's face diagonals tipped to the cube's body diagonal, turned by 0, 120 and 240 degrees.
fn children() -> [V4; 9] {
    let d = 1.0 / 2.0f64.sqrt();
    let tip = rotate_about(normalise([1.0, -1.0, 0.0]), (2.0 / 6.0f64.sqrt()).asin());
    let trio = [[d, d, 0.0, 0.0], [d, 0.0, -d, 0.0], [0.0, d, -d, 0.0]].map(|v| transform(v, &tip));
    std::array::from_fn(|i| transform(trio[i % 3], &rotate(2, (i / 3) as f64 * 2.0 * PI / 3.0)))
}

/// A sphere (`centre`, w = radius) and, `depth` levels down, its children along `dir`
/// (w = the children's radius ratio).
fn flake(out: &mut Nff, set: &[V4; 9], depth: u32, centre: V4, dir: V4) {
    out.line("s", &centre);
    if depth == 0 {
        return;
    }
    let m = if dir[2] >= 0.9999 {
        identity()
    } else if dir[2] <= -0.9999 {
        rotate(1, PI)
    } else {
        let z = [0.0, 0.0, 1.0];
        rotate_about(normalise(cross(z, xyz(dir))), dot(z, xyz(dir)).acos())
    };
    let scale = centre[3] * (1.0 + dir[3]);
    for v in set {
        let p = transform(*v, &m);
        let child = [
            p[0] * scale + centre[0],
            p[1] * scale + centre[1],
            p[2] * scale + centre[2],
            centre[3] * dir[3],
        ];
        let to = [
            (child[0] - centre[0]) / scale,
            (child[1] - centre[1]) / scale,
            (child[2] - centre[2]) / scale,
            dir[3],
        ];
        flake(out, set, depth - 1, child, to);
    }
}

fn tetra(out: &mut Nff, size: u32) {
    out.header(
        [1.022846, -3.177154, -2.174512],
        [-0.004103, -0.004103, 0.216539],
        [-0.816497, -0.816497, 0.816497],
        1.0,
    );
    out.line("l", &[2.0, -18.0, -5.0]);
    out.surface([1.0, 0.2, 0.2], 1.0, 0.0, 0.0, 0.0, 0.0);
    sierpinski(out, size, [0.0, 0.0, 0.0, 1.0]);
}

/// The corners of the cube around `c` (w = half edge) with x·y·z = +1, in SPD's order: the
/// tetrahedron inscribed in the cube.
fn corners(c: V4, half: f64) -> impl Iterator<Item = [f64; 3]> {
    let signs = [-1.0, 1.0];
    signs.into_iter().flat_map(move |x| {
        signs.into_iter().flat_map(move |y| {
            signs
                .into_iter()
                .filter(move |&z| x * y * z == 1.0)
                .map(move |z| [c[0] + x * half, c[1] + y * half, c[2] + z * half])
        })
    })
}

fn sierpinski(out: &mut Nff, depth: u32, c: V4) {
    if depth <= 1 {
        let p: Vec<[f64; 3]> = corners(c, c[3]).collect();
        // Faces (0 1 2), (3 2 1), (2 3 0), (1 0 3): each face's vertices wind outward.
        for face in 0..4 {
            let mut order = [face, (face + 1) % 4, (face + 2) % 4];
            if face % 2 == 1 {
                order.swap(0, 2);
            }
            out.polygon(&order.map(|i| p[i]));
        }
        return;
    }
    for q in corners(c, c[3] / 2.0).collect::<Vec<_>>() {
        sierpinski(out, depth - 1, [q[0], q[1], q[2], c[3] / 2.0]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_g_matches_c() {
        // Values and what glibc's printf("%g") prints for them.
        let cases: [(f64, &str); 12] = [
            (0.0, "0"),
            (-0.0, "-0"),
            (1.0, "1"),
            (0.5, "0.5"),
            (1.0 / 6.0, "0.166667"),
            (1.1102230246251565e-16, "1.11022e-16"),
            (100000.0, "100000"),
            (1234567.0, "1.23457e+06"),
            (0.0001, "0.0001"),
            (0.00001234, "1.234e-05"),
            (-0.371785, "-0.371785"),
            (9.9999996, "10"),
        ];
        for (v, want) in cases {
            let mut s = String::new();
            push_g(&mut s, v);
            assert_eq!(s, want, "%g of {v:e}");
        }
    }

    fn shipped(name: &str) -> String {
        let path = format!("{}/scenes/spd/{name}.nff", env!("CARGO_MANIFEST_DIR"));
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
    }

    #[test]
    fn generators_write_the_shipped_spd_files_byte_for_byte() {
        for (g, size) in
            [(Generator::Balls, 1), (Generator::Balls, 2), (Generator::Balls, 4), (Generator::Tetra, 4)]
        {
            let name = format!("{}_s{size}", g.name());
            let (ours, theirs) = (g.nff(size).unwrap(), shipped(&name));
            if let Some((i, (a, b))) = ours.lines().zip(theirs.lines()).enumerate().find(|(_, (a, b))| a != b)
            {
                panic!("{name}: line {} differs: ours '{a}', SPD's '{b}'", i + 1);
            }
            assert_eq!(ours.len(), theirs.len(), "{name}: same lines, different length");
        }
    }

    #[test]
    fn counts_and_limits() {
        assert_eq!(Generator::Balls.primitives(4), Some(7381));
        assert_eq!(Generator::Tetra.primitives(10), Some(1 << 20));
        // The largest sizes still load: 5 380 840 spheres, 4 194 304 triangles (size 12's 16.8M
        // triangles would have 50M vertices, past the loader's limit).
        assert_eq!(Generator::Balls.max_size(), 7);
        assert_eq!(Generator::Tetra.max_size(), 11);
        let err = Generator::Balls.nff(8).unwrap_err().to_string();
        assert!(err.contains("1 to 7") && err.contains("48427561"), "{err}");
        assert!(Generator::Tetra.nff(12).unwrap_err().to_string().contains("1 to 11"));
        assert!(Generator::Tetra.nff(0).is_err());
        let scene = crate::io::nff::parse_str(&Generator::Tetra.nff(3).unwrap(), "tetra_s3").unwrap();
        assert_eq!(scene.triangle_count(), 64);
    }
}
