//! The Wuhrer & Shu shape model: PCA, feature analysis, L-BFGS refinement.
