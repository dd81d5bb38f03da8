//! Batch on a render farm: `irt render SCENE --tile I/N --out DIR`, one task of a job array, and
//! `irt merge DIR --out F` once every task is done (src/farm.rs; examples/slurm, examples/k8s).

use super::render::{scene_of, whole_settings, RenderArgs};
use super::{check_output_path, open_device, open_vk_device};
use anyhow::{bail, Result};
use clap::Args;
use irt::farm::{self, TileSpec, Written};
use irt::gpu::device::Backend;
use irt::gpu::device::Device;
use irt::image::OutputFormat;
use std::path::PathBuf;
use std::time::Instant;

/// `irt render --tile I/N --out DIR`.
pub fn tile(args: &RenderArgs, spec: TileSpec) -> Result<()> {
    let dir = &args.out;
    if OutputFormat::from_path(dir).is_ok() {
        bail!(
            "--tile writes tile files into a directory: --out {} names an image; give a directory, and \
             `irt merge DIR --out {}` once every tile is there",
            dir.display(),
            dir.display()
        );
    }
    let scene = scene_of(args)?;
    let mode = args.mode.mode().map_err(anyhow::Error::msg)?;
    let settings = whole_settings(args, mode);
    let key = farm::tile_key(&scene, &settings)?;
    let size = [scene.camera.width, scene.camera.height];
    let name = dir.join(farm::Tile::file_name(spec));
    // A farm retries and re-runs tasks: a finished tile is not traced again.
    if farm::tile_done(dir, spec, key, size)? {
        println!("{} is there already from this render: nothing to do", name.display());
        return Ok(());
    }
    let t = Instant::now();
    let (tile, device) = match args.backend.backend {
        Backend::Wgpu => trace(&open_device(&args.device)?, scene, settings, spec)?,
        Backend::Ash => trace(&open_vk_device(&args.device, Default::default())?, scene, settings, spec)?,
    };
    let written = farm::write_tile(dir, &tile)?;
    let [w, h] = size;
    match written {
        Written::New => println!(
            "wrote {} (rows {}..{} of {w}x{h}, {:.2} s on {device})",
            name.display(),
            tile.rows.start,
            tile.rows.end,
            t.elapsed().as_secs_f64()
        ),
        // Another task wrote the same tile meanwhile: the same pixels, kept.
        Written::AlreadyThere => println!("{} appeared meanwhile from this render: kept", name.display()),
    }
    Ok(())
}

fn trace<D: Device>(
    ctx: &D,
    scene: irt::scene::Scene,
    settings: irt::render::Settings,
    spec: TileSpec,
) -> Result<(farm::Tile, String)> {
    let bar = super::bar(0, "{spinner} tile {msg}: {pos}/{len} pixels [{bar:30}] {elapsed_precise}");
    bar.set_message(spec.to_string());
    let tile = farm::render_tile(ctx, scene, settings, spec, &mut |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    })?;
    bar.finish_and_clear();
    Ok((tile, ctx.adapter_name().to_string()))
}

#[derive(Args)]
pub struct MergeArgs {
    /// The directory the tiles were written into (`irt render SCENE --tile I/N --out DIR`).
    pub dir: PathBuf,
    /// The picture, written atomically: .png (8-bit sRGB) or .exr (linear float), the same file
    /// `irt render` writes without --tile. Nothing is written while a tile is missing.
    #[arg(long, short)]
    pub out: PathBuf,
}

/// `irt merge DIR --out F`.
pub fn merge(args: MergeArgs) -> Result<()> {
    check_output_path(&args.out)?;
    let format = OutputFormat::from_path(&args.out).map_err(anyhow::Error::msg)?;
    let image = farm::merge(&args.dir)?;
    image.save_as(&args.out, format).map_err(|e| anyhow::anyhow!("writing {}: {e}", args.out.display()))?;
    println!(
        "wrote {} ({}x{}, merged from {})",
        args.out.display(),
        image.width,
        image.height,
        args.dir.display()
    );
    Ok(())
}
