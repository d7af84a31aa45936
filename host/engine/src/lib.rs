//! The tapeshape shape engine: bodies, measurements, populations, model training and prediction (no serial, no UI).
