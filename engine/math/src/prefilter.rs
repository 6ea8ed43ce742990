//! Prefiltered environment maps (written with the foundation).
