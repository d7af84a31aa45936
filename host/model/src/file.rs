//! The versioned model file (specified in `docs/model-format.md`).
//!
//! Layout: 8-byte magic `TSMODEL\0`, format version (u32 little-endian),
//! body length in bytes (u64 LE), the body (postcard encoding of
//! [`ModelFile`]'s fields), CRC-32 (IEEE) of the body (u32 LE). postcard is
//! compact and exact for f64 (raw IEEE bits); the header lets a reader refuse
//! a foreign or newer file with a clear message before decoding anything, and
//! the checksum catches truncation and corruption.

use std::path::Path;

use tapeshape_mesh::Anatomy;

use crate::{ModelError, Result, ShapeModel};

/// The file's magic bytes.
pub const MAGIC: [u8; 8] = *b"TSMODEL\0";
/// The format version this build writes. It reads this one and version 1
/// (before the sex priors: such a model predicts without them).
pub const FORMAT_VERSION: u32 = 2;

/// A version-1 body: [`ModelFile`] before [`ShapeModel::sex_priors`]
/// (postcard is not self-describing, so the old layout is spelled out).
#[derive(serde::Deserialize)]
struct ModelFileV1 {
    provenance: Provenance,
    template: TemplateInfo,
    measurement_set: MeasurementSetText,
    model: ShapeModelV1,
}

#[derive(serde::Deserialize)]
struct ShapeModelV1 {
    measurement_names: Vec<String>,
    pca: crate::pca::Pca,
    feature_map: crate::regress::FeatureMap,
    joint: crate::regress::JointGaussian,
    n_training: usize,
}

impl From<ModelFileV1> for ModelFile {
    fn from(v: ModelFileV1) -> Self {
        let m = v.model;
        ModelFile {
            provenance: v.provenance,
            template: v.template,
            measurement_set: v.measurement_set,
            model: ShapeModel {
                measurement_names: m.measurement_names,
                pca: m.pca,
                feature_map: m.feature_map,
                joint: m.joint,
                n_training: m.n_training,
                sex_priors: None,
            },
        }
    }
}

/// The template the model was trained on: its faces and anatomy.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TemplateInfo {
    /// Number of vertices V.
    pub n_vertices: usize,
    /// Triangles (counter-clockwise seen from outside), indices into the vertices.
    pub faces: Vec<[u32; 3]>,
    /// Landmarks and parts.
    pub anatomy: Anatomy,
}

/// The measurement set definitions, kept as the text they were read from so
/// that this crate does not parse them (`tapeshape-estimator` does, with `tapeshape-measure`).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeasurementSetText {
    /// Set name (e.g. `paper34`).
    pub name: String,
    /// Text format of `text` (e.g. `toml`).
    pub format: String,
    /// The definitions.
    pub text: String,
}

/// Where a model came from.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Provenance {
    /// Dataset file or description.
    pub dataset: String,
    /// Tool and version that trained it.
    pub trained_by: String,
    /// Creation time, RFC 3339 UTC.
    pub created: String,
    /// Free-form notes (settings, seeds).
    pub notes: String,
}

/// Everything a station needs to predict: template, measurement set, model.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ModelFile {
    /// Provenance.
    pub provenance: Provenance,
    /// The template topology and anatomy.
    pub template: TemplateInfo,
    /// The measurement set definitions.
    pub measurement_set: MeasurementSetText,
    /// The learned model.
    pub model: ShapeModel,
}

impl ModelFile {
    /// Encodes the file into bytes (header, body, checksum).
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let body = postcard::to_stdvec(self).map_err(|e| ModelError::File {
            path: String::new(),
            message: format!("encoding failed: {e}"),
        })?;
        let mut out = Vec::with_capacity(body.len() + 24);
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
        Ok(out)
    }

    /// Decodes and validates a file's bytes; `path` only names the file in errors.
    pub fn from_bytes(bytes: &[u8], path: &str) -> Result<Self> {
        let err = |message: String| ModelError::File {
            path: path.to_string(),
            message,
        };
        if bytes.len() < 20 || bytes[..8] != MAGIC {
            return Err(err(
                "not a tapeshape model file (bad magic); train one with `tapeshape train`".into(),
            ));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != FORMAT_VERSION && version != 1 {
            return Err(err(format!(
                "format version {version}, this build reads version {FORMAT_VERSION}: use a matching tapeshape or retrain"
            )));
        }
        let len = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
        let rest = &bytes[20..];
        if (rest.len() as u64) < len.saturating_add(4) {
            return Err(err(format!(
                "truncated: the header announces {len} body bytes, the file holds {}",
                rest.len().saturating_sub(4)
            )));
        }
        let len = len as usize;
        let body = &rest[..len];
        let crc = u32::from_le_bytes(rest[len..len + 4].try_into().expect("4 bytes"));
        if crc != crc32fast::hash(body) {
            return Err(err("corrupt: checksum mismatch; copy the file again".into()));
        }
        if rest.len() != len + 4 {
            return Err(err("trailing bytes after the checksum".into()));
        }
        let file: ModelFile = if version == 1 {
            postcard::from_bytes::<ModelFileV1>(body)
                .map_err(|e| err(format!("cannot decode the body: {e}")))?
                .into()
        } else {
            postcard::from_bytes(body).map_err(|e| err(format!("cannot decode the body: {e}")))?
        };
        file.validate().map_err(|e| err(e.to_string()))?;
        Ok(file)
    }

    /// Checks that template, measurement set and model agree.
    pub fn validate(&self) -> Result<()> {
        self.model.validate()?;
        let v = self.model.n_vertices();
        if self.template.n_vertices != v {
            return Err(ModelError::InvalidInput(format!(
                "template has {} vertices, the model {v}",
                self.template.n_vertices
            )));
        }
        if let Some(f) = self
            .template
            .faces
            .iter()
            .find(|f| f.iter().any(|&i| i as usize >= v))
        {
            return Err(ModelError::InvalidInput(format!(
                "template face {f:?} refers to a vertex beyond {v}"
            )));
        }
        Ok(())
    }

    /// Writes the file with the one atomic, fsynced write
    /// ([`tapeshape_common::fs::write_atomic`]): a reader sees the old
    /// model or the whole new one.
    pub fn save(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes()?;
        tapeshape_common::fs::write_atomic(path, &bytes).map_err(|source| ModelError::Io {
            path: path.display().to_string(),
            source,
        })
    }

    /// Reads and validates a model file.
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|source| ModelError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }
}
