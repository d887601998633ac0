//! Evaluation of 9-DoF box estimates (SPEC §4).
