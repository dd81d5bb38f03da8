//! The PLY reader's speed and memory (docs/ply.md, "Speed"): writes a terrain of about N
//! triangles as PLY (`irt::io::ply::write`: float x y z, with `normals` also nx ny nz, `uchar uint`
//! faces; binary little-endian unless `ascii` or `be` follows), then reads it back with
//! `irt::io::ply::parse_model` and times that. Run the two steps apart so that `/usr/bin/time -v`
//! sees the reader alone:
//!
//!     cargo build --release -p irt-tools
//!     target/release/irt-lab ply-speed write /tmp/grid.ply 10000000
//!     /usr/bin/time -v target/release/irt-lab ply-speed read /tmp/grid.ply
use irt::io::ply::{parse_model, write, Encoding};
use irt::scene::Mesh;
use std::time::Instant;

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let args: Vec<String> = args.to_vec();
    match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["write", path, triangles, ref options @ ..] => {
            let mut encoding = Encoding::BinaryLittleEndian;
            let mut normals = false;
            for o in options {
                match *o {
                    "le" => encoding = Encoding::BinaryLittleEndian,
                    "be" => encoding = Encoding::BinaryBigEndian,
                    "ascii" => encoding = Encoding::Ascii,
                    "normals" => normals = true,
                    _ => anyhow::bail!("the options are an encoding (le, be or ascii) and `normals`"),
                }
            }
            let mesh = grid(triangles.parse()?, normals);
            let start = Instant::now();
            write(&mesh, encoding, std::fs::File::create(path)?)?;
            let bytes = std::fs::metadata(path)?.len();
            println!(
                "wrote {path}: {} triangles, {} vertices, {:.1} MB in {:.2} s",
                mesh.indices.len(),
                mesh.positions.len(),
                bytes as f64 / 1e6,
                start.elapsed().as_secs_f64()
            );
        }
        ["read", path] => {
            let start = Instant::now();
            let bytes = std::fs::read(path)?;
            let read = start.elapsed().as_secs_f64();
            let parse_start = Instant::now();
            let model = parse_model(&bytes, path)?;
            let parse = parse_start.elapsed().as_secs_f64();
            let triangles: usize = model.meshes.iter().map(|m| m.indices.len()).sum();
            let vertices: usize = model.meshes.iter().map(|m| m.positions.len()).sum();
            println!(
                "{path}: {triangles} triangles, {vertices} vertices; file read {read:.2} s, parsed in {parse:.2} s \
                 ({:.0} MB/s, {:.0} ns a triangle)",
                bytes.len() as f64 / 1e6 / parse,
                parse * 1e9 / triangles as f64
            );
        }
        _ => anyhow::bail!(
            "usage: ply_speed write PATH TRIANGLES [le|be|ascii] [normals] | ply_speed read PATH"
        ),
    }
    Ok(())
}

/// irt's fractal terrain (`io::shapes::terrain`) with at least `triangles` triangles, its
/// coordinates rounded to f32 as a scan's are (so the file stores floats).
fn grid(triangles: usize, normals: bool) -> Mesh {
    let side = ((triangles as f64 / 2.0).sqrt().ceil() as u32).max(1) + 1;
    let mut mesh = irt::io::shapes::terrain(side, 1, normals).into_mesh(0);
    mesh.positions.iter_mut().for_each(|p| *p = p.as_vec3().as_dvec3());
    mesh.normals.iter_mut().flatten().for_each(|n| *n = n.as_vec3().as_dvec3());
    mesh
}
