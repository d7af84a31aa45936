//! The packed blend data: the MakeHuman base mesh and every morph target the
//! blend uses, in one zlib-compressed binary embedded in the crate.
//!
//! Why a pack instead of the 848 `.target.gz` files: the `tapeshape` binary
//! must be self-contained (no asset folder to ship or find at run time), load
//! in well under a second, and keep the git history small. Every target value
//! in the MakeHuman pack has at most 3 decimals (decimetres) and magnitude
//! below 8 dm, so it is stored **exactly** as an `i16` count of 1e-3 dm
//! (= 0.1 mm); the base mesh is stored as the `f64` values parsed from
//! `base.obj`. The pack therefore holds the sources losslessly, which the test
//! `tests/pack_matches_sources.rs` checks against the full pack file by file
//! (opt-in: `TAPESHAPE_SHARED=/path/to/shared`) and pins the embedded pack by
//! its SHA-256.
//!
//! Rebuild it (only needed if the source pack changes) with
//! `cargo run -p tapeshape-body --release --example pack_assets -- ../shared/assets/makehuman host/body/assets/makehuman/blend.pack.z`.
//!
//! Layout after zlib decompression (all little-endian):
//! ```text
//! magic  b"TSMHPACK"            8 bytes
//! version u32 (= 1)
//! n_base u32                     (19,158)
//! base   n_base * 3 f64          MakeHuman frame, decimetres (x, y, z)
//! n_targets u32
//! per target:
//!   name_len u16, name (UTF-8)   path relative to the pack root, e.g. "targets/torso/measure-waist-circ-incr.target.gz"
//!   n u32                        number of moved vertices
//!   index n * u16                base-mesh vertex index, as in the file (file order)
//!   dx n * i16, dy n * i16, dz n * i16   offsets in 1e-3 dm, MakeHuman frame
//! ```

use std::io::{Read, Write};
use std::path::Path;

/// The pack embedded in the crate (`assets/makehuman/blend.pack.z`), zlib-compressed.
pub static EMBEDDED: &[u8] = include_bytes!("../assets/makehuman/blend.pack.z");

/// Magic bytes opening a decompressed pack.
const MAGIC: &[u8; 8] = b"TSMHPACK";
/// Pack format version.
const VERSION: u32 = 1;
/// Number of vertices of the MakeHuman hm08 base mesh.
pub const N_BASE: usize = 19_158;

/// Errors reading the pack or the MakeHuman sources.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// Reading a file failed.
    #[error("cannot read {path}: {source}")]
    Io {
        /// File that failed.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// A source file has a line the recipe does not allow.
    #[error("{path}, line {line}: {what}")]
    Syntax {
        /// File.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        what: String,
    },
    /// The packed blob is damaged or of another version.
    #[error("the embedded blend pack is damaged: {0} (rebuild it with the pack_assets example)")]
    Corrupt(String),
}

/// One morph target: sparse offsets of base-mesh vertices.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawTarget {
    /// Path relative to the pack root (`targets/.../*.target.gz`).
    pub name: String,
    /// Base-mesh vertex indices (0..19,158), in file order.
    pub index: Vec<u16>,
    /// Offsets `[dx, dy, dz]` in units of 1e-3 decimetre (0.1 mm), MakeHuman frame.
    pub delta: Vec<[i16; 3]>,
}

/// The decoded pack: base mesh plus targets, in the MakeHuman frame and units.
#[derive(Debug, Clone, PartialEq)]
pub struct RawPack {
    /// Base-mesh vertices, decimetres, MakeHuman frame (+Y up, face toward +Z, +X = body's left).
    pub base: Vec<[f64; 3]>,
    /// Every target the blend uses.
    pub targets: Vec<RawTarget>,
}

/// The anchor names of the macro families, in the order the generator indexes them.
pub mod anchors {
    /// Gender anchors (anny: 0 = male, 1 = female).
    pub const GENDER: [&str; 2] = ["male", "female"];
    /// Adult age anchors (anny ages 2/3 and 1).
    pub const AGE: [&str; 2] = ["young", "old"];
    /// Muscle anchors (0, 0.5, 1).
    pub const MUSCLE: [&str; 3] = ["minmuscle", "averagemuscle", "maxmuscle"];
    /// Weight anchors (0, 0.5, 1).
    pub const WEIGHT: [&str; 3] = ["minweight", "averageweight", "maxweight"];
    /// Height anchors (0, 1).
    pub const HEIGHT: [&str; 2] = ["minheight", "maxheight"];
    /// Proportions anchors (0 ideal, 1 uncommon).
    pub const PROPORTIONS: [&str; 2] = ["idealproportions", "uncommonproportions"];
    /// Cup-size anchors (0, 0.5, 1).
    pub const CUP: [&str; 3] = ["mincup", "averagecup", "maxcup"];
    /// Firmness anchors (0, 0.5, 1).
    pub const FIRMNESS: [&str; 3] = ["minfirmness", "averagefirmness", "maxfirmness"];
    /// Race targets.
    pub const RACE: [&str; 3] = ["african", "asian", "caucasian"];
}

/// Path of a universal target.
pub fn universal_name(g: usize, a: usize, m: usize, w: usize) -> String {
    use anchors::*;
    format!(
        "targets/macrodetails/universal-{}-{}-{}-{}.target.gz",
        GENDER[g], AGE[a], MUSCLE[m], WEIGHT[w]
    )
}

/// Path of a race target.
pub fn race_name(r: usize, g: usize, a: usize) -> String {
    use anchors::*;
    format!(
        "targets/macrodetails/{}-{}-{}.target.gz",
        RACE[r], GENDER[g], AGE[a]
    )
}

/// Path of a height target.
pub fn height_name(g: usize, a: usize, m: usize, w: usize, h: usize) -> String {
    use anchors::*;
    format!(
        "targets/macrodetails/height/{}-{}-{}-{}-{}.target.gz",
        GENDER[g], AGE[a], MUSCLE[m], WEIGHT[w], HEIGHT[h]
    )
}

/// Path of a proportions target.
pub fn proportions_name(g: usize, a: usize, m: usize, w: usize, p: usize) -> String {
    use anchors::*;
    format!(
        "targets/macrodetails/proportions/{}-{}-{}-{}-{}.target.gz",
        GENDER[g], AGE[a], MUSCLE[m], WEIGHT[w], PROPORTIONS[p]
    )
}

/// Path of a breast target, or `None` for averagecup + averagefirmness (no such file: zero offset).
pub fn breast_name(a: usize, m: usize, w: usize, c: usize, f: usize) -> Option<String> {
    use anchors::*;
    if c == 1 && f == 1 {
        return None;
    }
    Some(format!(
        "targets/breast/female-{}-{}-{}-{}-{}.target.gz",
        AGE[a], MUSCLE[m], WEIGHT[w], CUP[c], FIRMNESS[f]
    ))
}

/// One row of `local_changes.tsv`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LocalChangeRow {
    /// The parameter name (anny's label).
    pub label: String,
    /// Target applied with weight x for x > 0.
    pub positive: String,
    /// Target applied with weight -x for x < 0.
    pub negative: String,
}

/// Parses `local_changes.tsv` (see the pack README 2.6).
pub fn parse_local_changes(text: &str, path: &str) -> Result<Vec<LocalChangeRow>, PackError> {
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let cols: Vec<&str> = line.split('\t').collect();
        if cols.len() < 5 {
            return Err(PackError::Syntax {
                path: path.into(),
                line: i + 1,
                what: format!(
                    "expected at least 5 tab-separated columns, found {}",
                    cols.len()
                ),
            });
        }
        if cols[0].parse::<usize>().ok() != Some(rows.len()) {
            return Err(PackError::Syntax {
                path: path.into(),
                line: i + 1,
                what: format!("index column {:?} is not {}", cols[0], rows.len()),
            });
        }
        rows.push(LocalChangeRow {
            label: cols[1].to_string(),
            positive: cols[3].to_string(),
            negative: cols[4].to_string(),
        });
    }
    Ok(rows)
}

/// Every target path the blend uses: the macro families (README 4.3) then
/// the local-change targets (README 4.4), each once, in a fixed order.
pub fn required_targets(local_changes: &[LocalChangeRow]) -> Vec<String> {
    let mut names = Vec::new();
    for g in 0..2 {
        for a in 0..2 {
            for m in 0..3 {
                for w in 0..3 {
                    names.push(universal_name(g, a, m, w));
                    for h in 0..2 {
                        names.push(height_name(g, a, m, w, h));
                    }
                    for p in 0..2 {
                        names.push(proportions_name(g, a, m, w, p));
                    }
                }
            }
            for r in 0..3 {
                names.push(race_name(r, g, a));
            }
        }
    }
    for a in 0..2 {
        for m in 0..3 {
            for w in 0..3 {
                for c in 0..3 {
                    for f in 0..3 {
                        names.extend(breast_name(a, m, w, c, f));
                    }
                }
            }
        }
    }
    for row in local_changes {
        for n in [&row.positive, &row.negative] {
            if !names.contains(n) {
                names.push(n.clone());
            }
        }
    }
    names
}

/// Parses a decimal with at most 3 decimals (`-.006`, `1.25`, `0`) exactly
/// into thousandths. Hand-written because the pack's value must be exact: a
/// float parse followed by rounding would hide a fourth decimal.
fn parse_milli(s: &str) -> Option<i64> {
    let (neg, body) = match s.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, s),
    };
    let (int, frac) = match body.split_once('.') {
        Some((i, f)) => (i, f),
        None => (body, ""),
    };
    if (int.is_empty() && frac.is_empty()) || frac.len() > 3 {
        return None;
    }
    if !int.bytes().all(|b| b.is_ascii_digit()) || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let i: i64 = if int.is_empty() { 0 } else { int.parse().ok()? };
    let mut f: i64 = if frac.is_empty() {
        0
    } else {
        frac.parse().ok()?
    };
    for _ in frac.len()..3 {
        f *= 10;
    }
    let v = i.checked_mul(1000)?.checked_add(f)?;
    Some(if neg { -v } else { v })
}

/// Parses the decompressed text of one `.target.gz` file (README 2.2).
pub fn parse_target_text(name: &str, text: &str) -> Result<RawTarget, PackError> {
    let mut index = Vec::new();
    let mut delta = Vec::new();
    let mut seen = vec![false; N_BASE];
    for (i, line) in text.lines().enumerate() {
        let err = |what: String| PackError::Syntax {
            path: name.to_string(),
            line: i + 1,
            what,
        };
        let mut it = line.split(' ');
        let (Some(vi), Some(x), Some(y), Some(z), None) =
            (it.next(), it.next(), it.next(), it.next(), it.next())
        else {
            return Err(err(format!("expected `i dx dy dz`, found {line:?}")));
        };
        let vi: usize = vi
            .parse()
            .map_err(|_| err(format!("bad vertex index {vi:?}")))?;
        if vi >= N_BASE {
            return Err(err(format!("vertex index {vi} >= {N_BASE}")));
        }
        if std::mem::replace(&mut seen[vi], true) {
            return Err(err(format!("vertex index {vi} listed twice")));
        }
        let mut d = [0i16; 3];
        for (k, s) in [x, y, z].into_iter().enumerate() {
            let v = parse_milli(s).ok_or_else(|| {
                err(format!(
                    "offset {s:?} is not a decimal with at most 3 decimals"
                ))
            })?;
            d[k] = i16::try_from(v)
                .map_err(|_| err(format!("offset {s:?} exceeds the pack's range")))?;
        }
        index.push(vi as u16);
        delta.push(d);
    }
    Ok(RawTarget {
        name: name.to_string(),
        index,
        delta,
    })
}

/// Reads one gzip target file of the MakeHuman pack.
pub fn read_target_gz(root: &Path, name: &str) -> Result<RawTarget, PackError> {
    let path = root.join(name);
    let io = |source| PackError::Io {
        path: path.display().to_string(),
        source,
    };
    let file = std::fs::File::open(&path).map_err(io)?;
    let mut text = String::new();
    flate2::read::GzDecoder::new(file)
        .read_to_string(&mut text)
        .map_err(io)?;
    let mut target = parse_target_text(&path.display().to_string(), &text)?;
    target.name = name.to_string();
    Ok(target)
}

/// Reads the `v` lines of `3dobjs/base.obj` (decimetres, MakeHuman frame).
pub fn read_base_obj(root: &Path) -> Result<Vec<[f64; 3]>, PackError> {
    let path = root.join("3dobjs/base.obj");
    let text = std::fs::read_to_string(&path).map_err(|source| PackError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let mut base = Vec::with_capacity(N_BASE);
    for (i, line) in text.lines().enumerate() {
        if let Some(rest) = line.strip_prefix("v ") {
            let v: Vec<f64> = rest
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|e| PackError::Syntax {
                    path: path.display().to_string(),
                    line: i + 1,
                    what: format!("bad vertex: {e}"),
                })?;
            if v.len() != 3 {
                return Err(PackError::Syntax {
                    path: path.display().to_string(),
                    line: i + 1,
                    what: "a `v` line needs 3 coordinates".into(),
                });
            }
            base.push([v[0], v[1], v[2]]);
        }
    }
    if base.len() != N_BASE {
        return Err(PackError::Syntax {
            path: path.display().to_string(),
            line: 0,
            what: format!("{} vertices, expected {N_BASE}", base.len()),
        });
    }
    Ok(base)
}

/// Reads everything the blend needs from the MakeHuman pack folder at `root`
/// (e.g. `../shared/assets/makehuman`).
pub fn read_sources(root: &Path) -> Result<RawPack, PackError> {
    let tsv_path = root.join("local_changes.tsv");
    let tsv = std::fs::read_to_string(&tsv_path).map_err(|source| PackError::Io {
        path: tsv_path.display().to_string(),
        source,
    })?;
    let rows = parse_local_changes(&tsv, &tsv_path.display().to_string())?;
    let base = read_base_obj(root)?;
    let targets = required_targets(&rows)
        .iter()
        .map(|n| read_target_gz(root, n))
        .collect::<Result<_, _>>()?;
    Ok(RawPack { base, targets })
}

impl RawPack {
    /// Serialises and zlib-compresses the pack (layout in the module docs).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(self.base.len() as u32).to_le_bytes());
        for v in &self.base {
            for c in v {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out.extend_from_slice(&(self.targets.len() as u32).to_le_bytes());
        for t in &self.targets {
            out.extend_from_slice(&(t.name.len() as u16).to_le_bytes());
            out.extend_from_slice(t.name.as_bytes());
            out.extend_from_slice(&(t.index.len() as u32).to_le_bytes());
            for i in &t.index {
                out.extend_from_slice(&i.to_le_bytes());
            }
            for k in 0..3 {
                for d in &t.delta {
                    out.extend_from_slice(&d[k].to_le_bytes());
                }
            }
        }
        let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(&out).expect("writing to a Vec cannot fail");
        enc.finish().expect("writing to a Vec cannot fail")
    }

    /// Decompresses and parses a pack made by [`RawPack::encode`].
    pub fn decode(compressed: &[u8]) -> Result<Self, PackError> {
        let mut raw = Vec::new();
        flate2::read::ZlibDecoder::new(compressed)
            .read_to_end(&mut raw)
            .map_err(|e| PackError::Corrupt(format!("zlib: {e}")))?;
        let mut r = Reader { buf: &raw, pos: 0 };
        if r.take(8)? != MAGIC {
            return Err(PackError::Corrupt("bad magic".into()));
        }
        let version = r.u32()?;
        if version != VERSION {
            return Err(PackError::Corrupt(format!(
                "version {version}, this build reads {VERSION}"
            )));
        }
        let n_base = r.u32()? as usize;
        if n_base != N_BASE {
            return Err(PackError::Corrupt(format!("{n_base} base vertices")));
        }
        let mut base = Vec::with_capacity(n_base);
        for _ in 0..n_base {
            base.push([r.f64()?, r.f64()?, r.f64()?]);
        }
        let n_targets = r.u32()? as usize;
        let mut targets = Vec::with_capacity(n_targets);
        for _ in 0..n_targets {
            let len = r.u16()? as usize;
            let name = std::str::from_utf8(r.take(len)?)
                .map_err(|_| PackError::Corrupt("target name is not UTF-8".into()))?
                .to_string();
            let n = r.u32()? as usize;
            let mut index = Vec::with_capacity(n);
            for _ in 0..n {
                let i = r.u16()?;
                if i as usize >= N_BASE {
                    return Err(PackError::Corrupt(format!("{name}: vertex {i}")));
                }
                index.push(i);
            }
            let mut delta = vec![[0i16; 3]; n];
            for k in 0..3 {
                for d in delta.iter_mut() {
                    d[k] = r.u16()? as i16;
                }
            }
            targets.push(RawTarget { name, index, delta });
        }
        if r.pos != raw.len() {
            return Err(PackError::Corrupt("trailing bytes".into()));
        }
        Ok(RawPack { base, targets })
    }
}

/// Little-endian cursor over the decompressed pack.
struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], PackError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.buf.len())
            .ok_or_else(|| PackError::Corrupt("truncated".into()))?;
        let s = &self.buf[self.pos..end];
        self.pos = end;
        Ok(s)
    }
    fn u16(&mut self) -> Result<u16, PackError> {
        Ok(u16::from_le_bytes(
            self.take(2)?.try_into().expect("2 bytes"),
        ))
    }
    fn u32(&mut self) -> Result<u32, PackError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn f64(&mut self) -> Result<f64, PackError> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn milli_parse_is_exact() {
        assert_eq!(parse_milli("-.006"), Some(-6));
        assert_eq!(parse_milli(".0123"), None);
        assert_eq!(parse_milli("7.214"), Some(7214));
        assert_eq!(parse_milli("0"), Some(0));
        assert_eq!(parse_milli("-1.5"), Some(-1500));
        assert_eq!(parse_milli("12"), Some(12000));
        assert_eq!(parse_milli("-"), None);
        assert_eq!(parse_milli("1e3"), None);
    }

    #[test]
    fn target_text_errors_name_the_line() {
        let e = parse_target_text("t", "1 0 0 0\n1 0 0 0\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        assert!(parse_target_text("t", "99999 0 0 0").is_err());
        assert!(parse_target_text("t", "1 0 0").is_err());
    }

    #[test]
    fn encode_decode_round_trip() {
        let pack = RawPack {
            base: (0..N_BASE).map(|i| [i as f64 * 0.1, -1.5, 2.25]).collect(),
            targets: vec![
                RawTarget {
                    name: "a".into(),
                    index: vec![3, 1, 19157],
                    delta: vec![[1, -2, 3], [-7214, 0, 5], [32767, -32768, 0]],
                },
                RawTarget {
                    name: "empty".into(),
                    index: vec![],
                    delta: vec![],
                },
            ],
        };
        let blob = pack.encode();
        assert_eq!(RawPack::decode(&blob).unwrap(), pack);
        assert!(RawPack::decode(&blob[..blob.len() / 2]).is_err());
    }
}
