//! anybox: zero-shot 9-DoF box pose and size from one RGB-D frame.

pub use anybox_eval as eval;
pub use anybox_geom as geom;
pub use anybox_io as io;
pub use anybox_synth as synth;
