// Entry point: one invocation per eye ray; eye ray, shading, hard shadows, and the reflection /
// refraction tree walked depth-first with a fixed stack.

// Rays traced by this invocation, by kind: eye, reflection, refraction, shadow.
var<private> ray_counts: vec4u;
// 1 if this invocation's eye ray hit something (written as the output's alpha), else 0.
var<private> eye_hit: f32;

struct Surface {
    p: vec3f,
    // Geometric and shading normals, both facing the incoming ray.
    ng: vec3f,
    n: vec3f,
    material: u32,
    // The ray hit the back side (for dielectrics: it is leaving the medium).
    inside: bool,
}

fn surface_at(h: Hit, o: vec3f, d: vec3f) -> Surface {
    let p = o + d * h.t;
    let i = prim_index(h.prim);
    var ng: vec3f;
    var n: vec3f;
    var material: u32;
    if HAS_SPHERES && prim_kind(h.prim) == PRIM_SPHERE {
        let s = load_sphere(i);
        ng = normalize(p - s.xyz);
        n = ng;
        material = sphere_material(i);
    } else if HAS_CONES && prim_kind(h.prim) == PRIM_CONE {
        let c = load_cone(i);
        ng = cone_normal(p, c.base, c.r0, c.axis, c.r1);
        n = ng;
        material = cone_material(i);
    } else {
        let tri = load_triangle(i);
        ng = normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0));
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
    }
    let inside = dot(ng, d) > 0.0;
    if inside {
        ng = -ng;
        n = -n;
    }
    if dot(n, ng) < 0.0 {
        n = ng;
    }
    return Surface(p, ng, n, material, inside);
}

// `p` moved off the surface to the side `dir` leaves on (docs/shading.md, "Ray origins").
fn offset_origin(p: vec3f, ng: vec3f, dir: vec3f) -> vec3f {
    let a = abs(p);
    let scale = params.trace.y * max(1.0, max(max(a.x, a.y), a.z));
    return p + select(-ng, ng, dot(dir, ng) > 0.0) * scale;
}

// Emitted towards the eye at `sf` by ambient and lights, shadows included.
fn shade_local(sf: Surface, m: Material, e: vec3f) -> vec3f {
    let ia = ambient_intensity(sf.n, params.ambient_up.xyz, params.ambient_sky.xyz, params.ambient_ground.xyz);
    var c = shade_ambient(m, sf.n, e, ia, sf.inside);
    for (var i = 0u; i < params.image.w; i++) {
        let light = params.lights[i];
        let to_light = light.position_radius.xyz - sf.p;
        let l = normalize(to_light);
        // SPD's rule: no shadow ray where the surface faces away from the light.
        if dot(sf.n, l) <= 0.0 {
            continue;
        }
        let s = light_visibility(offset_origin(sf.p, sf.ng, l), l, light);
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

fn radiance(eye: vec3f, dir: vec3f) -> vec3f {
    var stack: array<PendingRay, MAX_STACK>;
    var sp = 0u;
    var ray = PendingRay(eye, 1u, dir, vec3f(1.0));
    var total = vec3f(0.0);
    let max_depth = params.image.z;
    let cutoff = params.trace.x;
    loop {
        let h = trace_closest(ray.o, ray.d, 0.0, BIG);
        if ray.depth == 1u && h.prim != NO_HIT {
            eye_hit = 1.0;
        }
        if h.prim == NO_HIT {
            total += ray.w * params.background.rgb;
        } else {
            let sf = surface_at(h, ray.o, ray.d);
            let m = load_material(sf.material);
            let e = -ray.d;
            total += ray.w * shade_local(sf, m, e);
            if ray.depth < max_depth {
                let k = reflectance(m, sf.n, e, sf.inside);
                let w_s = ray.w * k.ks;
                if max(max(w_s.x, w_s.y), w_s.z) > cutoff {
                    let r = reflect_dir(ray.d, sf.n);
                    stack[sp] = PendingRay(offset_origin(sf.p, sf.ng, r), ray.depth + 1u, r, w_s);
                    sp += 1u;
                    ray_counts.y += 1u;
                }
                let w_t = ray.w * k.kt;
                if k.kt > 0.0 && max(max(w_t.x, w_t.y), w_t.z) > cutoff {
                    let t = refract_dir(ray.d, sf.n, select(1.0 / m.eta, m.eta, sf.inside));
                    if t.w != 0.0 {
                        stack[sp] = PendingRay(offset_origin(sf.p, sf.ng, t.xyz), ray.depth + 1u, t.xyz, w_t);
                        sp += 1u;
                        ray_counts.z += 1u;
                    }
                }
            }
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        ray = stack[sp];
    }
    return total;
}

fn eye_direction(px: f32, py: f32) -> vec3f {
    let size = vec2f(params.image.xy);
    let sx = 2.0 * px / size.x - 1.0;
    let sy = 1.0 - 2.0 * py / size.y;
    return normalize(params.cam_w.xyz + sx * params.cam_u.xyz + sy * params.cam_v.xyz);
}

@compute @workgroup_size(8, 8, 1)
fn render(@builtin(global_invocation_id) gid: vec3u) {
    if gid.x >= tile.rect.z || gid.y >= tile.rect.w {
        return;
    }
    let x = tile.rect.x + gid.x;
    let y = tile.rect.y + gid.y;
    ray_counts = vec4u(1u, 0u, 0u, 0u);
    eye_hit = 0.0;
    // One invocation per eye ray: at pixel centres, or at pixel corners (SPD's rule).
    pixel_id = y * params.eye_grid.x + x;
    let offset = select(0.5, 0.0, params.eye_grid.z != 0u);
    let c = radiance(params.eye.xyz, eye_direction(f32(x) + offset, f32(y) + offset));
    out_buf[pixel_id] = vec4f(c, eye_hit);
    if COUNT_RAYS {
        atomicAdd(&stats[0], ray_counts.x);
        atomicAdd(&stats[1], ray_counts.y);
        atomicAdd(&stats[2], ray_counts.z);
        atomicAdd(&stats[3], ray_counts.w);
    }
}
