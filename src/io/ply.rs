//! PLY, the Stanford polygon format (ASCII, binary little- and big-endian) → [`Model`].
//!
//! docs/ply.md says what is read, how colours become materials, what is ignored and how fast it
//! is. The loader is a small reader of its own rather than a crate: ply-rs and its fork
//! ply-rs-bw hand every property of every element to a setter keyed by a `String` (by default
//! into a map per element, with a `Vec` per face list), and serde-ply deserialises each row into
//! a struct with a `Vec` per list; at ten million faces those allocations are most of the time,
//! and none of them points at the line or byte of a bad value or bounds what it allocates by
//! what the file can hold. This reader borrows the file's bytes, makes one plan per
//! element from the header (which property feeds which field; everything else is skipped, lists
//! by their counts), and writes straight into the mesh's arrays.
//!
//! Errors give `file:line:column` in the header and in an ASCII body, and `at byte N` in a binary
//! body. Elements are counted from 0, as PLY's vertex indices are.

mod points;
pub use points::{write as write_points, PointTable};

use super::scalar::Scalar;
use super::shapes::{triangulate, MAX_POLYGON_VERTICES};
use super::stage::{self, Model};
use super::toml::DEFAULT_DIFFUSE_COLOR;
use super::{LoadError, MAX_MATERIALS, MAX_TRIANGLES, MAX_VERTICES};
use crate::image::srgb_to_linear;
use crate::scene::particles::ParticleStyle;
use crate::scene::{Material, MaterialKind, Mesh, Scene};
use glam::{DVec2, DVec3};
use std::io::{self, Write};

/// Files above this are refused before reading. A 10-million-triangle binary PLY (float
/// coordinates, `uchar int` face lists) is 190 MB; 16 million triangles and vertices with double
/// coordinates and normals and byte colours are about 1 GB. 2 GiB leaves room for properties
/// that are skipped, and bounds the file's bytes, which are held in memory during the load.
pub const MAX_FILE_BYTES: u64 = 2 << 30;
/// Colour levels per channel when faces are grouped into materials by colour: 32³ = 32768
/// groups at most (docs/ply.md, "Colours").
pub const COLOUR_LEVELS: usize = 32;
const _: () = assert!(COLOUR_LEVELS * COLOUR_LEVELS * COLOUR_LEVELS <= MAX_MATERIALS);

/// Parses a PLY file onto the default stage ([`stage::stage`]) and validates it.
pub fn parse(bytes: &[u8], origin: &str) -> Result<Scene, LoadError> {
    let scene = stage::stage(parse_model(bytes, origin)?);
    // Everything is checked on the way in; this is the scene model's own guard.
    scene.validate().map_err(|e| LoadError::new(origin, e.0))?;
    Ok(scene)
}

/// The meshes and materials of a PLY file (`origin` names it in messages); a file of points
/// alone gives particles drawn the default way ([`parse_particles`]).
pub fn parse_model(bytes: &[u8], origin: &str) -> Result<Model, LoadError> {
    let header = Header::parse(bytes, origin)?;
    if header.is_points() {
        return read_points(&header, bytes, origin, &ParticleStyle::default());
    }
    let mut reader = Reader::new(&header)?;
    match header.encoding {
        Encoding::Ascii => {
            let text = super::utf8(bytes, origin)?;
            reader.run(&mut Ascii { src: text, origin, pos: header.body, line_end: header.body, last: 0 })?
        }
        Encoding::BinaryLittleEndian => {
            reader.run(&mut Binary::<false> { bytes, origin, pos: header.body, last: 0 })?
        }
        Encoding::BinaryBigEndian => {
            reader.run(&mut Binary::<true> { bytes, origin, pos: header.body, last: 0 })?
        }
    }
    reader.finish()
}

/// The points of a PLY file with a `vertex` element and no `face` element, as spheres drawn
/// by `style` (`src/io/ply/points.rs`).
pub fn parse_particles(bytes: &[u8], origin: &str, style: &ParticleStyle) -> Result<Model, LoadError> {
    let header = Header::parse(bytes, origin)?;
    if !header.is_points() {
        let what =
            if header.elements.iter().any(|e| e.name == "vertex") { "faces" } else { "no vertex element" };
        return Err(LoadError::new(
            origin,
            format!("not a file of points: it has {what}; use [[model]] for a mesh"),
        ));
    }
    read_points(&header, bytes, origin, style)
}

fn read_points(
    header: &Header,
    bytes: &[u8],
    origin: &str,
    style: &ParticleStyle,
) -> Result<Model, LoadError> {
    let h = header;
    match h.encoding {
        Encoding::Ascii => {
            let text = super::utf8(bytes, origin)?;
            points::read(h, &mut Ascii { src: text, origin, pos: h.body, line_end: h.body, last: 0 }, style)
        }
        Encoding::BinaryLittleEndian => {
            points::read(h, &mut Binary::<false> { bytes, origin, pos: h.body, last: 0 }, style)
        }
        Encoding::BinaryBigEndian => {
            points::read(h, &mut Binary::<true> { bytes, origin, pos: h.body, last: 0 }, style)
        }
    }
}

/// How a PLY body is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

impl Encoding {
    pub const ALL: [Encoding; 3] = [Encoding::Ascii, Encoding::BinaryLittleEndian, Encoding::BinaryBigEndian];

    fn name(self) -> &'static str {
        match self {
            Encoding::Ascii => "ascii",
            Encoding::BinaryLittleEndian => "binary_little_endian",
            Encoding::BinaryBigEndian => "binary_big_endian",
        }
    }
}

// ---- The header ------------------------------------------------------------------------------

const TYPE_NAMES: &str = "char, uchar, short, ushort, int, uint, float, double (or int8, uint8, int16, \
                          uint16, int32, uint32, float32, float64)";

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

struct Property {
    name: String,
    kind: Kind,
    /// Byte offset of its `property` line in the header.
    at: usize,
}

struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
    /// Byte offsets of its `element` line and of its count in the header.
    at: usize,
    count_at: usize,
}

impl Element {
    /// Bytes per instance when it has no lists.
    fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(t) => Some(t.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }

    /// The fewest bytes one instance can take: in binary its scalars and list counts; in ASCII
    /// a character and a separator per property.
    fn min_size(&self, encoding: Encoding) -> u64 {
        let per = |p: &Property| match (encoding, p.kind) {
            (Encoding::Ascii, _) => 2,
            (_, Kind::Scalar(t) | Kind::List { count: t, .. }) => t.size() as u64,
        };
        self.properties.iter().map(per).sum()
    }

    fn property(&self, names: &[&str]) -> Option<(usize, &Property)> {
        self.properties.iter().enumerate().find(|(_, p)| names.contains(&p.name.as_str()))
    }
}

struct Header<'a> {
    /// The header's text, for positions.
    text: &'a str,
    origin: &'a str,
    encoding: Encoding,
    elements: Vec<Element>,
    /// Offset of the first byte after `end_header`'s line.
    body: usize,
}

fn trim_ascii(b: &[u8]) -> &[u8] {
    let start = b.iter().position(|c| !c.is_ascii_whitespace()).unwrap_or(b.len());
    let end = b.iter().rposition(|c| !c.is_ascii_whitespace()).map_or(start, |i| i + 1);
    &b[start..end.max(start)]
}

/// The words of `line` with their byte offsets in the header (`base` is the line's offset).
fn words(line: &str, base: usize) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let b = line.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let start = i;
        while i < b.len() && !b[i].is_ascii_whitespace() {
            i += 1;
        }
        out.push((base + start, &line[start..i]));
    }
    out
}

impl<'a> Header<'a> {
    fn error(&self, at: usize, message: impl Into<String>) -> LoadError {
        LoadError::at(self.origin, self.text, at, message)
    }

    /// Whether the file is points alone: a `vertex` element and no `face` element.
    fn is_points(&self) -> bool {
        let has = |name| self.elements.iter().any(|e| e.name == name);
        has("vertex") && !has("face")
    }

    fn parse(bytes: &'a [u8], origin: &'a str) -> Result<Header<'a>, LoadError> {
        let first = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
        if trim_ascii(first) != b"ply" {
            return Err(LoadError {
                line: Some(1),
                column: Some(1),
                ..LoadError::new(origin, "not a PLY file: its first line must be `ply`")
            });
        }
        // The header is text up to the `end_header` line; the body after it may be binary.
        let mut at = 0;
        let body = loop {
            at = at.min(bytes.len());
            let prefix = || std::str::from_utf8(&bytes[..at]).unwrap_or_default();
            if at == bytes.len() {
                return Err(LoadError::at(
                    origin,
                    prefix(),
                    at,
                    "the file ends in the header: it has no `end_header` line",
                ));
            }
            let end = bytes[at..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| at + i);
            let line = &bytes[at..end];
            if std::str::from_utf8(line).is_err() || line.contains(&0) {
                return Err(LoadError::at(
                    origin,
                    prefix(),
                    at,
                    "this header line is not text: is `end_header` missing before the binary data?",
                ));
            }
            if trim_ascii(line) == b"end_header" {
                break (end + 1).min(bytes.len());
            }
            at = end + 1;
        };
        let text = std::str::from_utf8(&bytes[..body]).expect("checked line by line");
        let mut h = Header { text, origin, encoding: Encoding::Ascii, elements: Vec::new(), body };
        let mut format_at = None;
        let mut base = 0;
        for line in text.split_inclusive('\n') {
            let w = words(line, base);
            base += line.len();
            let Some(&(at, keyword)) = w.first() else { continue };
            match keyword {
                "ply" if at == 0 => {}
                "comment" | "obj_info" => {}
                "format" => {
                    if let Some(first) = format_at {
                        let line = super::line_column(text, first).0;
                        return Err(h.error(at, format!("a second `format` line; the first is line {line}")));
                    }
                    format_at = Some(at);
                    h.encoding = h.format(&w)?;
                }
                "element" => h.element(&w)?,
                "property" => h.property(&w)?,
                "end_header" => {
                    if format_at.is_none() {
                        return Err(h.error(at, "the header has no `format` line before `end_header`"));
                    }
                }
                other => {
                    return Err(h.error(
                        at,
                        format!(
                            "unknown header line `{other}`; a PLY header has format, element, property, \
                             comment, obj_info and end_header lines"
                        ),
                    ))
                }
            }
        }
        Ok(h)
    }

    fn format(&self, w: &[(usize, &str)]) -> Result<Encoding, LoadError> {
        let [_, (enc_at, enc), (version_at, version)] = w else {
            return Err(self.error(w[0].0, "expected `format <encoding> 1.0`"));
        };
        let encoding = Encoding::ALL.into_iter().find(|e| e.name() == *enc).ok_or_else(|| {
            self.error(
                *enc_at,
                format!(
                    "unknown format `{enc}`; PLY files are ascii, binary_little_endian or binary_big_endian"
                ),
            )
        })?;
        if *version != "1.0" {
            return Err(self.error(*version_at, format!("PLY version `{version}`; irt reads version 1.0")));
        }
        Ok(encoding)
    }

    fn element(&mut self, w: &[(usize, &str)]) -> Result<(), LoadError> {
        let [(at, _), (_, name), (count_at, count)] = w else {
            return Err(self.error(w[0].0, "expected `element <name> <count>`"));
        };
        let count = count.parse::<u64>().map_err(|_| {
            self.error(*count_at, format!("element count `{count}` is not a whole number of at least 0"))
        })?;
        if let Some(first) = self.elements.iter().find(|e| e.name == *name) {
            let line = super::line_column(self.text, first.at).0;
            return Err(self.error(*at, format!("a second element `{name}`; the first is on line {line}")));
        }
        self.elements.push(Element {
            name: name.to_string(),
            count,
            properties: Vec::new(),
            at: *at,
            count_at: *count_at,
        });
        Ok(())
    }

    fn scalar(&self, at: usize, name: &str) -> Result<Scalar, LoadError> {
        Scalar::parse(name).ok_or_else(|| {
            self.error(at, format!("unknown property type `{name}`; PLY's types are {TYPE_NAMES}"))
        })
    }

    fn property(&mut self, w: &[(usize, &str)]) -> Result<(), LoadError> {
        let at = w[0].0;
        let (kind, name) =
            match w {
                [_, (_, "list"), (count_at, count), (item_at, item), (_, name)] => {
                    let count = self.scalar(*count_at, count)?;
                    if !count.is_integer() {
                        return Err(self.error(
                            *count_at,
                            format!("a list's count must be an integer type, not {}", count.name()),
                        ));
                    }
                    (Kind::List { count, item: self.scalar(*item_at, item)? }, *name)
                }
                [_, (_, "list"), ..] => {
                    return Err(self.error(at, "expected `property list <count type> <item type> <name>`"))
                }
                [_, (type_at, t), (_, name)] => (Kind::Scalar(self.scalar(*type_at, t)?), *name),
                _ => return Err(self.error(
                    at,
                    "expected `property <type> <name>` or `property list <count type> <item type> <name>`",
                )),
            };
        let text = self.text;
        let Some(element) = self.elements.last_mut() else {
            return Err(LoadError::at(self.origin, text, at, "a `property` line before any `element` line"));
        };
        if let Some(first) = element.properties.iter().find(|p| p.name == name) {
            let line = super::line_column(text, first.at).0;
            return Err(LoadError::at(
                self.origin,
                text,
                at,
                format!(
                    "element `{}` has a second property `{name}`; the first is on line {line}",
                    element.name
                ),
            ));
        }
        element.properties.push(Property { name: name.to_string(), kind, at });
        Ok(())
    }
}

// ---- The body: one cursor per encoding -------------------------------------------------------

/// Which instance of which element, and which of its properties, is being read (for messages).
#[derive(Clone, Copy)]
struct Place<'e> {
    element: &'e str,
    index: u64,
    property: &'e str,
}

/// A cursor over the body in one encoding.
trait Body {
    /// Starts an element before its first instance (binary: checks that a fixed-size element
    /// fits in what is left of the file).
    fn begin_element(&mut self, e: &Element) -> Result<(), LoadError>;
    /// Starts instance `index` (ASCII: its line).
    fn begin(&mut self, e: &Element, index: u64) -> Result<(), LoadError>;
    fn value(&mut self, t: Scalar, at: Place) -> Result<f64, LoadError>;
    fn skip(&mut self, t: Scalar, n: u64, at: Place) -> Result<(), LoadError>;
    /// Checks that `n` values of type `t` follow (binary; ASCII finds out value by value).
    fn require(&mut self, t: Scalar, n: u64, at: Place) -> Result<(), LoadError>;
    /// Ends instance `index` (ASCII: nothing may follow on its line).
    fn end(&mut self, e: &Element, index: u64) -> Result<(), LoadError>;
    /// Skips a whole element without lists, if this encoding can do it at once.
    fn skip_fixed(&mut self, e: &Element) -> Result<bool, LoadError>;
    /// An error at the value last read.
    fn error(&self, message: String) -> LoadError;
    /// Checks that nothing follows the last element.
    fn finish(&mut self) -> Result<(), LoadError>;
    fn position(&self) -> usize;
    fn seek(&mut self, position: usize);
    /// The file's length.
    fn len(&self) -> usize;
}

struct Binary<'a, const BIG: bool> {
    bytes: &'a [u8],
    origin: &'a str,
    pos: usize,
    /// Where the value last read starts.
    last: usize,
}

fn decode<const BIG: bool>(t: Scalar, b: &[u8]) -> f64 {
    macro_rules! num {
        ($ty:ty, $n:literal) => {{
            let mut a = [0u8; $n];
            a.copy_from_slice(&b[..$n]);
            (if BIG { <$ty>::from_be_bytes(a) } else { <$ty>::from_le_bytes(a) }) as f64
        }};
    }
    match t {
        Scalar::I8 => b[0] as i8 as f64,
        Scalar::U8 => b[0] as f64,
        Scalar::I16 => num!(i16, 2),
        Scalar::U16 => num!(u16, 2),
        Scalar::I32 => num!(i32, 4),
        Scalar::U32 => num!(u32, 4),
        Scalar::F32 => num!(f32, 4),
        Scalar::F64 => num!(f64, 8),
    }
}

impl<const BIG: bool> Binary<'_, BIG> {
    fn at(&self, offset: usize, message: String) -> LoadError {
        LoadError::new(self.origin, format!("at byte {offset}: {message}"))
    }

    fn truncated(&self, needed: u64, at: Place) -> LoadError {
        let missing = needed - (self.bytes.len() - self.pos) as u64;
        self.at(
            self.bytes.len(),
            format!(
                "the file ends, and {} {} needs {missing} more bytes (for {})",
                at.element, at.index, at.property
            ),
        )
    }
}

impl<const BIG: bool> Body for Binary<'_, BIG> {
    fn begin_element(&mut self, e: &Element) -> Result<(), LoadError> {
        let Some(stride) = e.fixed_size().filter(|&s| s > 0) else { return Ok(()) };
        let left = (self.bytes.len() - self.pos) as u64;
        if e.count.saturating_mul(stride as u64) > left {
            let k = left / stride as u64;
            let missing = stride as u64 - left % stride as u64;
            return Err(self.at(
                self.bytes.len(),
                format!(
                    "the file ends, and {} {k} needs {missing} more bytes (each {} has {stride}; the header declares {})",
                    e.name, e.name, e.count
                ),
            ));
        }
        Ok(())
    }

    fn begin(&mut self, _: &Element, _: u64) -> Result<(), LoadError> {
        Ok(())
    }

    fn value(&mut self, t: Scalar, at: Place) -> Result<f64, LoadError> {
        let n = t.size();
        let Some(b) = self.bytes.get(self.pos..self.pos + n) else {
            return Err(self.truncated(n as u64, at));
        };
        self.last = self.pos;
        self.pos += n;
        Ok(decode::<BIG>(t, b))
    }

    fn skip(&mut self, t: Scalar, n: u64, at: Place) -> Result<(), LoadError> {
        self.require(t, n, at)?;
        self.pos += n as usize * t.size();
        Ok(())
    }

    fn require(&mut self, t: Scalar, n: u64, at: Place) -> Result<(), LoadError> {
        let bytes = n * t.size() as u64;
        if bytes > (self.bytes.len() - self.pos) as u64 {
            return Err(self.truncated(bytes, at));
        }
        Ok(())
    }

    fn end(&mut self, _: &Element, _: u64) -> Result<(), LoadError> {
        Ok(())
    }

    fn skip_fixed(&mut self, e: &Element) -> Result<bool, LoadError> {
        let Some(stride) = e.fixed_size() else { return Ok(false) };
        self.begin_element(e)?;
        self.pos += e.count as usize * stride;
        Ok(true)
    }

    fn error(&self, message: String) -> LoadError {
        self.at(self.last, message)
    }

    fn finish(&mut self) -> Result<(), LoadError> {
        if self.pos < self.bytes.len() {
            let extra = self.bytes.len() - self.pos;
            return Err(
                self.at(self.pos, format!("{extra} bytes follow the last element the header declares"))
            );
        }
        Ok(())
    }

    fn position(&self) -> usize {
        self.pos
    }

    fn seek(&mut self, position: usize) {
        self.pos = position;
    }

    fn len(&self) -> usize {
        self.bytes.len()
    }
}

/// An ASCII body: one instance per line, values separated by spaces; blank lines are skipped.
struct Ascii<'a> {
    src: &'a str,
    origin: &'a str,
    pos: usize,
    line_end: usize,
    last: usize,
}

impl<'a> Ascii<'a> {
    fn at(&self, offset: usize, message: impl Into<String>) -> LoadError {
        LoadError::at(self.origin, self.src, offset, message)
    }

    /// The next word on the current line, and where it starts.
    fn word(&mut self) -> Option<(usize, &'a str)> {
        let b = self.src.as_bytes();
        while self.pos < self.line_end && b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if self.pos >= self.line_end {
            return None;
        }
        let start = self.pos;
        while self.pos < self.line_end && !b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        Some((start, &self.src[start..self.pos]))
    }
}

impl Body for Ascii<'_> {
    fn begin_element(&mut self, _: &Element) -> Result<(), LoadError> {
        Ok(())
    }

    fn begin(&mut self, e: &Element, index: u64) -> Result<(), LoadError> {
        let b = self.src.as_bytes();
        loop {
            if self.pos >= b.len() {
                return Err(self.at(
                    b.len(),
                    format!("the file ends before {} {index}; the header declares {}", e.name, e.count),
                ));
            }
            let end = b[self.pos..].iter().position(|&c| c == b'\n').map_or(b.len(), |i| self.pos + i);
            if b[self.pos..end].iter().any(|c| !c.is_ascii_whitespace()) {
                self.line_end = end;
                return Ok(());
            }
            self.pos = end + 1;
        }
    }

    fn value(&mut self, t: Scalar, at: Place) -> Result<f64, LoadError> {
        let line_end = self.line_end;
        let Some((start, word)) = self.word() else {
            return Err(self.at(
                line_end,
                format!("the line ends before {} of {} {}", at.property, at.element, at.index),
            ));
        };
        self.last = start;
        let bad = |this: &Self, why: &str| {
            this.at(
                start,
                format!("{} of {} {} is `{word}`, {why} ({})", at.property, at.element, at.index, t.name()),
            )
        };
        match t {
            Scalar::F32 => word.parse::<f32>().map(f64::from).map_err(|_| bad(self, "not a number")),
            Scalar::F64 => word.parse::<f64>().map_err(|_| bad(self, "not a number")),
            _ => {
                let v = word.parse::<i64>().map_err(|_| bad(self, "not a whole number"))?;
                let (lo, hi) = t.range();
                if v < lo || v > hi {
                    return Err(bad(self, &format!("out of its type's range {lo} to {hi}")));
                }
                Ok(v as f64)
            }
        }
    }

    fn skip(&mut self, t: Scalar, n: u64, at: Place) -> Result<(), LoadError> {
        for _ in 0..n {
            self.value(t, at)?;
        }
        Ok(())
    }

    fn require(&mut self, _: Scalar, _: u64, _: Place) -> Result<(), LoadError> {
        Ok(())
    }

    fn end(&mut self, e: &Element, index: u64) -> Result<(), LoadError> {
        if let Some((start, word)) = self.word() {
            let n = e.properties.len();
            return Err(self.at(
                start,
                format!("`{word}` is one value too many: {} {index} has {n} properties", e.name),
            ));
        }
        self.pos = self.line_end + 1;
        Ok(())
    }

    fn skip_fixed(&mut self, _: &Element) -> Result<bool, LoadError> {
        Ok(false)
    }

    fn error(&self, message: String) -> LoadError {
        self.at(self.last, message)
    }

    fn finish(&mut self) -> Result<(), LoadError> {
        let b = self.src.as_bytes();
        match b.get(self.pos..).and_then(|rest| rest.iter().position(|c| !c.is_ascii_whitespace())) {
            Some(i) => Err(self.at(self.pos + i, "data after the last element the header declares")),
            None => Ok(()),
        }
    }

    fn position(&self) -> usize {
        self.pos
    }

    fn seek(&mut self, position: usize) {
        self.pos = position;
        self.line_end = position;
    }

    fn len(&self) -> usize {
        self.src.len()
    }
}

// ---- Reading the elements ----------------------------------------------------------------------

/// Values an instance fills, by index: position, normal, colour, uv.
const X: usize = 0;
const NORMAL: usize = 3;
const COLOUR: usize = 6;
const UV: usize = 9;
const VALUES: usize = 11;

/// What one property feeds.
#[derive(Clone, Copy, PartialEq)]
enum Slot {
    Skip,
    /// Into `values[k]`, multiplied by `scale` (colours of integer types become 0–1).
    Value {
        k: usize,
        scale: f64,
    },
    /// The face's vertex index list.
    Indices,
}

#[derive(Clone, Copy, PartialEq)]
enum Role {
    Vertex,
    Face,
    Other,
}

/// Names irt reads, in order of preference.
const NORMAL_NAMES: [&str; 3] = ["nx", "ny", "nz"];
const COLOUR_NAMES: [[&str; 3]; 2] =
    [["red", "green", "blue"], ["diffuse_red", "diffuse_green", "diffuse_blue"]];
const UV_NAMES: [[&str; 2]; 4] =
    [["u", "v"], ["s", "t"], ["texture_u", "texture_v"], ["texture_s", "texture_t"]];
const INDEX_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

struct Reader<'h> {
    header: &'h Header<'h>,
    roles: Vec<Role>,
    plans: Vec<Vec<Slot>>,
    vertex_count: u64,
    has_normals: bool,
    vertex_colours: bool,
    face_colours: bool,
    has_uvs: bool,
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    uvs: Vec<DVec2>,
    /// Vertex colours as stored (sRGB-encoded, 0–1).
    colours: Vec<[f32; 3]>,
    indices: Vec<[u32; 3]>,
    /// Per triangle, its colour group, when the file has colours.
    groups: Vec<u16>,
    /// Per colour group, the sum of its triangles' colours and their number.
    group_sums: Vec<([f64; 3], u64)>,
    vertices_read: bool,
    short_faces: u64,
    flat_polygons: u64,
    clamped_colours: u64,
    warnings: Vec<String>,
}

impl<'h> Reader<'h> {
    fn new(header: &'h Header<'h>) -> Result<Self, LoadError> {
        let h = header;
        let end_at = h.text.rfind("end_header").unwrap_or(h.text.len());
        let mut r = Reader {
            header,
            roles: Vec::new(),
            plans: Vec::new(),
            vertex_count: 0,
            has_normals: false,
            vertex_colours: false,
            face_colours: false,
            has_uvs: false,
            positions: Vec::new(),
            normals: Vec::new(),
            uvs: Vec::new(),
            colours: Vec::new(),
            indices: Vec::new(),
            groups: Vec::new(),
            group_sums: Vec::new(),
            vertices_read: false,
            short_faces: 0,
            flat_polygons: 0,
            clamped_colours: 0,
            warnings: Vec::new(),
        };
        let vertex = h.elements.iter().position(|e| e.name == "vertex");
        let face = h.elements.iter().position(|e| e.name == "face");
        let (Some(vertex), Some(face)) = (vertex, face) else {
            let missing = if vertex.is_none() { "vertex" } else { "face" };
            return Err(h.error(
                end_at,
                format!(
                    "the header declares no `{missing}` element; irt renders surfaces (vertices and faces) \
                     and particles (vertices alone)"
                ),
            ));
        };
        for (i, e) in h.elements.iter().enumerate() {
            let role = if i == vertex {
                Role::Vertex
            } else if i == face {
                Role::Face
            } else {
                if e.name == "tristrips" {
                    r.warn("its triangle strips (element tristrips) are not read: irt reads faces".into());
                }
                Role::Other
            };
            r.roles.push(role);
            r.plans.push(vec![Slot::Skip; e.properties.len()]);
        }
        r.plan_vertex(vertex)?;
        r.plan_face(face)?;
        Ok(r)
    }

    fn warn(&mut self, message: String) {
        if !self.warnings.contains(&message) {
            self.warnings.push(message);
        }
    }

    /// The slots of a group of properties (x y z, nx ny nz, ...) that must be scalars; None if
    /// any is missing (with a warning when some but not all are there).
    fn group(&mut self, e: usize, names: &[&str], what: &str) -> Option<Vec<(usize, Scalar)>> {
        let element = &self.header.elements[e];
        let found: Vec<_> = names.iter().map(|n| element.property(&[n])).collect();
        if found.iter().all(Option::is_none) {
            return None;
        }
        let scalars: Option<Vec<(usize, Scalar)>> = found
            .iter()
            .map(|f| match f.map(|(i, p)| (i, p.kind)) {
                Some((i, Kind::Scalar(t))) => Some((i, t)),
                _ => None,
            })
            .collect();
        if scalars.is_none() {
            let names = names.join(", ");
            self.warn(format!(
                "its {what} are ignored: they need {names} on element {}, each a single number",
                element.name
            ));
        }
        scalars
    }

    fn plan_vertex(&mut self, e: usize) -> Result<(), LoadError> {
        let h = self.header;
        let element = &h.elements[e];
        if element.count > MAX_VERTICES as u64 {
            return Err(h.error(
                element.count_at,
                format!("{} vertices; irt's limit is {MAX_VERTICES}", element.count),
            ));
        }
        self.vertex_count = element.count;
        for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
            match element.property(&[name]) {
                None => {
                    return Err(h.error(
                        element.at,
                        format!("element vertex has no property `{name}`; irt needs x, y and z"),
                    ))
                }
                Some((_, Property { kind: Kind::List { .. }, at, .. })) => {
                    return Err(h.error(
                        *at,
                        format!("vertex property `{name}` is a list; a coordinate is one number"),
                    ))
                }
                Some((i, _)) => self.plans[e][i] = Slot::Value { k: X + k, scale: 1.0 },
            }
        }
        if let Some(n) = self.group(e, &NORMAL_NAMES, "normals") {
            for (k, (i, _)) in n.into_iter().enumerate() {
                self.plans[e][i] = Slot::Value { k: NORMAL + k, scale: 1.0 };
            }
            self.has_normals = true;
        }
        if let Some(c) = COLOUR_NAMES.iter().find_map(|names| self.group(e, names, "colours")) {
            self.set_colours(e, &c);
            self.vertex_colours = true;
        }
        if let Some(uv) = UV_NAMES.iter().find_map(|names| self.group(e, names, "texture coordinates")) {
            for (k, (i, _)) in uv.into_iter().enumerate() {
                self.plans[e][i] = Slot::Value { k: UV + k, scale: 1.0 };
            }
            self.has_uvs = true;
        }
        Ok(())
    }

    /// Colour slots: integer types scaled by their largest value, floats as they are (0–1).
    fn set_colours(&mut self, e: usize, c: &[(usize, Scalar)]) {
        for (k, &(i, t)) in c.iter().enumerate() {
            let scale = if t.is_integer() { 1.0 / t.range().1 as f64 } else { 1.0 };
            self.plans[e][i] = Slot::Value { k: COLOUR + k, scale };
        }
    }

    fn plan_face(&mut self, e: usize) -> Result<(), LoadError> {
        let h = self.header;
        let element = &h.elements[e];
        if element.count > MAX_TRIANGLES as u64 {
            return Err(h.error(
                element.count_at,
                format!("{} faces; irt's limit is {MAX_TRIANGLES} triangles", element.count),
            ));
        }
        match element.property(&INDEX_NAMES) {
            None => {
                return Err(h.error(
                    element.at,
                    "element face has no list `vertex_indices` (or `vertex_index`) of its corners",
                ))
            }
            Some((_, Property { kind: Kind::Scalar(_), at, name })) => {
                return Err(
                    h.error(*at, format!("face property `{name}` is a single number; it must be a list"))
                )
            }
            Some((_, Property { kind: Kind::List { item, .. }, at, name })) if !item.is_integer() => {
                return Err(h.error(
                    *at,
                    format!("face property `{name}` lists {}s; vertex indices must be integers", item.name()),
                ))
            }
            Some((i, _)) => self.plans[e][i] = Slot::Indices,
        }
        if let Some(c) = COLOUR_NAMES.iter().find_map(|names| self.group(e, names, "face colours")) {
            self.set_colours(e, &c);
            self.face_colours = true;
        }
        Ok(())
    }

    /// How many instances of `e` to allocate for: its count (within irt's limits, checked from
    /// the header), but no more than the rest of the file can hold at the fewest bytes an
    /// instance takes. A count the file cannot hold then ends in the error at the byte or line
    /// where the data runs out, without its allocation.
    fn capacity<B: Body>(&self, body: &B, e: &Element) -> usize {
        let left = (body.len() - body.position().min(body.len())) as u64;
        e.count.min(left / e.min_size(self.header.encoding).max(1)) as usize
    }

    /// Reads every element in file order; a `face` element before the `vertex` element is read
    /// once the vertices are (polygons need their positions, colours their vertices' colours).
    fn run<B: Body>(&mut self, body: &mut B) -> Result<(), LoadError> {
        let h = self.header;
        let mut deferred = None;
        for (i, e) in h.elements.iter().enumerate() {
            match self.roles[i] {
                Role::Vertex => {
                    self.read_vertices(body, e, i)?;
                    if let Some((at, face)) = deferred.take() {
                        let resume = body.position();
                        body.seek(at);
                        self.read_faces(body, &h.elements[face], face)?;
                        body.seek(resume);
                    }
                }
                Role::Face if !self.vertices_read => {
                    deferred = Some((body.position(), i));
                    skip(body, e)?;
                }
                Role::Face => self.read_faces(body, e, i)?,
                Role::Other => skip(body, e)?,
            }
        }
        body.finish()
    }

    fn read_vertices<B: Body>(&mut self, body: &mut B, e: &Element, i: usize) -> Result<(), LoadError> {
        let n = self.capacity(body, e);
        self.positions.reserve_exact(n);
        if self.has_normals {
            self.normals.reserve_exact(n);
        }
        if self.has_uvs {
            self.uvs.reserve_exact(n);
        }
        if self.vertex_colours {
            self.colours.reserve_exact(n);
        }
        let plan = std::mem::take(&mut self.plans[i]);
        let mut clamped = 0;
        instances(body, e, &plan, 0, |_, _, v, _| {
            self.positions.push(DVec3::new(v[X], v[X + 1], v[X + 2]));
            if self.has_normals {
                self.normals.push(DVec3::new(v[NORMAL], v[NORMAL + 1], v[NORMAL + 2]));
            }
            if self.has_uvs {
                self.uvs.push(DVec2::new(v[UV], v[UV + 1]));
            }
            if self.vertex_colours {
                self.colours.push(colour(&v[COLOUR..COLOUR + 3], &mut clamped));
            }
            Ok(())
        })?;
        self.clamped_colours += clamped;
        self.vertices_read = true;
        Ok(())
    }

    fn read_faces<B: Body>(&mut self, body: &mut B, e: &Element, i: usize) -> Result<(), LoadError> {
        let n = self.capacity(body, e);
        self.indices.reserve(n);
        let coloured = self.face_colours || self.vertex_colours;
        if coloured {
            self.groups.reserve(n);
            self.group_sums = vec![([0.0; 3], 0); COLOUR_LEVELS.pow(3)];
        }
        let plan = std::mem::take(&mut self.plans[i]);
        let mut corners: Vec<DVec3> = Vec::new();
        let (mut clamped, mut short, mut flat) = (0, 0, 0);
        let vertex_count = self.vertex_count;
        instances(body, e, &plan, vertex_count, |body, index, v, list| {
            if list.len() < 3 {
                short += 1;
                return Ok(());
            }
            let before = self.indices.len();
            if let &[a, b, c] = list {
                self.indices.push([a, b, c]);
            } else {
                corners.clear();
                corners.extend(list.iter().map(|&k| self.positions[k as usize]));
                let triangles = triangulate(&corners);
                if triangles.is_empty() {
                    flat += 1;
                }
                self.indices.extend(triangles.iter().map(|t| t.map(|j| list[j])));
            }
            if self.indices.len() > MAX_TRIANGLES {
                return Err(body.error(format!(
                    "face {index} makes more than irt's limit of {MAX_TRIANGLES} triangles"
                )));
            }
            if coloured {
                let c = if self.face_colours {
                    colour(&v[COLOUR..COLOUR + 3], &mut clamped)
                } else {
                    let sum = list.iter().fold([0.0f32; 3], |s, &k| {
                        let c = self.colours[k as usize];
                        [s[0] + c[0], s[1] + c[1], s[2] + c[2]]
                    });
                    sum.map(|x| x / list.len() as f32)
                };
                let made = self.indices.len() - before;
                let g = group_of(c);
                self.groups.extend(std::iter::repeat_n(g, made));
                let (sum, n) = &mut self.group_sums[g as usize];
                for (s, x) in sum.iter_mut().zip(c) {
                    *s += x as f64 * made as f64;
                }
                *n += made as u64;
            }
            Ok(())
        })?;
        self.clamped_colours += clamped;
        self.short_faces += short;
        self.flat_polygons += flat;
        Ok(())
    }

    fn finish(mut self) -> Result<Model, LoadError> {
        let origin = self.header.origin;
        if self.short_faces > 0 {
            self.warn(format!("skipped {} faces with fewer than 3 vertices", self.short_faces));
        }
        if self.flat_polygons > 0 {
            self.warn(format!("skipped {} polygons without area", self.flat_polygons));
        }
        if self.clamped_colours > 0 {
            self.warn(format!("{} colours outside 0 to 1 were clamped", self.clamped_colours));
        }
        if self.indices.is_empty() {
            return Err(LoadError::new(
                origin,
                "the file has no faces with 3 or more vertices: nothing to render",
            ));
        }
        let normals = if self.has_normals {
            let unit: Option<Vec<DVec3>> = self.normals.iter().map(|&n| super::unit_normal(n)).collect();
            if unit.is_none() {
                self.warn("a vertex normal is zero; the normals are ignored (flat shading)".into());
            }
            unit
        } else {
            None
        };
        let uvs = self.has_uvs.then_some(self.uvs);
        for w in &self.warnings {
            log::warn!("{origin}: {w}");
        }
        let mesh = Mesh { positions: self.positions, normals, uvs, indices: self.indices, material: 0 };
        if self.groups.is_empty() {
            let kind = MaterialKind::Diffuse { color: DVec3::splat(DEFAULT_DIFFUSE_COLOR) };
            return Ok(Model {
                meshes: vec![mesh],
                materials: vec![Material::new("default", kind)],
                ..Default::default()
            });
        }
        Ok(split_by_colour(mesh, &self.groups, &self.group_sums))
    }
}

/// Skips an element, at once where the encoding allows.
fn skip<B: Body>(body: &mut B, e: &Element) -> Result<(), LoadError> {
    if e.properties.is_empty() || body.skip_fixed(e)? {
        return Ok(());
    }
    let plan = vec![Slot::Skip; e.properties.len()];
    instances(body, e, &plan, 0, |_, _, _, _| Ok(()))
}

/// Reads every instance of `e` by `plan`, calling `each(body, index, values, corners)`. Vertex
/// indices are checked against `vertex_count` as they are read, so errors point at the index.
/// An element without properties occupies nothing, in either encoding.
fn instances<B: Body>(
    body: &mut B,
    e: &Element,
    plan: &[Slot],
    vertex_count: u64,
    mut each: impl FnMut(&B, u64, &[f64; VALUES], &[u32]) -> Result<(), LoadError>,
) -> Result<(), LoadError> {
    if e.properties.is_empty() {
        return Ok(());
    }
    body.begin_element(e)?;
    let mut values = [0.0; VALUES];
    let mut corners: Vec<u32> = Vec::new();
    for index in 0..e.count {
        body.begin(e, index)?;
        for (p, &slot) in e.properties.iter().zip(plan) {
            let at = Place { element: &e.name, index, property: &p.name };
            match (p.kind, slot) {
                (Kind::Scalar(t), Slot::Value { k, scale }) => {
                    let v = body.value(t, at)?;
                    if !v.is_finite() {
                        return Err(body.error(format!(
                            "{} of {} {index} is {v}; numbers must be finite",
                            p.name, e.name
                        )));
                    }
                    values[k] = v * scale;
                }
                (Kind::Scalar(t), _) => body.skip(t, 1, at)?,
                (Kind::List { count, item }, slot) => {
                    let n = body.value(count, at)?;
                    if n < 0.0 {
                        return Err(body.error(format!("{} of {} {index} has {n} items", p.name, e.name)));
                    }
                    let n = n as u64;
                    if slot != Slot::Indices {
                        body.skip(item, n, at)?;
                        continue;
                    }
                    if n > MAX_POLYGON_VERTICES as u64 {
                        return Err(body.error(format!(
                            "face {index} has {n} vertices; irt reads polygons of at most {MAX_POLYGON_VERTICES}"
                        )));
                    }
                    body.require(item, n, at)?;
                    corners.clear();
                    for _ in 0..n {
                        let k = body.value(item, at)?;
                        if k < 0.0 || k >= vertex_count as f64 {
                            return Err(body.error(format!(
                                "face {index} has vertex index {k}, but there are {vertex_count} vertices"
                            )));
                        }
                        corners.push(k as u32);
                    }
                }
            }
        }
        body.end(e, index)?;
        each(body, index, &values, &corners)?;
    }
    Ok(())
}

/// A colour as stored, clamped to 0–1 (counting the clamps).
fn colour(v: &[f64], clamped: &mut u64) -> [f32; 3] {
    let mut c = [0.0f32; 3];
    for (c, &x) in c.iter_mut().zip(v) {
        if !(0.0..=1.0).contains(&x) {
            *clamped += 1;
        }
        *c = x.clamp(0.0, 1.0) as f32;
    }
    c
}

/// The colour group of a colour: its channels quantised to [`COLOUR_LEVELS`] each.
fn group_of(c: [f32; 3]) -> u16 {
    let level = |x: f32| ((x * COLOUR_LEVELS as f32) as usize).min(COLOUR_LEVELS - 1);
    (level(c[0]) * COLOUR_LEVELS * COLOUR_LEVELS + level(c[1]) * COLOUR_LEVELS + level(c[2])) as u16
}

/// One mesh and one diffuse material per colour group, in the order of the groups; each mesh
/// keeps the vertices its triangles use, in their first use's order. A single group keeps the
/// mesh whole.
fn split_by_colour(mesh: Mesh, groups: &[u16], sums: &[([f64; 3], u64)]) -> Model {
    let used: Vec<usize> = (0..sums.len()).filter(|&g| sums[g].1 > 0).collect();
    let material = |g: usize| {
        let (sum, n) = sums[g];
        let color = DVec3::from_array(sum.map(|s| srgb_to_linear((s / n as f64).clamp(0.0, 1.0))));
        // Named by the group's centre, which is unique to it.
        let levels =
            [g / (COLOUR_LEVELS * COLOUR_LEVELS), g / COLOUR_LEVELS % COLOUR_LEVELS, g % COLOUR_LEVELS];
        let hex: String = levels
            .iter()
            .map(|&l| format!("{:02x}", ((l as f64 + 0.5) / COLOUR_LEVELS as f64 * 255.0).round() as u8))
            .collect();
        Material::new(format!("colour #{hex}"), MaterialKind::Diffuse { color })
    };
    let materials: Vec<Material> = used.iter().map(|&g| material(g)).collect();
    if used.len() == 1 {
        return Model { meshes: vec![mesh], materials, ..Default::default() };
    }
    // Triangles by group (a counting sort keeps file order within a group).
    let mut start = vec![0usize; sums.len() + 1];
    for &g in groups {
        start[g as usize + 1] += 1;
    }
    for g in 0..sums.len() {
        start[g + 1] += start[g];
    }
    let mut order = vec![0u32; groups.len()];
    let mut next = start.clone();
    for (t, &g) in groups.iter().enumerate() {
        order[next[g as usize]] = t as u32;
        next[g as usize] += 1;
    }
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut meshes = Vec::with_capacity(used.len());
    for (m, &g) in used.iter().enumerate() {
        let triangles = &order[start[g]..start[g + 1]];
        let mut used_vertices: Vec<u32> = Vec::new();
        let indices: Vec<[u32; 3]> = triangles
            .iter()
            .map(|&t| {
                mesh.indices[t as usize].map(|v| {
                    let r = &mut remap[v as usize];
                    if *r == u32::MAX {
                        *r = used_vertices.len() as u32;
                        used_vertices.push(v);
                    }
                    *r
                })
            })
            .collect();
        let pick = |all: &[DVec3]| used_vertices.iter().map(|&v| all[v as usize]).collect::<Vec<_>>();
        meshes.push(Mesh {
            positions: pick(&mesh.positions),
            normals: mesh.normals.as_deref().map(&pick),
            uvs: mesh.uvs.as_ref().map(|uv| used_vertices.iter().map(|&v| uv[v as usize]).collect()),
            indices,
            material: m as u32,
        });
        for &v in &used_vertices {
            remap[v as usize] = u32::MAX;
        }
    }
    Model { meshes, materials, ..Default::default() }
}

// ---- Writing ---------------------------------------------------------------------------------

/// Writes `mesh` as PLY: x, y, z (with nx, ny, nz and u, v when it has them) and a
/// `list uchar uint vertex_indices` per triangle. Each group of values is written as `float`
/// when every value in it is exactly an f32, else as `double`, so that reading the file back
/// gives the same mesh bit for bit. The material is not written.
pub fn write(mesh: &Mesh, encoding: Encoding, out: impl Write) -> io::Result<()> {
    let mut w = io::BufWriter::with_capacity(1 << 20, out);
    let p = &mesh.positions;
    let type_of = |is_f32: bool| if is_f32 { Scalar::F32 } else { Scalar::F64 };
    let pos_t = type_of(all_f32(p.iter().flat_map(|v| v.to_array())));
    let normal_t = mesh.normals.as_ref().map(|n| type_of(all_f32(n.iter().flat_map(|v| v.to_array()))));
    let uv_t = mesh.uvs.as_ref().map(|uv| type_of(all_f32(uv.iter().flat_map(|v| v.to_array()))));
    writeln!(w, "ply\nformat {} 1.0\ncomment written by irt", encoding.name())?;
    writeln!(w, "element vertex {}", p.len())?;
    let props = |w: &mut dyn Write, t: Scalar, names: &[&str]| -> io::Result<()> {
        names.iter().try_for_each(|n| writeln!(w, "property {} {n}", t.name()))
    };
    props(&mut w, pos_t, &["x", "y", "z"])?;
    if let Some(t) = normal_t {
        props(&mut w, t, &["nx", "ny", "nz"])?;
    }
    if let Some(t) = uv_t {
        props(&mut w, t, &["u", "v"])?;
    }
    writeln!(w, "element face {}\nproperty list uchar uint vertex_indices\nend_header", mesh.indices.len())?;
    let value = |w: &mut dyn Write, t: Scalar, x: f64, first: bool| -> io::Result<()> {
        match (encoding, t) {
            (Encoding::Ascii, Scalar::F32) => write!(w, "{}{}", if first { "" } else { " " }, x as f32),
            (Encoding::Ascii, _) => write!(w, "{}{}", if first { "" } else { " " }, x),
            (Encoding::BinaryLittleEndian, Scalar::F32) => w.write_all(&(x as f32).to_le_bytes()),
            (Encoding::BinaryLittleEndian, _) => w.write_all(&x.to_le_bytes()),
            (Encoding::BinaryBigEndian, Scalar::F32) => w.write_all(&(x as f32).to_be_bytes()),
            (Encoding::BinaryBigEndian, _) => w.write_all(&x.to_be_bytes()),
        }
    };
    let newline = |w: &mut dyn Write| if encoding == Encoding::Ascii { writeln!(w) } else { Ok(()) };
    for i in 0..p.len() {
        for (k, x) in p[i].to_array().into_iter().enumerate() {
            value(&mut w, pos_t, x, k == 0)?;
        }
        if let (Some(t), Some(n)) = (normal_t, &mesh.normals) {
            n[i].to_array().into_iter().try_for_each(|x| value(&mut w, t, x, false))?;
        }
        if let (Some(t), Some(uv)) = (uv_t, &mesh.uvs) {
            uv[i].to_array().into_iter().try_for_each(|x| value(&mut w, t, x, false))?;
        }
        newline(&mut w)?;
    }
    for t in &mesh.indices {
        match encoding {
            Encoding::Ascii => writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?,
            Encoding::BinaryLittleEndian => {
                w.write_all(&[3])?;
                t.iter().try_for_each(|i| w.write_all(&i.to_le_bytes()))?;
            }
            Encoding::BinaryBigEndian => {
                w.write_all(&[3])?;
                t.iter().try_for_each(|i| w.write_all(&i.to_be_bytes()))?;
            }
        }
    }
    w.flush()
}

/// Whether every value is exactly an f32, so that `float` stores it without loss.
fn all_f32(values: impl IntoIterator<Item = f64>) -> bool {
    values.into_iter().all(|x| x as f32 as f64 == x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalars_decode_in_both_byte_orders() {
        for (t, le, be, want) in [
            (Scalar::I8, vec![0xfe], vec![0xfe], -2.0),
            (Scalar::U16, vec![0x34, 0x12], vec![0x12, 0x34], 4660.0),
            (Scalar::I32, (-5i32).to_le_bytes().to_vec(), (-5i32).to_be_bytes().to_vec(), -5.0),
            (Scalar::U32, u32::MAX.to_le_bytes().to_vec(), u32::MAX.to_be_bytes().to_vec(), u32::MAX as f64),
            (Scalar::F32, 0.1f32.to_le_bytes().to_vec(), 0.1f32.to_be_bytes().to_vec(), 0.1f32 as f64),
            (Scalar::F64, 0.1f64.to_le_bytes().to_vec(), 0.1f64.to_be_bytes().to_vec(), 0.1),
        ] {
            assert_eq!(decode::<false>(t, &le), want, "{t:?} little-endian");
            assert_eq!(decode::<true>(t, &be), want, "{t:?} big-endian");
        }
    }

    #[test]
    fn colour_groups_quantise_each_channel_and_are_unique() {
        assert_eq!(group_of([0.0, 0.0, 0.0]), 0);
        assert_eq!(group_of([1.0, 1.0, 1.0]) as usize, COLOUR_LEVELS.pow(3) - 1);
        assert_eq!(group_of([0.0, 0.0, 1.0 / 32.0]), 1);
        assert_eq!(group_of([0.0, 1.0 / 32.0, 0.0]), 32);
        assert_eq!(group_of([0.999, 0.0, 0.0]) as usize, 31 * 32 * 32);
    }
}
