//! The kiosk terminal interface (ratatui + crossterm) of `tapeshape station`
//! and `tapeshape demo` (issue 5).
