//! Opening a stage within bounds, and walking its prims into objects, materials and lights.

use super::{Imported, Source, lights, mesh, shading, well_formed, xform};
use crate::error::{RenderError, key_error};
use openusd::ar::{self, Asset, ResolvedPath, Resolver};
use openusd::usd::{Prim, Stage};
use std::cell::Cell;
use std::collections::HashMap;
use std::io;
use std::path::Path;
use std::rc::Rc;

/// Bounds on what opening a stage may read.
#[derive(Clone, Copy, Debug)]
pub struct StageLimits {
    /// Bytes of all layers (and packaged files) together.
    pub bytes: u64,
}

impl StageLimits {
    /// Composed layers take several times their bytes in memory (decoded values, specs and
    /// the composition's indices): a stage may read a quarter of the memory budget, and
    /// without one, 4 GiB.
    pub fn from_budget(budget: Option<u64>) -> Self {
        Self {
            bytes: budget.map_or(4 << 30, |b| b / 4),
        }
    }
}

/// The default resolver, refusing any asset that is not a regular file or would take the
/// stage past its limit.
struct BoundedResolver {
    inner: ar::DefaultResolver,
    limit: u64,
    read: Rc<Cell<u64>>,
}

impl Resolver for BoundedResolver {
    fn create_identifier(&self, asset_path: &str, anchor: Option<&ResolvedPath>) -> String {
        self.inner.create_identifier(asset_path, anchor)
    }

    fn resolve(&self, asset_path: &str) -> Option<ResolvedPath> {
        self.inner.resolve(asset_path)
    }

    fn resolve_for_new_asset(&self, asset_path: &str) -> Option<ResolvedPath> {
        self.inner.resolve_for_new_asset(asset_path)
    }

    fn open_asset(&self, resolved: &ResolvedPath) -> io::Result<Box<dyn Asset>> {
        let path: &Path = resolved;
        // A packaged file's own path is not on disk; the package itself is checked.
        if path.exists() {
            rift_fx::io::regular_file(path)?;
        }
        let mut asset = self.inner.open_asset(resolved)?;
        let total = self.read.get().saturating_add(asset.size()?);
        if total > self.limit {
            return Err(io::Error::other(format!(
                "the stage's layers need more than the {} MiB allowed for reading USD (a \
                 quarter of the memory budget; give more with --max-memory)",
                self.limit >> 20
            )));
        }
        self.read.set(total);
        let bytes = asset.read_all()?;
        // A binary layer is checked before the crate's reader trusts its declared sizes.
        if bytes.starts_with(b"PXR-USDC") {
            super::crate_check::check(&bytes, self.limit)
                .map_err(|m| io::Error::other(format!("{resolved}: {m}")))?;
        }
        Ok(Box::new(io::Cursor::new(bytes)))
    }
}

/// Opens the stage of `layer` within `limits`; the message says what went wrong.
pub fn open_stage(layer: &Path, limits: StageLimits) -> Result<Stage, String> {
    rift_fx::io::regular_file(layer).map_err(|e| format!("{}: {e}", layer.display()))?;
    let Some(name) = layer.to_str() else {
        return Err(format!("{}: the path is not valid UTF-8", layer.display()));
    };
    let resolver = BoundedResolver {
        inner: ar::DefaultResolver::new(),
        limit: limits.bytes,
        read: Rc::new(Cell::new(0)),
    };
    // The crate's errors may carry a chain of causes; all of them say what is wrong.
    let stage = Stage::builder()
        .resolver(resolver)
        .open(name)
        .map_err(|e| format!("{}: cannot open the stage: {e:#}", layer.display()))?;
    if let Some(e) = stage.composition_errors().first() {
        return Err(format!("{}: {e}", layer.display()));
    }
    Ok(stage)
}

/// Reads `stage` from `source` into `out`.
pub(super) fn read(stage: &Stage, source: &Source, out: &mut Imported) -> Result<(), RenderError> {
    let root = match source.root {
        Some(path) => {
            let prim = openusd::sdf::path(path)
                .ok()
                .filter(well_formed)
                .map(|p| stage.prim(p))
                .filter(|p| p.is_valid().unwrap_or(false));
            prim.ok_or_else(|| {
                key_error(
                    source.shot_file,
                    format!("{}.root", source.key),
                    format!("{}: no prim is at {path:?}", source.layer.display()),
                )
            })?
        }
        None => stage.prim(openusd::sdf::Path::abs_root()),
    };
    let mut walk = Walk {
        source,
        out,
        materials: HashMap::new(),
        subdivided: Vec::new(),
        still_normals: Vec::new(),
        shared: Default::default(),
    };
    let mut stack: Vec<Prim> = children(source, &root)?;
    stack.reverse();
    while let Some(prim) = stack.pop() {
        if walk.visit(&prim)? == Descend::Yes {
            let mut kids = children(source, &prim)?;
            kids.reverse();
            stack.extend(kids);
        }
    }
    walk.say_once();
    // References and payloads are composed as their prims are reached: a cycle, or a layer
    // that is missing, is known only now.
    match stage.composition_errors().first() {
        Some(e) => Err(key_error(
            source.shot_file,
            format!("{}.file", source.key),
            format!("{}: {e}", source.layer.display()),
        )),
        None => Ok(()),
    }
}

/// The active, defined children of `prim` (instances expanded into their prototypes' prims).
pub(super) fn children(source: &Source, prim: &Prim) -> Result<Vec<Prim>, RenderError> {
    let path = prim.path().as_str().to_owned();
    let all = prim.children().map_err(|e| source.read_error(&path, e))?;
    let mut out = Vec::with_capacity(all.len());
    for child in all {
        let p = child.path().as_str().to_owned();
        if !well_formed(child.path()) {
            return Err(source.error(&path, None, format!("a child has a malformed path {p:?}")));
        }
        let active = child.is_active().map_err(|e| source.read_error(&p, e))?;
        let defined = child.is_defined().map_err(|e| source.read_error(&p, e))?;
        let abstract_ = child.is_abstract().map_err(|e| source.read_error(&p, e))?;
        if active && defined && !abstract_ {
            out.push(child);
        }
    }
    Ok(out)
}

#[derive(PartialEq, Eq)]
enum Descend {
    Yes,
    No,
}

/// Prototype meshes already made into objects, by the mesh's key, the transform baked into its
/// points, and the stretch its instances share (rounded): the object's index among the
/// imported objects, and that stretch.
#[derive(Default)]
pub struct Shared(pub HashMap<SharedKey, (usize, glam::DMat3)>);

/// A prototype mesh's key, the transform baked into its points and its instances' stretch,
/// rounded (`instancing.rs`).
pub type SharedKey = (String, [i64; 16], Option<[i64; 9]>);

/// The walk over a stage's prims.
pub(super) struct Walk<'a> {
    pub source: &'a Source<'a>,
    pub out: &'a mut Imported,
    /// Materials already made, by the USD material's path: their name among the scene's
    /// materials.
    materials: HashMap<String, String>,
    /// Meshes that are subdivision surfaces (said once).
    subdivided: Vec<String>,
    /// Meshes whose points deform but whose normals stay put (shaded flat).
    still_normals: Vec<String>,
    /// Prototype meshes already read, shared by their instances.
    pub shared: Shared,
}

impl Walk<'_> {
    fn visit(&mut self, prim: &Prim) -> Result<Descend, RenderError> {
        let path = prim.path().as_str().to_owned();
        let kind = prim
            .type_name()
            .map_err(|e| self.source.read_error(&path, e))?
            .map(|t| t.as_str().to_owned())
            .unwrap_or_default();
        if !xform::rendered(prim).map_err(|e| self.source.read_error(&path, e))? {
            return Ok(Descend::No);
        }
        if prim
            .is_instance()
            .map_err(|e| self.source.read_error(&path, e))?
        {
            self.instance(prim)?;
            return Ok(Descend::No);
        }
        match kind.as_str() {
            "" | "Xform" | "Scope" | "SkelRoot" => Ok(Descend::Yes),
            // Read where meshes bind them.
            "Material" | "Shader" | "NodeGraph" | "GeomSubset" => Ok(Descend::No),
            "Mesh" => {
                self.mesh(prim, &path)?;
                Ok(Descend::Yes)
            }
            // The shot's own camera is read as the shot camera (`camera.rs`).
            "Camera" if self.source.shot_camera == Some(path.as_str()) => Ok(Descend::No),
            "PointInstancer" => {
                self.point_instancer(prim)?;
                Ok(Descend::No)
            }
            "SphereLight" | "DiskLight" | "RectLight" | "DistantLight" | "DomeLight" => {
                lights::read(prim, &kind, self.source, self.out)?;
                Ok(Descend::Yes)
            }
            other => {
                self.out.warnings.push(format!(
                    "{}: <{path}> is a {other}, which rift does not read from USD yet; \
                     rendered without it{}",
                    self.source.layer.display(),
                    unread_hint(other)
                ));
                Ok(Descend::No)
            }
        }
    }

    /// A mesh prim into an object, with the materials it binds.
    fn mesh(&mut self, prim: &Prim, path: &str) -> Result<(), RenderError> {
        let placement = xform::placement(prim, self.source)?;
        let shape = self.mesh_shape(prim, path, &placement)?;
        self.out
            .objects
            .push(placement.object(path.to_owned(), std::sync::Arc::new(shape)));
        Ok(())
    }

    /// The shape of the mesh `prim` (at `path`), its points baked by `placement`, with the
    /// materials it binds made.
    pub fn mesh_shape(
        &mut self,
        prim: &Prim,
        path: &str,
        placement: &xform::Placement,
    ) -> Result<crate::scene::mesh::Shape, RenderError> {
        let read = mesh::read(prim, self.source, placement)?;
        let mut part_materials = Vec::with_capacity(read.bindings.len());
        for binding in &read.bindings {
            part_materials.push(self.material(prim, binding.as_deref())?);
        }
        if read.subdivision.is_some() {
            self.subdivided.push(path.to_owned());
        }
        if read.still_normals {
            self.still_normals.push(path.to_owned());
        }
        Ok(read.shape.with_materials(&part_materials))
    }

    /// Says once for the stage which meshes rift renders otherwise than USD says.
    fn say_once(&mut self) {
        let layer = self.source.layer.display();
        let said = [
            (
                &self.subdivided,
                ("is a subdivision surface", "are subdivision surfaces"),
                "rift renders the control cage, without subdividing",
            ),
            (
                &self.still_normals,
                (
                    "deforms with normals that are not sampled over time",
                    "deform with normals that are not sampled over time",
                ),
                "rift shades each of their triangles by its own normal",
            ),
        ];
        for (paths, (one, many), instead) in said {
            if !paths.is_empty() {
                self.out.warnings.push(format!(
                    "{layer}: {} ({}); {instead}",
                    meshes(paths.len(), one, many),
                    examples(paths)
                ));
            }
        }
    }

    /// The scene material's name for a mesh part bound to the USD material at `bound`
    /// (`None`: unbound, its display colour).
    fn material(&mut self, prim: &Prim, bound: Option<&str>) -> Result<String, RenderError> {
        let key = bound.map_or_else(
            || format!("{}#displayColor", prim.path().as_str()),
            str::to_owned,
        );
        if let Some(name) = self.materials.get(&key) {
            return Ok(name.clone());
        }
        let made = match bound {
            Some(material) => shading::material(prim.stage(), material, self.source)?,
            None => shading::display_color(prim, self.source)?,
        };
        self.out.warnings.extend(made.warnings);
        self.out.materials.push(made.entry);
        self.materials.insert(key, made.name.clone());
        Ok(made.name)
    }
}

/// "1 mesh `one`" or "n meshes `many`".
fn meshes(n: usize, one: &str, many: &str) -> String {
    match n {
        1 => format!("1 mesh {one}"),
        _ => format!("{n} meshes {many}"),
    }
}

/// Up to three of `paths`, then how many more.
fn examples(paths: &[String]) -> String {
    let shown: Vec<String> = paths.iter().take(3).map(|p| format!("<{p}>")).collect();
    match paths.len() {
        n if n > 3 => format!("{} and {} more", shown.join(", "), n - 3),
        _ => shown.join(", "),
    }
}

/// What a user can do about a prim type rift does not read.
fn unread_hint(kind: &str) -> &'static str {
    match kind {
        "Camera" => " (`usd = \"<path>\"` in the shot's [camera] frames the shot with it)",
        "Sphere" | "Cube" | "Cylinder" | "Cone" | "Capsule" | "Plane" => " (export it as a mesh)",
        _ => "",
    }
}
