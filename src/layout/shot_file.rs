//! The shot file being staged: its text as `rift layout` read (or last saved) it, and as edited
//! in the page since, as a format-preserving TOML document (toml_edit), so comments and layout
//! stay. An edit is kept only once the edited text loads as a shot; saving writes the edits
//! after a backup (`<shot>.toml.bak`), atomically, and refuses when the file has changed on disk
//! since it was read, rather than overwrite someone else's work.

use super::edit::{self, Edit};
use rift_render::rift_fx::Shot;
use rift_render::rift_fx::export::atomic;
use std::path::{Path, PathBuf};
use toml_edit::DocumentMut;

/// The staged shot file.
pub struct ShotFile {
    path: PathBuf,
    /// The text on disk, as read or last saved.
    saved: String,
    /// The text as edited.
    doc: DocumentMut,
}

impl ShotFile {
    pub fn open(path: &Path) -> Result<Self, String> {
        let saved = read(path)?;
        let doc = saved
            .parse()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(Self {
            path: path.to_owned(),
            saved,
            doc,
        })
    }

    pub fn doc(&self) -> &DocumentMut {
        &self.doc
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// True when edits have not been saved.
    pub fn unsaved(&self) -> bool {
        self.doc.to_string() != self.saved
    }

    /// The document with `edit` applied to `shot` (the document as it loads) and the shot the
    /// result loads as, or why not (naming the file and what was edited).
    pub fn edited(&self, edit: &Edit, shot: &Shot) -> Result<(DocumentMut, Shot), String> {
        let mut doc = self.doc.clone();
        edit::apply(&mut doc, edit, shot)
            .map_err(|e| format!("{}: {}: {e}", self.path.display(), edit.what()))?;
        let shot = Shot::parse(&doc.to_string(), &self.path).map_err(|e| e.to_string())?;
        let shot = crate::cli::with_usd_camera(shot, "layout").map_err(|e| format!("{e:#}"))?;
        Ok((doc, shot))
    }

    /// Keeps an edited document (checked by the caller).
    pub fn keep(&mut self, doc: DocumentMut) {
        self.doc = doc;
    }

    /// Writes the edits into the file, the previous text kept as `<shot>.toml.bak`.
    pub fn save(&mut self) -> Result<(), String> {
        let on_disk = read(&self.path)?;
        if on_disk != self.saved {
            return Err(format!(
                "{}: changed on disk since rift layout read it; not overwritten (revert to \
                 load it, then edit again)",
                self.path.display()
            ));
        }
        let text = self.doc.to_string();
        let backup = self.path.with_extension("toml.bak");
        atomic::write(&backup, |out| out.write_all(self.saved.as_bytes()))
            .map_err(|e| format!("{}: cannot write the backup: {e}", backup.display()))?;
        atomic::write(&self.path, |out| out.write_all(text.as_bytes()))
            .map_err(|e| format!("{}: cannot write: {e}", self.path.display()))?;
        self.saved = text;
        Ok(())
    }

    /// Drops the edits, reading the file again; returns the shot it loads as.
    pub fn revert(&mut self) -> Result<Shot, String> {
        let fresh = Self::open(&self.path)?;
        let shot = Shot::parse(&fresh.saved, &self.path).map_err(|e| e.to_string())?;
        let shot = crate::cli::with_usd_camera(shot, "layout").map_err(|e| format!("{e:#}"))?;
        *self = fresh;
        Ok(shot)
    }
}

fn read(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))
}
