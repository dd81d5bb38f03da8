// Readback kernels: each calls one shader function on inputs from `test_in` and writes the
// result to `out_buf`; the tests compare them with the f64 twins in src/reference. Item i reads
// STRIDE vec4s from test_in[STRIDE * i]. An entry point is one line over the items of its
// dispatch (`launch.rect.z` of them, `gpu::recording::Dispatch::readback`), calling its body.

// The i-th (o, d) pair of test_in: the ray's origin and direction.
fn test_ray(i: u32) -> array<vec3f, 2> {
    return array<vec3f, 2>(test_in[2u * i].xyz, test_in[2u * i + 1u].xyz);
}

// in: (o, t_min), (d, t_max), (c, r), anchor -> (t, 0, 0, 0)
@compute @workgroup_size(64, 1, 1)
fn k_sphere(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_sphere(g.x); } }
fn t_sphere(i: u32) {
    let a = test_in[4u * i];
    let b = test_in[4u * i + 1u];
    let c = test_in[4u * i + 2u];
    let anchor = test_in[4u * i + 3u].xyz;
    out_buf[i] = vec4f(intersect_sphere(a.xyz, b.xyz, c.xyz, c.w, anchor, a.w, b.w), 0.0, 0.0, 0.0);
}

// in: (o, t_min), (d, t_max), p0, p1, p2 -> (t, b1, b2, 0)
@compute @workgroup_size(64, 1, 1)
fn k_triangle(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_triangle(g.x); } }
fn t_triangle(i: u32) {
    let a = test_in[5u * i];
    let b = test_in[5u * i + 1u];
    let r = intersect_triangle(a.xyz, b.xyz, test_in[5u * i + 2u].xyz, test_in[5u * i + 3u].xyz,
        test_in[5u * i + 4u].xyz, a.w, b.w);
    out_buf[i] = vec4f(r, 0.0);
}

// in: (o, t_min), (d, t_max), (base, r0), (axis, r1) -> (t, cone_normal at o + t d)
@compute @workgroup_size(64, 1, 1)
fn k_cone(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_cone(g.x); } }
fn t_cone(i: u32) {
    let a = test_in[4u * i];
    let b = test_in[4u * i + 1u];
    let c = test_in[4u * i + 2u];
    let e = test_in[4u * i + 3u];
    let t = intersect_cone(a.xyz, b.xyz, c.xyz, c.w, e.xyz, e.w, a.w, b.w);
    var n = vec3f(0.0);
    if t != MISS {
        n = cone_normal(a.xyz + t * b.xyz, c.xyz, c.w, e.xyz, e.w);
    }
    out_buf[i] = vec4f(t, n);
}

// in: (cos, r0, eta, inside) -> (schlick, dielectric_reflectance, 0, 0)
@compute @workgroup_size(64, 1, 1)
fn k_fresnel(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_fresnel(g.x); } }
fn t_fresnel(i: u32) {
    let a = test_in[i];
    out_buf[i] = vec4f(schlick(a.x, a.y), dielectric_reflectance(a.x, a.z, a.w != 0.0), 0.0, 0.0);
}

// in: (d, _), (n, eta_ratio) -> (refracted, ok); out[n + i]: reflected
@compute @workgroup_size(64, 1, 1)
fn k_refract(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_refract(g.x); } }
fn t_refract(i: u32) {
    let d = test_in[2u * i].xyz;
    let n = test_in[2u * i + 1u];
    out_buf[2u * i] = refract_dir(d, n.xyz, n.w);
    out_buf[2u * i + 1u] = vec4f(reflect_dir(d, n.xyz), 0.0);
}

// in: n, up, sky, ground -> I_a
@compute @workgroup_size(64, 1, 1)
fn k_ambient(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_ambient(g.x); } }
fn t_ambient(i: u32) {
    let b = 4u * i;
    out_buf[i] = vec4f(ambient_intensity(test_in[b].xyz, test_in[b + 1u].xyz, test_in[b + 2u].xyz, test_in[b + 3u].xyz), 0.0);
}

// in: (colour, kind), (eta, exponent, inside, _), n, e, l, l_e, ia
// -> shade_ambient, shade_light, (k_s, k_t)
@compute @workgroup_size(64, 1, 1)
fn k_shade(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_shade(g.x); } }
fn t_shade(i: u32) {
    let b = 7u * i;
    let a = test_in[b];
    let p = test_in[b + 1u];
    let m = Material(a.xyz, u32(a.w), p.x, p.y, NO_TEXTURE);
    let inside = p.z != 0.0;
    let n = test_in[b + 2u].xyz;
    let e = test_in[b + 3u].xyz;
    let l = test_in[b + 4u].xyz;
    let k = reflectance(m, n, e, inside);
    out_buf[3u * i] = vec4f(shade_ambient(m, n, e, test_in[b + 6u].xyz, inside), 0.0);
    out_buf[3u * i + 1u] = vec4f(shade_light(m, n, e, l, test_in[b + 5u].xyz, inside), 0.0);
    out_buf[3u * i + 2u] = vec4f(k.ks, k.kt);
}

const DDA_MAX_CELLS: u32 = 64u;

// in: (o, t_min), (d, t_max) -> up to DDA_MAX_CELLS (x, y, z, t_exit) of the cells visited in
// order, then (-1, -1, -1, -1).
@compute @workgroup_size(64, 1, 1)
fn k_dda(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_dda(g.x); } }
fn t_dda(i: u32) {
    let a = test_in[2u * i];
    let b = test_in[2u * i + 1u];
    var s: Dda;
    var k = 0u;
    if dda_init(a.xyz, b.xyz, a.w, b.w, &s) {
        loop {
            out_buf[DDA_MAX_CELLS * i + k] = vec4f(vec3f(s.cell), f32(dda_cell_exit(&s)));
            k += 1u;
            if k == DDA_MAX_CELLS || !dda_step(&s) {
                break;
            }
        }
    }
    if k < DDA_MAX_CELLS {
        out_buf[DDA_MAX_CELLS * i + k] = vec4f(-1.0);
    }
}

// in: (o, t_min), (d, t_max) -> (t, prim ref bits, b1, b2) of the nearest hit through the grid;
// prim = NO_HIT on a miss.
@compute @workgroup_size(64, 1, 1)
fn k_trace(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_trace(g.x); } }
fn t_trace(i: u32) {
    let a = test_in[2u * i];
    let b = test_in[2u * i + 1u];
    let h = trace_closest(a.xyz, b.xyz, a.w, b.w);
    out_buf[i] = vec4f(h.t, bitcast<f32>(h.prim), h.b1, h.b2);
}

// in: (o, dist), (l, light_r), (a, falloff), (b, radius), (c, inside 1/0)
// -> (falloff(f, radius) [radius read as tau], sphere_shell(centre a, radius), triangle_shell(a b c, inside),
//     segment_distance(o, l, dist, a, b)) as (σ, t) pairs
@compute @workgroup_size(64, 1, 1)
fn k_shell(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_shell(g.x); } }
fn t_shell(i: u32) {
    let o = test_in[5u * i];
    let l = test_in[5u * i + 1u];
    let a = test_in[5u * i + 2u];
    let b = test_in[5u * i + 3u];
    let c = test_in[5u * i + 4u];
    let f = u32(a.w);
    let sphere = sphere_shell(f, o.xyz, l.xyz, o.w, l.w, a.xyz, b.w);
    let tri = triangle_shell(f, o.xyz, l.xyz, o.w, l.w, c.w != 0.0, a.xyz, b.xyz, c.xyz);
    out_buf[2u * i] = vec4f(falloff(f, b.w), 0.0, sphere);
    out_buf[2u * i + 1u] = vec4f(tri, segment_distance(o.xyz, l.xyz, o.w, a.xyz, b.xyz));
}

// in: (o, light index), (l = unit direction to the light's centre, pixel) -> (s, 0, 0, 0) of
// `light_visibility` in the pipeline's shadow mode.
@compute @workgroup_size(64, 1, 1)
fn k_visibility(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_visibility(g.x); } }
fn t_visibility(i: u32) {
    let a = test_in[2u * i];
    let b = test_in[2u * i + 1u];
    pixel_id = u32(b.w);
    bundle_seed = pixel_id;
    out_buf[i] = vec4f(light_visibility(a.xyz, b.xyz, params.lights[u32(a.w)]), 0.0, 0.0, 0.0);
}

// in: (o, _), (d, _) -> (hit 1/0, n_g·l, s, 0): the eye ray's nearest hit, then the first
// light's visibility from the offset origin there (self-shadowing tests).
@compute @workgroup_size(64, 1, 1)
fn k_acne(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_acne(g.x); } }
fn t_acne(i: u32) {
    let r = test_ray(i);
    let o = r[0];
    let d = r[1];
    let h = trace_closest(o, d, 0.0, BIG);
    if h.prim == NO_HIT {
        out_buf[i] = vec4f(0.0);
        return;
    }
    let sf = surface_at(h, o, d);
    let light = params.lights[0];
    let l = normalize(light.position_radius.xyz - sf.p);
    let s = light_visibility(offset_origin(sf, l), l, light);
    out_buf[i] = vec4f(1.0, dot(sf.ng, l), s, 0.0);
}

// in: (o, dist), (l, light_r), (base, r0), (axis, r1), (falloff, _, _, _) -> (σ, t, 0, 0) of cone_shell
@compute @workgroup_size(64, 1, 1)
fn k_cone_shell(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_cone_shell(g.x); } }
fn t_cone_shell(i: u32) {
    let o = test_in[5u * i];
    let l = test_in[5u * i + 1u];
    let c = test_in[5u * i + 2u];
    let e = test_in[5u * i + 3u];
    let f = u32(test_in[5u * i + 4u].x);
    out_buf[i] = vec4f(cone_shell(f, o.xyz, l.xyz, o.w, l.w, c.xyz, c.w, e.xyz, e.w), 0.0, 0.0);
}

// in: (u, v, texture, _) -> (rgb, 0) of sample_texture
@compute @workgroup_size(64, 1, 1)
fn k_texture(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_texture(g.x); } }
fn t_texture(i: u32) {
    let a = test_in[i];
    out_buf[i] = vec4f(sample_texture(u32(a.z), a.xy), 0.0);
}

// in: o, d -> (1 if hit, uv, 0) of surface_at: texture coordinates interpolated at a hit
@compute @workgroup_size(64, 1, 1)
fn k_surface_uv(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_surface_uv(g.x); } }
fn t_surface_uv(i: u32) {
    let r = test_ray(i);
    let h = trace_closest(r[0], r[1], 0.0, BIG);
    out_buf[i] = select(vec4f(1.0, surface_at(h, r[0], r[1]).uv, 0.0), vec4f(0.0), h.prim == NO_HIT);
}

// in: (d, cells per face side) -> (shell_cell(d, n) as f32 bits, 0, 0, 0)
@compute @workgroup_size(64, 1, 1)
fn k_shell_cell(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_shell_cell(g.x); } }
fn t_shell_cell(i: u32) {
    out_buf[i] = vec4f(bitcast<f32>(shell_cell(test_in[i].xyz, u32(test_in[i].w))), 0.0, 0.0, 0.0);
}

// in: (segment length, slab count, near, 1 / log2(ratio)) -> (shell_slab as f32 bits, 0, 0, 0)
@compute @workgroup_size(64, 1, 1)
fn k_shell_slab(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_shell_slab(g.x); } }
fn t_shell_slab(i: u32) {
    let v = test_in[i];
    let slabs = vec4u(u32(v.y), bitcast<u32>(v.z), bitcast<u32>(v.w), 0u);
    out_buf[i] = vec4f(bitcast<f32>(shell_slab(v.x, slabs)), 0.0, 0.0, 0.0);
}

// in: (node index, 0, 0, 0) -> (lo, link bits), (hi, 0): a compact BVH node of the uploaded
// scene as the stackless walk decodes it (a scene packed for `--accel bvh`).
@compute @workgroup_size(64, 1, 1)
fn k_bvh_qnode(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_bvh_qnode(g.x); } }
fn t_bvh_qnode(i: u32) {
    let n = bvh_qnode(texel(params.accel_base.x + bitcast<u32>(test_in[i].x)), params.accel_min.xyz, params.cell.xyz);
    out_buf[2u * i] = vec4f(n.lo, bitcast<f32>(n.a));
    out_buf[2u * i + 1u] = vec4f(n.hi, 0.0);
}

// in: corners 0..3, corners 4..7, (a, iso), (b, 0) -> (s by cell_hit, s by the closed form, 0, 0)
@compute @workgroup_size(64, 1, 1)
fn k_cell_hit(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_cell_hit(g.x); } }
fn t_cell_hit(i: u32) {
    let a = test_in[4u * i + 2u];
    let s = cell_hit(test_in[4u * i], test_in[4u * i + 1u], a.xyz, test_in[4u * i + 3u].xyz, a.w);
    let closed = cell_hit_closed_form(test_in[4u * i], test_in[4u * i + 1u], a.xyz, test_in[4u * i + 3u].xyz, a.w);
    out_buf[i] = vec4f(s, closed, 0.0, 0.0);
}

// in: (i, j, k, 0) as u32 -> (sample (i, j, k) of volume 0, 0, 0, 0): its samples as the
// brick layout stores them, decoded.
@compute @workgroup_size(64, 1, 1)
fn k_volume_sample(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_volume_sample(g.x); } }
fn t_volume_sample(i: u32) {
    out_buf[i] = vec4f(volume_sample(load_volume(0u), bitcast<vec3u>(test_in[i].xyz)), 0.0, 0.0, 0.0);
}

// in: (o, t_min), (d, t_max) -> (t or MISS, which isovalue, 0, 0): volume 0's macrocell walk
// alone, in its isosurface look.
@compute @workgroup_size(64, 1, 1)
fn k_volume_walk(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_volume_walk(g.x); } }
fn t_volume_walk(i: u32) {
    let a = test_in[2u * i];
    let b = test_in[2u * i + 1u];
    out_buf[i] = vec4f(volume_walk(0u, a.xyz, b.xyz, a.w, b.w, LOOK_ISO).xy, 0.0, 0.0);
}

// in: (o, t_min), (d, t_max), (leaf as u32, 0, 0, 0) -> (t or MISS, u, v, Newton steps): one
// patch leaf's solve alone.
@compute @workgroup_size(64, 1, 1)
fn k_patch_newton(@builtin(global_invocation_id) g: vec3u) { if g.x < launch.rect.z { t_patch_newton(g.x); } }
fn t_patch_newton(i: u32) {
    let a = test_in[3u * i];
    let b = test_in[3u * i + 1u];
    out_buf[i] = patch_newton(bitcast<u32>(test_in[3u * i + 2u].x), a.xyz, b.xyz, a.w, b.w);
}
