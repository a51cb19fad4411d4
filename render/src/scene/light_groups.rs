//! Light groups: emitters (objects, each opening's ring, the environment) may name a
//! `light_group`; the renderer then writes, beside the beauty, one `lightgroup.<name>` layer per
//! group (the rest in `lightgroup.default`), and the layers sum to the beauty, so a compositor
//! can dial each light's contribution after the render.

use crate::error::{RenderError, key_error};
use std::path::Path;

/// Groups a scene may have, the default one included (each costs 24 bytes a pixel while
/// rendering).
pub const MAX_LIGHT_GROUPS: usize = 8;

/// The name of the group of every emitter that names none.
pub const DEFAULT_GROUP: &str = "default";

/// The groups named so far; index 0 is the default group.
pub(crate) struct LightGroups {
    names: Vec<String>,
}

impl LightGroups {
    pub fn new() -> Self {
        Self {
            names: vec![DEFAULT_GROUP.to_owned()],
        }
    }

    /// The index of the group `name` (0 when `None`), adding it when new; `key` is where the
    /// shot gave it, for errors.
    pub fn index(&mut self, file: &Path, key: &str, name: Option<&str>) -> Result<u8, RenderError> {
        let Some(name) = name else {
            return Ok(0);
        };
        let valid = !name.is_empty()
            && name.len() <= 64
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !valid {
            return Err(key_error(
                file,
                key,
                format!(
                    "{name:?}: a light group is named with letters, digits and `_` (it becomes \
                     the EXR layer lightgroup.<name>)"
                ),
            ));
        }
        if let Some(i) = self.names.iter().position(|n| n == name) {
            return Ok(i as u8);
        }
        if self.names.len() == MAX_LIGHT_GROUPS {
            return Err(key_error(
                file,
                key,
                format!(
                    "{name:?} would be light group {}; a shot may have at most {} besides the \
                     default",
                    self.names.len(),
                    MAX_LIGHT_GROUPS - 1
                ),
            ));
        }
        self.names.push(name.to_owned());
        Ok((self.names.len() - 1) as u8)
    }

    /// The groups' names, the default first; empty when the shot names none (no layers, and
    /// nothing to track while rendering).
    pub fn names(self) -> Vec<String> {
        if self.names.len() > 1 {
            self.names
        } else {
            Vec::new()
        }
    }
}
