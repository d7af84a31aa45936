//! Model files on disk and in the program: plain or gzip-compressed (a
//! `.gz` name; detected by its magic when read), and the default model
//! embedded at build time.

use tapeshape_model::ModelFile;

use crate::PredictError;

/// Writes a model file gzip-compressed when `path` ends in `.gz`, plain
/// otherwise, with the one atomic, fsynced write
/// ([`tapeshape_common::fs::write_atomic`]).
pub fn save_model(file: &ModelFile, path: &std::path::Path) -> Result<(), PredictError> {
    let gz = path.extension().is_some_and(|e| e == "gz");
    if !gz {
        return Ok(file.save(path)?);
    }
    let bytes = file.to_bytes()?;
    let io = |source| PredictError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut enc, &bytes).map_err(io)?;
    let compressed = enc.finish().map_err(io)?;
    tapeshape_common::fs::write_atomic(path, &compressed).map_err(io)
}

/// Reads a model file, plain or gzip-compressed (detected by its magic).
pub fn load_model_bytes(bytes: &[u8], origin: &str) -> Result<ModelFile, PredictError> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(bytes), &mut out).map_err(
            |e| PredictError::Input(format!("{origin}: damaged compressed model file: {e}")),
        )?;
        Ok(ModelFile::from_bytes(&out, origin)?)
    } else {
        Ok(ModelFile::from_bytes(bytes, origin)?)
    }
}

/// The embedded default model (gzip of a model file).
pub(crate) static DEFAULT_MODEL: &[u8] = include_bytes!("../models/default.tsm.gz");
