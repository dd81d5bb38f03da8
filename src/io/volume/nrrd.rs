//! NRRD (teem's "nearly raw raster data", formats NRRD0001–NRRD0005): a text header of
//! `field: value` lines (`#` comments, `key:=value` pairs ignored) that ends at a blank line,
//! followed by the data; or a detached header (`.nhdr`) whose `data file` names it, relative to
//! the header. Encodings raw, gzip and ascii; a three-dimensional scalar grid (a leading axis of
//! size 1 is dropped). Spacing from `spacings` or `space directions`, origin from `space origin`.

use super::{aligned_grid, gunzip, voxel_count};
use crate::io::scalar::Scalar;
use crate::io::LoadError;
use crate::scene::volume::Grid;
use glam::DVec3;
use std::path::Path;

/// A header is a few hundred bytes; more than this is not a NRRD header.
const MAX_HEADER_BYTES: usize = 1 << 20;

pub fn load(path: &Path) -> Result<Grid, LoadError> {
    let shown = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| LoadError::new(&shown, e.to_string()))?;
    parse(&bytes, path)
}

/// The fields of a header that irt uses.
#[derive(Default)]
struct Header {
    sample: Option<Scalar>,
    dimension: Option<usize>,
    sizes: Vec<u64>,
    encoding: Option<String>,
    big_endian: bool,
    spacings: Option<Vec<f64>>,
    directions: Option<Vec<Option<DVec3>>>,
    origin: Option<DVec3>,
    data_file: Option<String>,
    line_skip: usize,
    byte_skip: i64,
}

/// A NRRD file's bytes (`path`: where it is, for a detached data file and for messages).
pub fn parse(bytes: &[u8], path: &Path) -> Result<Grid, LoadError> {
    let shown = path.display().to_string();
    let head = &bytes[..bytes.len().min(MAX_HEADER_BYTES)];
    // The header is text up to its blank line; the data after it may be anything.
    let end = find_blank_line(head);
    let text_end = end.map_or(head.len(), |(at, _)| at);
    let text = std::str::from_utf8(&head[..text_end])
        .map_err(|e| LoadError::new(&shown, format!("the header is not text (byte {})", e.valid_up_to())))?;
    let fail = |offset: usize, m: String| LoadError::at(&shown, text, offset, m);
    if !text.starts_with("NRRD000") || !matches!(text.as_bytes().get(7), Some(b'1'..=b'5')) {
        return Err(LoadError::new(&shown, "not a NRRD file: it starts without NRRD0001 to NRRD0005"));
    }
    let mut h = Header::default();
    let mut offset = 0;
    for (n, line) in text.split('\n').enumerate() {
        let at = offset;
        offset += line.len() + 1;
        let line = line.trim_end_matches('\r');
        if n == 0 || line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        if line.contains(":=") && !line.contains(": ") {
            continue; // a key/value pair: not irt's
        }
        let Some((field, value)) = line.split_once(": ") else {
            return Err(fail(at, format!("`{line}` is neither `field: value` nor `key:=value`")));
        };
        let value = value.trim();
        let at_value = at + field.len() + 2;
        field_into(&mut h, &field.to_ascii_lowercase(), value).map_err(|m| fail(at_value, m))?;
    }
    let need = |what: &str| LoadError::new(&shown, format!("the header has no `{what}` field"));
    let sample = h.sample.ok_or_else(|| need("type"))?;
    let dimension = h.dimension.ok_or_else(|| need("dimension"))?;
    if h.sizes.len() != dimension {
        let m = format!("`sizes` gives {} sizes for dimension {dimension}", h.sizes.len());
        return Err(LoadError::new(&shown, m));
    }
    // A leading axis of one sample (a scalar written as a 1-vector) is no axis.
    let skip = usize::from(dimension == 4 && h.sizes[0] == 1);
    if dimension - skip != 3 {
        let m = format!(
            "a {dimension}-dimensional grid of sizes {:?}: irt reads 3-dimensional scalar grids",
            h.sizes
        );
        return Err(LoadError::new(&shown, m));
    }
    let dims = [h.sizes[skip], h.sizes[skip + 1], h.sizes[skip + 2]];
    let n = voxel_count(dims).map_err(|m| LoadError::new(&shown, m))? as usize;
    let want = n * sample.size();
    let encoding = h.encoding.clone().ok_or_else(|| need("encoding"))?;

    let (data, data_name): (std::borrow::Cow<[u8]>, String) = match &h.data_file {
        None => {
            let Some((_, start)) = end else {
                return Err(LoadError::new(&shown, "the header names no `data file` and no data follows it"));
            };
            (bytes[start..].into(), shown.clone())
        }
        Some(file) => {
            let dir = path.parent().unwrap_or(Path::new("."));
            let data_path = dir.join(file);
            let name = data_path.display().to_string();
            let d = std::fs::read(&data_path)
                .map_err(|e| LoadError::new(&shown, format!("its data file {name}: {e}")))?;
            (d.into(), name)
        }
    };
    let data = skip_lines(&data, h.line_skip).map_err(|m| LoadError::new(&data_name, m))?;
    let raw = match encoding.as_str() {
        "raw" => {
            let from = byte_skip(data.len(), want, h.byte_skip).map_err(|m| LoadError::new(&data_name, m))?;
            let body = &data[from..];
            if body.len() < want {
                let m = format!(
                    "{} bytes of data; {n} samples of {} bytes need {want}",
                    body.len(),
                    sample.size()
                );
                return Err(LoadError::new(&data_name, m));
            }
            std::borrow::Cow::Borrowed(&body[..want])
        }
        "gzip" | "gz" => gunzip(data, want).map_err(|m| LoadError::new(&data_name, m))?.into(),
        "ascii" | "text" | "txt" => return ascii(data, dims, &h, &data_name),
        other => {
            let m = format!("encoding `{other}`: irt reads raw, gzip and ascii NRRD data");
            return Err(LoadError::new(&shown, m));
        }
    };
    grid(dims, &h, sample.decode_voxels(&raw, h.big_endian)).map_err(|m| LoadError::new(&shown, m))
}

/// Where the blank line that ends an attached header is: its start, and where the data begins.
fn find_blank_line(b: &[u8]) -> Option<(usize, usize)> {
    (0..b.len()).find_map(|i| {
        if b[i] != b'\n' {
            return None;
        }
        match (b.get(i + 1), b.get(i + 2)) {
            (Some(b'\n'), _) => Some((i + 1, i + 2)),
            (Some(b'\r'), Some(b'\n')) => Some((i + 1, i + 3)),
            _ => None,
        }
    })
}

fn field_into(h: &mut Header, field: &str, value: &str) -> Result<(), String> {
    let count = |v: &str| v.parse::<u64>().map_err(|_| format!("`{v}` is not a count"));
    let number = |v: &str| v.parse::<f64>().map_err(|_| format!("`{v}` is not a number"));
    match field {
        "type" => h.sample = Some(sample_type(value)?),
        "dimension" => h.dimension = Some(count(value)? as usize),
        "sizes" => h.sizes = value.split_whitespace().map(count).collect::<Result<_, _>>()?,
        "encoding" => h.encoding = Some(value.to_ascii_lowercase()),
        "endian" => {
            h.big_endian = match value {
                "big" => true,
                "little" => false,
                v => return Err(format!("endian `{v}`: give little or big")),
            }
        }
        "spacings" => {
            let s = value.split_whitespace().filter(|s| *s != "nan" && *s != "NaN").map(number);
            h.spacings = Some(s.collect::<Result<_, _>>()?);
        }
        "space directions" => {
            let d =
                value.split_whitespace().map(|d| if d == "none" { Ok(None) } else { vector(d).map(Some) });
            h.directions = Some(d.collect::<Result<_, _>>()?);
        }
        "space origin" => h.origin = Some(vector(value)?),
        "data file" | "datafile" => {
            if value.starts_with("LIST") || value.contains('%') {
                return Err(format!("data file `{value}`: irt reads one data file, not a list or pattern"));
            }
            h.data_file = Some(value.to_string());
        }
        "line skip" | "lineskip" => h.line_skip = count(value)? as usize,
        "byte skip" | "byteskip" => {
            h.byte_skip = value.parse().map_err(|_| format!("`{value}` is not a byte count (or -1)"))?
        }
        "kinds"
            if value
                .split_whitespace()
                .any(|k| k.contains("vector") || k.contains("RGB") || k.contains("complex")) =>
        {
            return Err(format!("kinds `{value}`: irt reads grids of one scalar a sample"));
        }
        // Fields that do not change where samples are or what they hold.
        _ => {}
    }
    Ok(())
}

fn sample_type(v: &str) -> Result<Scalar, String> {
    Ok(match v {
        "signed char" | "int8" | "int8_t" => Scalar::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => Scalar::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => Scalar::I16,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => Scalar::U16,
        "int" | "signed int" | "int32" | "int32_t" => Scalar::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => Scalar::U32,
        "float" => Scalar::F32,
        "double" => Scalar::F64,
        other => {
            return Err(format!("type `{other}`: irt reads 8-, 16- and 32-bit integers, float and double"))
        }
    })
}

/// `(x,y,z)`.
fn vector(v: &str) -> Result<DVec3, String> {
    let inner = v.trim().strip_prefix('(').and_then(|s| s.strip_suffix(')'));
    let parts: Vec<f64> = inner
        .ok_or_else(|| format!("`{v}` is not a vector like (1,0,0)"))?
        .split(',')
        .map(|p| p.trim().parse::<f64>().map_err(|_| format!("`{v}` is not a vector like (1,0,0)")))
        .collect::<Result<_, _>>()?;
    match parts[..] {
        [x, y, z] => Ok(DVec3::new(x, y, z)),
        _ => Err(format!("`{v}` has {} components; irt reads 3-dimensional space", parts.len())),
    }
}

fn skip_lines(data: &[u8], lines: usize) -> Result<&[u8], String> {
    let mut rest = data;
    for n in 0..lines {
        let at = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or(format!("`line skip` {lines}: the data has {n} lines"))?;
        rest = &rest[at + 1..];
    }
    Ok(rest)
}

/// Where raw data starts: `skip` bytes in, or (-1) the last `want` bytes.
fn byte_skip(len: usize, want: usize, skip: i64) -> Result<usize, String> {
    match skip {
        -1 => len.checked_sub(want).ok_or(format!("{len} bytes of data; the samples need {want}")),
        s if s >= 0 => Ok((s as usize).min(len)),
        s => Err(format!("`byte skip` {s}: give a count of bytes or -1")),
    }
}

/// Text samples, kept as float32 whatever `type` says (exact in it up to 2^24).
fn ascii(data: &[u8], dims: [u64; 3], h: &Header, name: &str) -> Result<Grid, LoadError> {
    let text = std::str::from_utf8(data).map_err(|_| LoadError::new(name, "ascii data that is not text"))?;
    let n = dims.iter().product::<u64>() as usize;
    // A number takes two bytes of text at least: no more room than the text can fill.
    let mut values = Vec::with_capacity(n.min(text.len() / 2 + 1));
    for (i, word) in text.split_whitespace().enumerate() {
        if i == n {
            return Err(LoadError::new(name, format!("more than the {n} samples the header promises")));
        }
        let v: f64 =
            word.parse().map_err(|_| LoadError::new(name, format!("sample {i} `{word}` is not a number")))?;
        values.push(v as f32);
    }
    if values.len() < n {
        return Err(LoadError::new(name, format!("{} samples; the header promises {n}", values.len())));
    }
    grid(dims, h, crate::scene::volume::Voxels::F32(values)).map_err(|m| LoadError::new(name, m))
}

fn grid(dims: [u64; 3], h: &Header, voxels: crate::scene::volume::Voxels) -> Result<Grid, String> {
    let dims = dims.map(|d| d as u32);
    let directions: [DVec3; 3] = match (&h.directions, &h.spacings) {
        (Some(d), _) => {
            let spatial: Vec<DVec3> = d.iter().flatten().copied().collect();
            spatial.try_into().map_err(|v: Vec<DVec3>| {
                format!("`space directions` gives {} spatial axes, not 3", v.len())
            })?
        }
        (None, Some(s)) if s.len() >= 3 => {
            let s = &s[s.len() - 3..];
            [DVec3::X * s[0], DVec3::Y * s[1], DVec3::Z * s[2]]
        }
        (None, Some(s)) => return Err(format!("`spacings` gives {} numbers for 3 axes", s.len())),
        (None, None) => [DVec3::X, DVec3::Y, DVec3::Z],
    };
    aligned_grid(dims, directions, h.origin.unwrap_or(DVec3::ZERO), voxels)
}
