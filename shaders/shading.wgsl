// The shading equations of docs/shading.md. CPU twins: src/reference (same names).

fn ambient_intensity(n: vec3f, up: vec3f, sky: vec3f, ground: vec3f) -> vec3f {
    let c = dot(n, up);
    let half_sin = 0.5 * sqrt(max(0.0, 1.0 - c * c));
    if c >= 0.0 {
        return (1.0 - half_sin) * sky + half_sin * ground;
    }
    return half_sin * sky + (1.0 - half_sin) * ground;
}

fn pow5(x: f32) -> f32 {
    let x2 = x * x;
    return x2 * x2 * x;
}

fn schlick(c: f32, r0: f32) -> f32 {
    return r0 + (1.0 - r0) * pow5(1.0 - clamp(c, 0.0, 1.0));
}

fn schlick3(c: f32, r0: vec3f) -> vec3f {
    return r0 + (1.0 - r0) * pow5(1.0 - clamp(c, 0.0, 1.0));
}

// Fresnel reflectance of a dielectric seen at cos_i = n·e; leaving the medium uses the
// transmitted angle, and total internal reflection reflects everything.
fn dielectric_reflectance(cos_i: f32, eta: f32, inside: bool) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    let r0 = r * r;
    if !inside {
        return schlick(cos_i, r0);
    }
    let c = clamp(cos_i, 0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - c * c);
    if sin2_t > 1.0 {
        return 1.0;
    }
    return schlick(sqrt(1.0 - sin2_t), r0);
}

fn reflect_dir(d: vec3f, n: vec3f) -> vec3f {
    return d - 2.0 * dot(d, n) * n;
}

// Refracted direction (xyz) and whether there is one (w = 1), w = 0 on total internal reflection.
fn refract_dir(d: vec3f, n: vec3f, eta_ratio: f32) -> vec4f {
    let c = -dot(n, d);
    let k = 1.0 - eta_ratio * eta_ratio * (1.0 - c * c);
    if k < 0.0 {
        return vec4f(0.0);
    }
    return vec4f(normalize(eta_ratio * d + (eta_ratio * c - sqrt(k)) * n), 1.0);
}

// Whether `m` is of kind `k` — false for kinds the pipeline was not specialised for
// (MATERIAL_KINDS in the prelude), so their code folds away.
fn kind_is(m: Material, k: u32) -> bool {
    return (MATERIAL_KINDS & (1u << k)) != 0u && m.kind == k;
}

// The material's Fresnel reflectance F at this point, per channel (docs/shading.md table).
fn fresnel(m: Material, n: vec3f, e: vec3f, inside: bool) -> vec3f {
    let c = dot(n, e);
    if kind_is(m, MAT_METAL) {
        return schlick3(c, m.color);
    }
    if kind_is(m, MAT_DIELECTRIC) {
        return vec3f(dielectric_reflectance(c, m.eta, inside));
    }
    if kind_is(m, MAT_POLISHED) {
        let r = (m.eta - 1.0) / (m.eta + 1.0);
        return vec3f(schlick(c, r * r));
    }
    return vec3f(0.0);
}

// 0^0 = 1, so exponent 0 gives a constant highlight.
fn highlight(n: vec3f, h: vec3f, exponent: f32) -> f32 {
    let c = max(dot(n, h), 0.0);
    if exponent == 0.0 {
        return 1.0;
    }
    return pow(c, exponent);
}

fn shade_ambient(m: Material, n: vec3f, e: vec3f, ia: vec3f, inside: bool) -> vec3f {
    if kind_is(m, MAT_DIFFUSE) {
        return m.color * ia;
    }
    if kind_is(m, MAT_POLISHED) {
        return m.color * ia * (1.0 - fresnel(m, n, e, inside).x);
    }
    return vec3f(0.0);
}

// One unshadowed light of intensity l_e in direction l; 0 when the surface faces away from it.
fn shade_light(m: Material, n: vec3f, e: vec3f, l: vec3f, l_e: vec3f, inside: bool) -> vec3f {
    let nl = dot(n, l);
    if nl <= 0.0 {
        return vec3f(0.0);
    }
    if kind_is(m, MAT_DIFFUSE) {
        return m.color * l_e * nl;
    }
    let spec = fresnel(m, n, e, inside) * l_e * highlight(n, normalize(l + e), m.exponent);
    if kind_is(m, MAT_POLISHED) {
        let ne = clamp(dot(n, e), 0.0, 1.0);
        return m.color * l_e * (1.0 - pow5(1.0 - ne)) * (1.0 - pow5(1.0 - nl)) + spec;
    }
    return spec;
}

// Weights of the reflected (k_s, per channel) and refracted (k_t) rays.
struct Reflectance {
    ks: vec3f,
    kt: f32,
}

fn reflectance(m: Material, n: vec3f, e: vec3f, inside: bool) -> Reflectance {
    let f = fresnel(m, n, e, inside);
    if kind_is(m, MAT_DIELECTRIC) {
        return Reflectance(f, 1.0 - f.x);
    }
    return Reflectance(f, 0.0);
}
