//! Evaluation of the shape estimation (issue 6): the baselines the paper compares
//! with, behind the same predict interface as the method, and the paper's
//! experiments as commands that regenerate their tables and figures
//! (`cargo run --release -p tapeshape-eval -- NAME --out docs/results/NAME`,
//! `src/main.rs`).

pub mod customers;
pub mod experiments;
pub mod figures;
pub mod method;
pub mod methods;
pub mod poptable;
pub mod report;
pub mod sexcheck;
pub mod surface;

pub use method::{Method, MethodError, MethodOutput, TrainingData};
