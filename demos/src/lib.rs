//! The demos: the `demo` binary (src/main.rs) and the interactive viewer. The scenes are the `scenes` crate
//! (demos/scenes), the measuring machinery the `lab` crate (demos/lab).

pub mod viewer;
