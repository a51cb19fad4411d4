//! Preparing a scene for rendering: the measuring and training passes that run once per scene.

pub mod exits;
