// Entry point: one invocation per eye ray; eye ray, shading, hard shadows, and the reflection /
// refraction tree walked depth-first with a fixed stack.

// Rays traced by this invocation, by kind: eye, reflection, refraction, shadow.
var<private> ray_counts: vec4u;
// Loop iterations run by this invocation (see `LAVAPIPE_LOOP_LIMIT` in src/gpu/layout.rs).
var<private> loop_iters: u32;
// A slice's position of the pixel being traced (render_slice), where OUT_COMPACT puts its output.
var<private> out_slot: u32;
// 1 if this invocation's eye ray hit something (written as the output's alpha), else 0.
var<private> eye_hit: f32;
// SIMD efficiency (`Variant::simd_stats`; `irt bench --simd`), per loop of layout::SIMD_LOOPS
// (a vec4 each: there are four): the iterations this lane was active in, and (counted by one
// active lane, `simd_elect`) the iterations its SIMD group ran, masked lanes included.
var<private> simd_lanes: vec4u;
var<private> simd_groups: vec4u;

// One iteration of tracing loop `k` (a LOOP_* constant): the loop meter, and the SIMD counters
// where the variant has them. Every tracing loop calls it, so the lanes' counts sum to the meter
// (tests/simd_counters.rs); the dispatch modes' own loops (modes.wgsl) count the meter alone.
fn loop_tick(k: u32) {
    loop_iters += 1u;
    if SIMD_STATS {
        simd_lanes[k] += 1u;
        if simd_elect() {
            simd_groups[k] += 1u;
        }
    }
}

// `v` added to the 64-bit counter at stats word `at` (low word first).
fn stats_add64(at: u32, v: u32) {
    let old = atomicAdd(&stats[at], v);
    if old > 0xffffffffu - v {
        atomicAdd(&stats[at + 1u], 1u);
    }
}

struct Surface {
    p: vec3f,
    // Geometric and shading normals, both facing the incoming ray.
    ng: vec3f,
    n: vec3f,
    material: u32,
    // The ray hit the back side (for dielectrics: it is leaving the medium).
    inside: bool,
    // Magnitude of the numbers p was computed from; its rounding error is relative to this.
    scale: f32,
    // Texture coordinates (interpolated on triangles, (0, 0) on a mesh without them; spheres and
    // cones: `sphere_uv`, `cone_uv`).
    uv: vec2f,
}

fn vmax(v: vec3f) -> f32 {
    return max(max(v.x, v.y), v.z);
}

// `v` normalised, or `fallback` when `v` is zero or too small to normalise (a hit at a sphere's
// centre, a triangle that collapsed in f32): never a NaN normal.
fn unit_or(v: vec3f, fallback: vec3f) -> vec3f {
    let len2 = dot(v, v);
    if !(len2 > 1.0e-30) || len2 > 1.0e30 {
        let m = max(max(abs(v.x), abs(v.y)), abs(v.z));
        if m > 0.0 && m < 3.0e38 {
            return normalize(v / m);
        }
        return fallback;
    }
    return v * inverseSqrt(len2);
}

// The hit point is recomputed from the primitive (sphere: centre + r n; triangle: barycentrics),
// so its error is relative to the primitive's coordinates, not to the ray's origin and length:
// what the ulp-based offset below assumes.
fn surface_at(h: Hit, o: vec3f, d: vec3f) -> Surface {
    var p = o + d * h.t;
    var scale = 0.0;
    let i = prim_index(h.prim);
    var ng: vec3f;
    var n: vec3f;
    var material: u32;
    var uv = vec2f(0.0);
    if HAS_SPHERES && prim_kind(h.prim) == PRIM_SPHERE {
        let s = load_sphere(i);
        ng = unit_or(p - s.xyz, -d);
        n = ng;
        // Whichever way of computing p used smaller numbers: the centre and radius, or (for a
        // sphere much larger than the view, such as a planet-sized ground) the ray.
        let sphere_scale = vmax(abs(s.xyz)) + s.w;
        let ray_scale = vmax(abs(o)) + h.t;
        if sphere_scale <= ray_scale {
            p = s.xyz + s.w * ng;
            scale = sphere_scale;
        } else {
            scale = ray_scale;
        }
        material = sphere_material(i);
        if HAS_TEXTURES {
            uv = sphere_uv(ng);
        }
    } else if HAS_VOLUMES && prim_kind(h.prim) == PRIM_VOLUME {
        ng = unit_or(volume_normal(i, p), -d);
        n = ng;
        // p stays the ray's, as on a cone.
        scale = vmax(abs(o)) + h.t;
        material = load_volume(i).materials[u32(h.b1)];
    } else if HAS_PATCHES && prim_kind(h.prim) == PRIM_PATCH {
        let ps = patch_surface(i, vec2f(h.b1, h.b2));
        p = ps.p;
        ng = unit_or(ps.n, -d);
        n = ng;
        // Recomputed from the piece: its error is relative to the piece's numbers.
        scale = ps.size;
        material = ps.material;
        if HAS_TEXTURES {
            uv = ps.uv;
        }
    } else if HAS_CONES && prim_kind(h.prim) == PRIM_CONE {
        let c = load_cone(i);
        ng = unit_or(cone_normal(p, c.base, c.r0, c.axis, c.r1), -d);
        n = ng;
        // p stays the ray's: its error is relative to the ray's numbers.
        scale = vmax(abs(o)) + h.t;
        material = cone_material(i);
        if HAS_TEXTURES {
            uv = cone_uv(p, c.base, c.axis);
        }
    } else {
        let tri = load_triangle(i);
        p = tri.p0 + h.b1 * (tri.p1 - tri.p0) + h.b2 * (tri.p2 - tri.p0);
        scale = vmax(max(max(abs(tri.p0), abs(tri.p1)), abs(tri.p2)));
        ng = unit_or(cross(tri.p1 - tri.p0, tri.p2 - tri.p0), -d);
        n = ng;
        if tri.normals != NO_NORMALS {
            let nv = vertex_normal(tri.normals, h.b1, h.b2);
            // Normals that cancel out (opposite vertex normals) fall back to the face normal.
            if dot(nv, nv) > 0.0 {
                n = normalize(nv);
                // The vertex normals say which side is out, whatever the winding.
                ng = select(ng, -ng, dot(ng, n) < 0.0);
            }
        }
        material = tri.material;
        if HAS_TEXTURES && tri.uvs != NO_UVS {
            uv = vertex_uv(tri.uvs, h.b1, h.b2);
        }
    }
    let inside = dot(ng, d) > 0.0;
    if inside {
        ng = -ng;
        n = -n;
    }
    if dot(n, ng) < 0.0 {
        n = ng;
    }
    return Surface(p, ng, n, material, inside, scale, uv);
}

// `p` moved off the surface to the side `dir` leaves on (docs/shading.md, "Ray origins").
// Wächter & Binder (Ray Tracing Gems ch. 6): a fixed number of ulps of each coordinate (256, in
// the normal's direction), so the offset follows the point's own f32 spacing at every
// magnitude; where a coordinate is small next to the numbers the point was computed from
// (`sf.scale`: ulps of a coordinate near 0 say nothing about the error of p), an offset of
// 2^-15 of that scale instead. With scale 1 these are W&B's constants.
fn offset_origin(sf: Surface, dir: vec3f) -> vec3f {
    let p = sf.p;
    let n = select(-sf.ng, sf.ng, dot(dir, sf.ng) > 0.0);
    let of_i = vec3i(256.0 * n);
    let p_i = bitcast<vec3f>(bitcast<vec3i>(p) + select(of_i, -of_i, p < vec3f(0.0)));
    let p_f = p + (sf.scale / 32768.0) * n;
    return select(p_i, p_f, abs(p) < vec3f(sf.scale / 32.0));
}

// Emitted towards the eye at `sf` by ambient and lights, shadows included.
fn shade_local(sf: Surface, m: Material, e: vec3f) -> vec3f {
    let ia = ambient_intensity(sf.n, params.ambient_up.xyz, params.ambient_sky.xyz, params.ambient_ground.xyz);
    var c = vec3f(0.0);
    if launch.pass_range.z != 0u {
        c = shade_ambient(m, sf.n, e, ia, sf.inside);
    }
    for (var i = 0u; i < params.image.w; i++) {
        loop_tick(LOOP_LIGHTS);
        let light = params.lights[i];
        let to_light = light.position_radius.xyz - sf.p;
        let l = normalize(to_light);
        // SPD's rule: no shadow ray where the surface faces away from the light.
        if dot(sf.n, l) <= 0.0 {
            continue;
        }
        let s = light_visibility(offset_origin(sf, l), l, light);
        if s > 0.0 {
            c += s * shade_light(m, sf.n, e, l, light.color.rgb, sf.inside);
        }
    }
    return c;
}

struct PendingRay {
    o: vec3f,
    depth: u32,
    d: vec3f,
    w: vec3f,
}

// What a ray brings back from its nearest hit, its own weight not applied: the background on a
// miss, else ambient and lights at the hit; with the surface and material its reflected and
// refracted rays start from.
struct Shaded {
    c: vec3f,
    hit: bool,
    sf: Surface,
    m: Material,
    // The share of the light from the hit (and so from the rays it spawns) that the volumes
    // drawn by MIP or DVR let through to the ray's origin; c has it applied.
    veil: f32,
}

fn shade_ray(o: vec3f, d: vec3f, eye_ray: bool) -> Shaded {
    let h = trace_closest(o, d, 0.0, BIG);
    loop_tick(LOOP_RAY_TREE);
    let first_pass = launch.pass_range.z != 0u;
    // Emitted by the volumes in front of the hit: counted in the first pass alone, as ambient.
    var fog = vec4f(0.0, 0.0, 0.0, 1.0);
    if HAS_VOLUMES {
        fog = through_volumes(o, d, select(h.t, BIG, h.prim == NO_HIT));
        fog = vec4f(select(vec3f(0.0), fog.rgb, first_pass), fog.w);
    }
    if h.prim == NO_HIT {
        return Shaded(fog.rgb + fog.w * select(vec3f(0.0), params.background.rgb, first_pass), false, Surface(), Material(), fog.w);
    }
    if eye_ray {
        eye_hit = 1.0;
    }
    let sf = surface_at(h, o, d);
    var m = load_material(sf.material);
    if HAS_TEXTURES && m.texture != NO_TEXTURE {
        m.color *= sample_texture(m.texture, sf.uv);
    }
    return Shaded(fog.rgb + fog.w * shade_local(sf, m, -d), true, sf, m, fog.w);
}

// Whether the pipeline's materials can spawn reflected or refracted rays: a diffuse-only
// pipeline (a diffuse scene; the peer workload) traces the eye ray alone and has no ray stack,
// whose zero-initialisation and pushes every pixel pays on lavapipe (docs/performance.md, "No ray
// stack where no ray is spawned").
const SECONDARY_RAYS = (MATERIAL_KINDS & ~(1u << MAT_DIFFUSE)) != 0u;

fn radiance(eye: vec3f, dir: vec3f) -> vec3f {
    if !SECONDARY_RAYS {
        return shade_ray(eye, dir, true).c;
    }
    var stack: array<PendingRay, MAX_STACK>;
    var sp = 0u;
    var ray = PendingRay(eye, 1u, dir, vec3f(1.0));
    var total = vec3f(0.0);
    let max_depth = params.image.z;
    let cutoff = params.trace.x;
    loop {
        let s = shade_ray(ray.o, ray.d, ray.depth == 1u);
        total += ray.w * s.c;
        // The next ray: the refracted one where there is one, with the reflected one pushed
        // behind it, else the reflected one, else the top of the stack. The order pushing both
        // and popping the refracted one gave, with one push site instead of two and no push
        // and pop for a single child: a stack slot is a per-lane scatter or gather of 10 words.
        var has_child = false;
        var child = ray;
        if s.hit && ray.depth < max_depth {
            let sf = s.sf;
            let k = reflectance(s.m, sf.n, -ray.d, sf.inside);
            let w_s = ray.w * s.veil * k.ks;
            if max(max(w_s.x, w_s.y), w_s.z) > cutoff {
                let r = reflect_dir(ray.d, sf.n);
                child = PendingRay(offset_origin(sf, r), ray.depth + 1u, r, w_s);
                has_child = true;
                ray_counts.y += 1u;
            }
            let w_t = ray.w * s.veil * k.kt;
            if k.kt > 0.0 && max(max(w_t.x, w_t.y), w_t.z) > cutoff {
                let t = refract_dir(ray.d, sf.n, select(1.0 / s.m.eta, s.m.eta, sf.inside));
                if t.w != 0.0 {
                    if has_child {
                        stack[sp] = child;
                        sp += 1u;
                    }
                    child = PendingRay(offset_origin(sf, t.xyz), ray.depth + 1u, t.xyz, w_t);
                    has_child = true;
                    ray_counts.z += 1u;
                }
            }
        }
        if !has_child {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            child = stack[sp];
        }
        ray = child;
    }
    return total;
}

fn eye_direction(px: f32, py: f32) -> vec3f {
    let size = vec2f(params.image.xy);
    let sx = 2.0 * px / size.x - 1.0;
    let sy = 1.0 - 2.0 * py / size.y;
    return normalize(params.cam_w.xyz + sx * params.cam_u.xyz + sy * params.cam_v.xyz);
}

// Pixel (x, y)'s sample `launch.sample.x`: its ray tree traced, the output written (the first pass
// of a split bundle writes, later passes add), rays counted, and on the last pass the frame
// buffer updated as `launch.sample.y` says. Every dispatch mode (modes.wgsl) ends here, so all of
// them compute the same pixel the same way.
fn trace_pixel(x: u32, y: u32) {
    ray_counts = vec4u(1u, 0u, 0u, 0u);
    eye_hit = 0.0;
    simd_lanes = vec4u(0u);
    simd_groups = vec4u(0u);
    // One invocation per eye ray: at pixel centres, or at pixel corners (SPD's rule).
    pixel_id = y * params.eye_grid.x + x;
    bundle_seed = pixel_id + launch.sample.x * 0x9e3779b9u;
    let flags = launch.sample.y;
    let at = vec2f(f32(x), f32(y)) + select(vec2f(0.5) + launch.jitter.xy, vec2f(0.0), params.eye_grid.z != 0u);
    // One radiance call site (lavapipe runs a branch's loops even when no lane takes it, so a
    // second call for the rare jitter pairs would cost every pixel): one sample, or the paper's
    // frameless jitter, two of four sub-pixel positions (a 2×2 pattern at ±0.25 px) per visit,
    // the other two on the next visit.
    let pairs = (flags & FRAME_JITTER_PAIRS) != 0u;
    let n = select(1u, 2u, pairs);
    var c = vec3f(0.0);
    for (var k = 0u; k < n; k++) {
        let off = select(vec2f(0.0), jitter_pair(2u * (launch.sample.x & 1u) + k), pairs);
        c += radiance(params.eye.xyz, eye_direction_at(at + off));
    }
    c /= f32(n);
    // Alpha carries 2 × the loop iterations (the most of any pass) + whether the eye ray hit;
    // the renderer checks the first against lavapipe's limit and counts the second for SPD.
    let meter = f32(2u * loop_iters + u32(eye_hit));
    // The output at the pixel (less the output's base: a piece of a picture larger than the
    // buffer), or (OUT_COMPACT) at the slice position `out_slot`.
    let o = select(pixel_id - launch.sample.w, out_slot, (flags & OUT_COMPACT) != 0u);
    var total = c;
    if launch.pass_range.z != 0u {
        out_buf[o] = vec4f(c, meter);
    } else {
        let prev = out_buf[o];
        total = prev.rgb + c;
        out_buf[o] = vec4f(total, max(prev.a, meter));
        ray_counts = vec4u(0u, 0u, 0u, ray_counts.w);
    }
    if COUNT_RAYS {
        atomicAdd(&stats[0], ray_counts.x);
        atomicAdd(&stats[1], ray_counts.y);
        atomicAdd(&stats[2], ray_counts.z);
        atomicAdd(&stats[3], ray_counts.w);
    }
    if SIMD_STATS {
        for (var k = 0u; k < 4u; k++) {
            stats_add64(STATS_SIMD_AT + 4u * k, simd_lanes[k]);
            stats_add64(STATS_SIMD_AT + 4u * k + 2u, simd_groups[k]);
        }
    }
    if (flags & FRAME_WRITE) != 0u && launch.pass_range.w != 0u {
        update_frame(pixel_id, total);
    }
}

// Pixel `i` of the frame buffer gets a new value `c`: replaces it, is added to its samples
// (FRAME_ACCUMULATE; alpha counts them) or blended in with weight α (FRAME_BLEND).
fn update_frame(i: u32, c: vec3f) {
    let flags = launch.sample.y;
    let old = frame_buf[i];
    var f = vec4f(c, 1.0);
    if (flags & FRAME_ACCUMULATE) != 0u {
        f = old + f;
    } else if (flags & FRAME_BLEND) != 0u && old.a > 0.0 {
        f = vec4f(mix(old.rgb / old.a, c, launch.jitter.z), 1.0);
    }
    frame_buf[i] = f;
}

// Sub-pixel offsets of the paper's jitter pattern; visits alternate between its diagonals.
fn jitter_pair(k: u32) -> vec2f {
    let s = select(-0.25, 0.25, k == 1u || k == 2u);
    let t = select(-0.25, 0.25, k == 1u || k == 3u);
    return vec2f(s, t);
}

fn eye_direction_at(p: vec2f) -> vec3f {
    return eye_direction(p.x, p.y);
}

// The headless bands: one invocation per pixel of `launch.rect`, in tiles of RENDER_TILE_W x
// RENDER_TILE_H (layout::RENDER_TILE: 4x2-pixel SIMD groups on lavapipe). Rows of tiles are
// dealt to launch.work.x = n threads (Dispatch::dealt): lavapipe hands each of its n threads a
// contiguous run of workgroups, here one z-slice, so workgroup (x, y, z) traces tile
// (x, y·n + z) and every thread's rows spread over the whole rect instead of one thread taking
// the sky and the other the objects. No divides: lavapipe has none for vectors.
@compute @workgroup_size(RENDER_TILE_W, RENDER_TILE_H, 1)
fn render(
    @builtin(workgroup_id) wg: vec3u,
    @builtin(local_invocation_id) lid: vec3u,
) {
    let p = vec2u(wg.x, wg.y * launch.work.x + wg.z) * vec2u(RENDER_TILE_W, RENDER_TILE_H) + lid.xy;
    if p.x >= launch.rect.z || p.y >= launch.rect.w {
        return;
    }
    loop_iters = 0u;
    trace_pixel(launch.rect.x + p.x, launch.rect.y + p.y);
}
