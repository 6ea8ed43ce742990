pub use engine_blockers as blockers;
pub use engine_math as math;
