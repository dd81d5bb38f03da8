//! `irt convert`: any scene irt loads, written as a native TOML scene.

use super::args::not_a_directory;
use super::check_output_path;
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct ConvertArgs {
    /// Scene to read (.toml, .gltf, .glb, .nff, .obj, .ply).
    pub input: PathBuf,
    /// TOML file to write (atomically); loading it gives back exactly the scene irt read. Each
    /// texture is written beside it as OUTPUT-STEM.<index>[.<name>].png (replacing such files).
    pub output: PathBuf,
}

pub fn run(args: ConvertArgs) -> Result<()> {
    if !args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
        bail!("output '{}' must be a .toml file: irt writes its native TOML format", args.output.display());
    }
    check_output_path(&args.output)?;
    not_a_directory(&args.input)?;
    let scene = irt::io::load(&args.input)?;
    // A volume's samples stay in their file, which the TOML names by its absolute path.
    if scene.volumes.iter().any(|v| v.file.is_none()) {
        bail!("'{}' holds a volume made in code, with no file for the TOML to name", args.input.display());
    }
    let stem = args.output.file_stem().map_or("scene".into(), |s| s.to_string_lossy());
    let files = irt::io::toml_write::to_files(&scene, &stem).map_err(anyhow::Error::msg)?;
    if files.toml.len() as u64 > irt::io::MAX_SCENE_FILE_BYTES {
        bail!(
            "the TOML would be {} bytes, above the {}-byte limit irt loads; keep the scene in its own format",
            files.toml.len(),
            irt::io::MAX_SCENE_FILE_BYTES
        );
    }
    // Textures first: the TOML, written last, never refers to a file that is not there yet.
    let dir = args.output.parent().unwrap_or(Path::new(""));
    for (name, png) in &files.textures {
        let path = dir.join(name);
        irt::image::write_atomic(&path, png).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    irt::image::write_atomic(&args.output, files.toml.as_bytes())
        .with_context(|| format!("writing {}", args.output.display()))?;
    eprintln!(
        "wrote {} ({} materials, {} textures, {} spheres, {} triangles, {} volumes, {} patches, {} lights)",
        args.output.display(),
        scene.materials.len(),
        scene.textures.len(),
        scene.spheres.len(),
        scene.triangle_count(),
        scene.volumes.len(),
        scene.patches.len(),
        scene.lights.len()
    );
    Ok(())
}
