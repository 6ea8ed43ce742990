//! (work in progress: see the math issue)
