//! Base-colour textures: 8-bit sRGB images with the wrap and filter of the sampler that reads
//! them (docs/scene-format.md, docs/gltf.md). Sampling itself lives twice, as usual: in
//! `shaders/texture.wgsl` (f32) and its f64 twin in `crate::reference::texture`.

use std::fmt;

/// Largest texture accepted (4096², 64 MiB as RGBA8 on the host and 64 MiB in the scene
/// texture); bigger images are refused from their header, before decoding.
pub const MAX_TEXTURE_PIXELS: u64 = 1 << 24;
/// Texels of every texture of a scene together (the scene texture must hold them).
pub const MAX_TOTAL_TEXTURE_PIXELS: u64 = 1 << 25;
/// Textures per scene.
pub const MAX_TEXTURES: usize = 1 << 12;

/// How texture coordinates outside [0, 1] are mapped back in (glTF's sampler wrap modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    #[default]
    Repeat,
    Clamp,
    Mirror,
}

/// How a texel is read between texel centres. No mip-mapping: irt has no ray footprints, so a
/// texture seen from far away aliases like any unfiltered detail (docs/gltf.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Filter {
    Nearest,
    #[default]
    Linear,
}

/// An image used as a base colour: the material's colour is multiplied by the texture's linear
/// RGB at the hit's texture coordinates (u to the right, v down: (0, 0) is the top-left corner
/// of the image, as in glTF). Alpha is kept, so a scene round-trips, but not used.
#[derive(Clone, PartialEq)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// sRGB-encoded RGBA, row-major, row 0 the top of the image.
    pub texels: Vec<[u8; 4]>,
    /// Wrap along u and along v.
    pub wrap: [Wrap; 2],
    pub filter: Filter,
}

impl fmt::Debug for Texture {
    // Millions of texels are no use in a test failure; the size and a checksum are.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sum = self.texels.iter().flatten().fold(0u64, |h, &b| h.wrapping_mul(31).wrapping_add(b as u64));
        f.debug_struct("Texture")
            .field("name", &self.name)
            .field("size", &format_args!("{}x{}", self.width, self.height))
            .field("texel_checksum", &sum)
            .field("wrap", &self.wrap)
            .field("filter", &self.filter)
            .finish()
    }
}

impl Wrap {
    pub const NAMES: [(&'static str, Wrap); 3] =
        [("repeat", Wrap::Repeat), ("clamp", Wrap::Clamp), ("mirror", Wrap::Mirror)];

    pub fn name(self) -> &'static str {
        Self::NAMES.iter().find(|(_, w)| *w == self).expect("every mode is named").0
    }
}

impl Filter {
    pub const NAMES: [(&'static str, Filter); 2] = [("nearest", Filter::Nearest), ("linear", Filter::Linear)];

    pub fn name(self) -> &'static str {
        Self::NAMES.iter().find(|(_, w)| *w == self).expect("every filter is named").0
    }
}
