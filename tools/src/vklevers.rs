//! The raw-Vulkan levers of the ash path, each against the default in one process, rounds
//! interleaved (so load from other processes falls on both alike): the numbers of
//! docs/backends.md, "Raw-Vulkan levers".
//!
//!     cargo run --release -p irt-tools -- vklevers robust ROUNDS SCENE...
//!     cargo run --release -p irt-tools -- vklevers push ROUNDS DISPATCHES_PER_ROUND SCENE
//!     cargo run --release -p irt-tools -- vklevers check ROUNDS
//!     cargo run --release -p irt-tools -- vklevers overrides ROUNDS
//!
//! `robust`: frame time with robustness on (default) / off, and naga's index checks on / off,
//! and whether every image is bit for bit the default's. `push`: the tile as a mapped uniform
//! (default) or as push constants: tiny-dispatch time and frame time. `check`: per pipeline, what
//! naga's SPIR-V writer, the structural check, naga's read-back check, spirv-val and pipeline
//! creation cost, over every variant of the render kernel. `overrides`: the variant switches as
//! WGSL `override`s of one module (an experiment here; irt composes `const`s), which naga 30
//! substitutes before it writes SPIR-V (no OpSpecConstant): what one parse saves per variant,
//! and whether lavapipe compiles the result any differently.

use irt::gpu::device::{Device, KernelSpec};
use irt::gpu::recording::dispatch_overhead;
use irt::gpu::shaders::{self, Program, Variant};
use irt::gpu::vk::{self, VkContext, VkDispatcher, VkOptions};
use irt::gpu::AdapterChoice;
use irt::render::{Picture, Session, Settings};
use std::time::{Duration, Instant};

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

/// The median over rounds of `a[round] / b[round]`: each ratio of two times taken moments
/// apart, so load that changes between rounds cancels.
fn paired_ratio(a: &[Duration], b: &[Duration]) -> f64 {
    let mut r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x.as_secs_f64() / y.as_secs_f64()).collect();
    r.sort_by(f64::total_cmp);
    r[r.len() / 2]
}

fn load(path: &str) -> anyhow::Result<irt::scene::Scene> {
    let p = (path != "default").then(|| std::path::PathBuf::from(path));
    let mut scene = irt::io::load_or_default(p.as_deref())?;
    (scene.camera.width, scene.camera.height) = (512, 512);
    Ok(scene)
}

fn bits(f: &Picture) -> Vec<u32> {
    f.image.pixels.iter().flatten().map(|x| x.to_bits()).collect()
}

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let lever = args.first().map(String::as_str).unwrap_or("robust");
    let rounds: usize = args.get(1).map_or(Ok(7), |a| a.parse())?;
    let choice = AdapterChoice::from_arg_or_env(None);
    let base = VkContext::new(&choice)?;
    println!("{} ({}); {rounds} rounds interleaved", base.info.name, base.info.driver_info);
    match lever {
        "robust" => {
            let cases = [
                ("robust on, index checks (default)", VkOptions::default()),
                ("robust off", VkOptions { robust: false, ..Default::default() }),
                ("index checks off", VkOptions { index_checks: false, ..Default::default() }),
                (
                    "robust off, index checks off",
                    VkOptions { robust: false, index_checks: false, ..Default::default() },
                ),
            ];
            let ctxs: Vec<VkContext> =
                cases.iter().map(|(_, o)| VkContext::with_options(&choice, *o)).collect::<Result<_, _>>()?;
            for path in &args[2..] {
                let scene = load(path)?;
                let settings = Settings { corner_rays: path.ends_with(".nff"), ..Settings::bands() };
                let mut rs: Vec<Session<VkContext>> = ctxs
                    .iter()
                    .map(|c| Session::new(c, &scene, settings.clone()))
                    .collect::<Result<_, _>>()?;
                let first: Vec<Vec<u32>> = rs
                    .iter_mut()
                    .zip(&ctxs)
                    .map(|(r, c)| r.try_picture(c, &mut |_, _| {}).map(|f| bits(&f)))
                    .collect::<Result<_, _>>()?;
                let mut times = vec![Vec::new(); rs.len()];
                // Each round starts at the next case, so no case always runs first.
                for round in 0..rounds {
                    for k in 0..rs.len() {
                        let i = (round + k) % rs.len();
                        let s = Instant::now();
                        rs[i].try_picture(&ctxs[i], &mut |_, _| {})?;
                        times[i].push(s.elapsed());
                    }
                }
                let ratios: Vec<f64> = times.iter().map(|t| paired_ratio(t, &times[0])).collect();
                let m: Vec<f64> = times.into_iter().map(median).collect();
                println!("scene {path} at 512x512: case, frame median (ms), median of the rounds' ratios to the default, image");
                for (i, (name, _)) in cases.iter().enumerate() {
                    println!(
                        "| {path} | {name} | {:.1} | {:.3} | {} |",
                        m[i],
                        ratios[i],
                        if first[i] == first[0] { "identical" } else { "DIFFERENT" }
                    );
                }
            }
        }
        "push" => {
            let per_round: u32 = args.get(2).map_or(Ok(300), |a| a.parse())?;
            let path = args.get(3).map_or("default", String::as_str);
            let cases = [
                ("tile in a mapped uniform (default)", VkOptions::default()),
                ("tile in push constants", VkOptions { push_tile: true, ..Default::default() }),
            ];
            let ctxs: Vec<VkContext> =
                cases.iter().map(|(_, o)| VkContext::with_options(&choice, *o)).collect::<Result<_, _>>()?;
            let scene = load(path)?;
            let mut rs: Vec<Session<VkContext>> =
                ctxs.iter().map(|c| Session::new(c, &scene, Settings::bands())).collect::<Result<_, _>>()?;
            let first: Vec<Vec<u32>> = rs
                .iter_mut()
                .zip(&ctxs)
                .map(|(r, c)| r.try_picture(c, &mut |_, _| {}).map(|f| bits(&f)))
                .collect::<Result<_, _>>()?;
            let input = [[0.5f32, 0.04, 1.5, 0.0]];
            let ds: Vec<VkDispatcher> = ctxs
                .iter()
                .zip(&rs)
                .map(|(c, r)| c.compile(r.device_scene(), KernelSpec::tests(&input, 1)))
                .collect::<Result<_, _>>()?;
            let (mut frame, mut tiny) = (vec![Vec::new(); 2], vec![Vec::new(); 2]);
            for round in 0..rounds {
                for k in 0..2 {
                    let i = (round + k) % 2;
                    let s = Instant::now();
                    rs[i].try_picture(&ctxs[i], &mut |_, _| {})?;
                    frame[i].push(s.elapsed());
                    tiny[i].push(dispatch_overhead(&ctxs[i].bind(&ds[i]), "k_fresnel", per_round)?);
                }
            }
            let (fr, tr): (Vec<f64>, Vec<f64>) = (
                frame.iter().map(|f| paired_ratio(f, &frame[0])).collect(),
                tiny.iter().map(|t| paired_ratio(t, &tiny[0])).collect(),
            );
            let (f, t): (Vec<f64>, Vec<f64>) =
                (frame.into_iter().map(median).collect(), tiny.into_iter().map(median).collect());
            println!(
                "scene {path} at 512x512; {per_round} tiny dispatches a round (median), median of rounds: \
                 tiny dispatch (µs), its paired ratio, frame (ms), its paired ratio, image"
            );
            for (i, (name, _)) in cases.iter().enumerate() {
                println!(
                    "| {name} | {:.2} | {:.3} | {:.1} | {:.3} | {} |",
                    t[i] * 1e3,
                    tr[i],
                    f[i],
                    fr[i],
                    if first[i] == first[0] { "identical" } else { "DIFFERENT" }
                );
            }
        }
        "check" | "check-noindex" => {
            let base = if lever == "check" {
                base
            } else {
                VkContext::with_options(&choice, VkOptions { index_checks: false, ..Default::default() })?
            };
            let options = vk::spv_options(&base);
            let variants = Variant::all();
            let names = [
                "naga writes SPIR-V",
                "structural check",
                "naga read-back",
                "spirv-val",
                "pipeline creation",
            ];
            let mut t = vec![Vec::new(); names.len()];
            let mut words_total = 0usize;
            for round in 0..rounds {
                for v in &variants {
                    let src = shaders::compose(Program::Render, *v);
                    let (module, info) = shaders::validate(&src).map_err(anyhow::Error::msg)?;
                    let s = Instant::now();
                    let words = vk::compile_entry(&module, &info, "render", &options)?;
                    t[0].push(s.elapsed());
                    let s = Instant::now();
                    vk::check_spirv(&words, "render")?;
                    t[1].push(s.elapsed());
                    let s = Instant::now();
                    vk::naga_check(&words, "render")?;
                    t[2].push(s.elapsed());
                    let s = Instant::now();
                    let ran = vk::spirv_val_check(&words, "render")?;
                    t[3].push(s.elapsed());
                    anyhow::ensure!(ran, "spirv-val is not installed");
                    let s = Instant::now();
                    base.try_pipeline(&words, "render")?;
                    t[4].push(s.elapsed());
                    if round == 0 {
                        words_total += words.len();
                    }
                }
            }
            println!(
                "render kernel, {} variants x {rounds} rounds; mean module {} words; medians per pipeline (ms):",
                variants.len(),
                words_total / variants.len()
            );
            for (name, v) in names.iter().zip(t) {
                println!("| {name} | {:.3} |", median(v));
            }
        }
        "overrides" => overrides(&base, rounds)?,
        other => anyhow::bail!("unknown lever {other:?}: robust, push, check or overrides"),
    }
    Ok(())
}

/// The variant switches of the prelude as WGSL `override`s (type-level switches, `real` and
/// the layered texture, stay `const`).
const SWITCHES: [&str; 8] = [
    "HAS_SPHERES",
    "HAS_TRIANGLES",
    "HAS_CONES",
    "COUNT_RAYS",
    "HAS_TEXTURES",
    "SHELL_WALK",
    "SHADOW_MODE",
    "MATERIAL_KINDS",
];

fn override_values(v: &Variant) -> naga::back::PipelineConstants {
    let b = |x: bool| x as u32 as f64;
    let values = [
        b(v.spheres),
        b(v.triangles),
        b(v.cones),
        b(v.count_rays),
        b(v.textures),
        b(v.shell_walk),
        v.shadows as f64,
        v.materials as f64,
    ];
    SWITCHES.iter().zip(values).map(|(n, x)| (n.to_string(), x)).collect()
}

fn overrides(ctx: &VkContext, rounds: usize) -> anyhow::Result<()> {
    let mut src = shaders::compose(Program::Render, Variant::FULL);
    for name in SWITCHES {
        let start = src.find(&format!("const {name}: ")).expect(name);
        let end = start + src[start..].find(';').expect(name);
        let ty = if name == "SHADOW_MODE" || name == "MATERIAL_KINDS" { "u32" } else { "bool" };
        src.replace_range(start..=end, &format!("override {name}: {ty};"));
    }
    let options = vk::spv_options(ctx);
    let variants: Vec<Variant> = Variant::all().into_iter().filter(|v| !v.layered && !v.f64).collect();
    let (mut parse_once, mut composed, mut overridden, mut pipe_c, mut pipe_o) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut words_c, mut words_o, mut same) = (0usize, 0usize, 0usize);
    let stage = naga::ShaderStage::Compute;
    let pipeline = naga::back::spv::PipelineOptions { entry_point: "render".into(), shader_stage: stage };
    for round in 0..rounds {
        let s = Instant::now();
        let (module, info) = shaders::validate(&src).map_err(anyhow::Error::msg)?;
        parse_once.push(s.elapsed());
        for v in &variants {
            let s = Instant::now();
            let (m, i) =
                shaders::validate(&shaders::compose(Program::Render, *v)).map_err(anyhow::Error::msg)?;
            let wc = vk::compile_entry(&m, &i, "render", &options)?;
            composed.push(s.elapsed());
            let s = Instant::now();
            let (m, i) = naga::back::pipeline_constants::process_overrides(
                &module,
                &info,
                Some((stage, "render")),
                &override_values(v),
            )?;
            let wo = naga::back::spv::write_vec(&m, &i, &options, Some(&pipeline))?;
            overridden.push(s.elapsed());
            vk::check_spirv(&wo, "render")?;
            let s = Instant::now();
            ctx.try_pipeline(&wc, "render")?;
            pipe_c.push(s.elapsed());
            let s = Instant::now();
            ctx.try_pipeline(&wo, "render")?;
            pipe_o.push(s.elapsed());
            if round == 0 {
                (words_c, words_o) = (words_c + wc.len(), words_o + wo.len());
                same += (wc == wo) as usize;
            }
        }
    }
    let n = variants.len();
    println!("render kernel, {n} variants (not layered, f32) x {rounds} rounds; medians (ms)");
    println!("| parse + validate the override module, once | {:.2} |", median(parse_once));
    println!(
        "| per variant: compose + parse + validate + write (composed consts) | {:.2} |",
        median(composed)
    );
    println!("| per variant: process_overrides + write (one override module) | {:.2} |", median(overridden));
    println!("| lavapipe pipeline creation, composed SPIR-V | {:.1} |", median(pipe_c));
    println!("| lavapipe pipeline creation, override SPIR-V | {:.1} |", median(pipe_o));
    println!(
        "mean words: composed {}, overrides {}; identical words in {same} of {n}",
        words_c / n,
        words_o / n
    );
    Ok(())
}
