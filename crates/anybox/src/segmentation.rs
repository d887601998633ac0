//! (stage module; being written)
