//! The methods of the evaluation, each behind [`crate::Method`] and each
//! trained from the same [`crate::TrainingData`]:
//!
//! * [`Ours`]: the paper's method (PCA + feature-analysis start + step 1 over
//!   the weights + step 2 over the vertices), `tapeshape_model::ShapeModel`.
//! * [`StepOneOnly`]: the same model without step 2: the optimisation stays
//!   inside the PCA space (as Baek and Lee).
//! * [`FeatureAnalysis`]: the linear map from measurements to PCA weights
//!   alone (Allen et al.), no refinement.
//! * [`Sgplvm`]: a shared Gaussian-process latent variable model of the
//!   measurements and the PCA weights (Ek et al.).
//! * [`RbfInterpolation`]: Gaussian radial basis function interpolation from
//!   measurements to PCA weights (Seo and Magnenat-Thalmann).
//! * [`GeneratorFit`]: the body generator's own parameters fitted to the
//!   measurements (what parametric-model tools do).
//!
//! Why one module per family: the paper's three variants share one trained
//! [`tapeshape_model::ShapeModel`] (fit once, pass it to each with
//! `from_model`), the learned baselines share only the PCA of the training
//! meshes, and the generator fit needs no training at all. How each baseline
//! is built, and why, is in `docs/baselines.md`.
//!
//! Units and frame everywhere: metres, station frame (Z up, +Y front, +X the
//! body's right). Targets are `M` values in the order of the training set's
//! compiled measurement set, `None` where not given.

mod common;
pub mod generator;
pub mod paper;
pub mod rbf;
pub mod sgplvm;

pub use common::training_weights;
pub use generator::{GeneratorFit, GeneratorFitSettings, GeneratorSolution};
pub use paper::{FeatureAnalysis, Ours, StepOneOnly};
pub use rbf::{RbfInterpolation, RbfSettings, Width};
pub use sgplvm::{Sgplvm, SgplvmSettings};
