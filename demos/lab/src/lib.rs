//! The `lab` crate: everything that measures the engine. Error metrics ([`metrics`]) and converged references
//! ([`converge`]), one measurement of a technique against them ([`measure`], the `compare` binary), the report
//! sweep ([`report`]) and its results page (`report::page`), per-pass GPU times ([`bench`], [`capture`]),
//! the memory soak ([`soak`]), error and flicker over a clip ([`temporal`]), the Mitsuba 3 cross-check ([`export`]) and the SVG plots ([`plot`]). Its binaries
//! are in src/bin.

pub use plot;

pub mod bench;
pub mod capture;
pub mod converge;
pub mod export;
pub mod measure;
pub mod metrics;
pub mod report;
pub mod soak;
pub mod temporal;
