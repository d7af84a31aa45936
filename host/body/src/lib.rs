//! MakeHuman-based adult body generator, template landmarks and body parts.
