//! Simulated tape measure, fault injection and pseudo-terminal wiring for tests and the demo.
