// Base-colour textures (src/scene/texture.rs; records: src/gpu/layout.rs, pack_scene).
// CPU twin: src/reference/texture.rs (same names). Sampling reads the scene texture's texels
// with textureLoad and filters here, not with a sampler: a hardware sampler's filter weights
// have a few bits of precision, so the f64 twin could not follow it.

struct TextureInfo {
    first: u32,
    size: vec2u,
    flags: u32,
}

fn load_texture(t: u32) -> TextureInfo {
    let r = texel(params.aux_base.z + t * TEXTURE_TEXELS);
    return TextureInfo(r.x, r.yz, r.w);
}

// sRGB-encoded value in [0, 1] → linear (the sRGB EOTF).
fn srgb_to_linear(c: vec3f) -> vec3f {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3f(2.4));
    return select(hi, lo, c <= vec3f(0.04045));
}

// Linear RGB of pixel `i` of the texture whose pixels start at pixel `first`.
fn texture_pixel(first: u32, i: u32) -> vec3f {
    let p = first + i;
    let word = texel(params.aux_base.w + p / PIXELS_PER_TEXEL)[p % PIXELS_PER_TEXEL];
    return srgb_to_linear(unpack4x8unorm(word).rgb);
}

// Coordinate `u` (in texture widths) folded into the range the wrap mode repeats: [0, 1] for
// repeat and clamp, [0, 2] for mirror (one period: the image, then its mirror). Done in float so
// that the texel indices below stay small whatever `u` is; the clamp also maps a NaN to 0.
fn fold_coord(u: f32, mode: u32) -> f32 {
    var f = clamp(u, 0.0, 1.0);
    if mode == WRAP_REPEAT {
        f = u - floor(u);
    } else if mode == WRAP_MIRROR {
        f = u - 2.0 * floor(0.5 * u);
    }
    return min(max(f, 0.0), 2.0);
}

// Texel index `i` wrapped into [0, n). `i` comes from a folded coordinate, so it is at most one
// period outside [0, period): one add or subtract of the period replaces the integer modulo,
// which AVX2 has no vector instruction for (docs/performance.md, "Lanes, threads and kernels").
fn wrap_index(i: i32, n: i32, mode: u32) -> i32 {
    if mode == WRAP_CLAMP {
        return clamp(i, 0, n - 1);
    }
    let period = select(n, 2 * n, mode == WRAP_MIRROR);
    var k = i;
    if k < 0 {
        k += period;
    } else if k >= period {
        k -= period;
    }
    return select(k, 2 * n - 1 - k, k >= n);
}

// u of the direction `q` around the unit axis `a`: its angle in the orthonormal frame around
// `a` that light discs use too (`frame`, shadows.wgsl), 0..1.
fn angle_u(q: vec3f, a: vec3f) -> f32 {
    let e = basis(a);
    return 0.5 + atan2(dot(q, e.v), dot(q, e.u)) / TAU;
}

// Texture coordinates of a sphere at the outward unit normal `n`: longitude around +y (u) and
// latitude from the +y pole (v = 0) to the -y pole (v = 1), as an equirectangular map.
fn sphere_uv(n: vec3f) -> vec2f {
    return vec2f(angle_u(n, vec3f(0.0, 1.0, 0.0)), acos(clamp(n.y, -1.0, 1.0)) * (1.0 / PI));
}

// Texture coordinates of a cone at `p`: the angle around its axis (u) and the position along it,
// v = 1 at the base and 0 at the apex end (the image upright on a cone standing on its base).
fn cone_uv(p: vec3f, base: vec3f, axis: vec3f) -> vec2f {
    let a = normalize(axis);
    let q = p - base;
    return vec2f(angle_u(q, a), 1.0 - dot(q, axis) / dot(axis, axis));
}

// Linear RGB of texture `t` at `uv` (u right, v down, (0, 0) the top-left corner of the image),
// filtered and wrapped as the texture says.
fn sample_texture(t: u32, uv: vec2f) -> vec3f {
    let info = load_texture(t);
    let n = vec2i(info.size);
    let wrap = vec2u(info.flags, info.flags >> TEXTURE_WRAP_V_SHIFT) & vec2u((1u << TEXTURE_WRAP_V_SHIFT) - 1u);
    let x = vec2f(fold_coord(uv.x, wrap.x), fold_coord(uv.y, wrap.y)) * vec2f(info.size);
    if (info.flags >> TEXTURE_FILTER_SHIFT) == FILTER_NEAREST {
        let i = vec2i(floor(x));
        let ix = wrap_index(i.x, n.x, wrap.x);
        let iy = wrap_index(i.y, n.y, wrap.y);
        return texture_pixel(info.first, u32(iy * n.x + ix));
    }
    // Bilinear between the four texel centres around x (centres at integer + 0.5).
    let xc = x - 0.5;
    let i0 = vec2i(floor(xc));
    let f = xc - floor(xc);
    let x0 = wrap_index(i0.x, n.x, wrap.x);
    let x1 = wrap_index(i0.x + 1, n.x, wrap.x);
    let y0 = wrap_index(i0.y, n.y, wrap.y) * n.x;
    let y1 = wrap_index(i0.y + 1, n.y, wrap.y) * n.x;
    let top = mix(texture_pixel(info.first, u32(y0 + x0)), texture_pixel(info.first, u32(y0 + x1)), f.x);
    let bottom = mix(texture_pixel(info.first, u32(y1 + x0)), texture_pixel(info.first, u32(y1 + x1)), f.x);
    return mix(top, bottom, f.y);
}
