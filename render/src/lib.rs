//! rift-render: the portal-aware CPU path tracer (in progress).
//!
//! It will build a scene from the same shot file as rift-fx (through [`rift_fx::Shot`]), load or
//! generate the ring curves, and trace light through portals. Until then this crate only fixes the
//! dependency direction: render depends on fx, never the reverse.

pub use rift_fx;
