//! Synthetic warehouse-like RGB-D scenes in BOP layout (SPEC §5).
