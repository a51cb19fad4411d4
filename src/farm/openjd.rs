//! The farm plan as an Open Job Description job template (specification jobtemplate-2023-09).
//!
//! Job parameters carry what a farm remaps or overrides (the rift program, the shot file, the
//! frames, the finished-frame pattern and the work directory, as PATHs so path mapping applies);
//! steps: `Rings` (when the shot's rings are generated; one task per frame), `Render` (frames ×
//! sample chunks, after `Rings`) and `Merge` (one task per frame, after `Render`). Render tasks
//! are cancelled with a notice first: SIGTERM makes rift save its checkpoint, and a retried task
//! resumes from it.

use super::yaml::Yaml;
use super::{Arg, Piece, Plan};
use anyhow::bail;
use std::path::{Component, Path};

/// Seconds a cancelled render task is given to save its checkpoint before it is killed.
const NOTIFY_SECONDS: i64 = 120;

/// A job template.
pub struct Template {
    pub text: String,
    /// The `-p NAME=VALUE` arguments a run needs: paths outside the template's directory
    /// cannot be defaults.
    pub run_here: String,
}

/// The job template for a template saved in `job_dir`.
pub fn template(plan: &Plan, job_dir: &Path) -> anyhow::Result<Template> {
    if plan.frames.first < 0 {
        bail!(
            "--frames: an Open Job Description range cannot start below 0 (frame {})",
            plan.frames.first
        );
    }
    for value in [&plan.rift, &plan.shot_file, &plan.output, &plan.work_dir] {
        if value.contains("{{") {
            bail!(
                "{value}: a path with `{{{{` cannot go into an Open Job Description format string"
            );
        }
    }
    let (parameters, given) = parameters(plan, job_dir);
    let run_here: String = given
        .iter()
        .map(
            |(name, value)| match value.contains(|c: char| c.is_whitespace() || c == '\'') {
                // Quoted for a POSIX shell, as the printed command is meant to be pasted.
                true => format!(" -p '{name}={}'", value.replace('\'', "'\\''")),
                false => format!(" -p {name}={value}"),
            },
        )
        .collect();
    let doc = Yaml::map([
        ("specificationVersion", Yaml::str("jobtemplate-2023-09")),
        ("name", Yaml::str(format!("rift {}", plan.shot_name))),
        (
            "description",
            Yaml::str(format!(
                "Renders shot {} in {} sample chunk(s) per frame and merges them; written by rift farm openjd.",
                plan.shot_name,
                plan.chunks.len()
            )),
        ),
        ("parameterDefinitions", Yaml::List(parameters)),
        ("steps", Yaml::List(steps(plan))),
    ]);
    Ok(Template {
        text: format!(
            "# Open Job Description job template for shot {} (rift farm openjd).\n\
             # Check it: openjd check FILE\n\
             # Run it here: openjd run FILE{run_here} --step Merge --run-dependencies\n{}",
            plan.shot_name,
            doc.to_text()
        ),
        run_here,
    })
}

/// The steps: Rings (when the rings are generated), Render (every frame with every sample
/// chunk) after it, Merge after Render.
fn steps(plan: &Plan) -> Vec<Yaml> {
    let mut steps = Vec::new();
    if plan.bake_rings {
        steps.push(step(
            "Rings",
            None,
            vec![frame_parameter()],
            action(&plan.fx_args(), false),
        ));
    }
    let chunks = Yaml::map([
        ("name", Yaml::str("Samples")),
        ("type", Yaml::str("STRING")),
        ("range", Yaml::strs(plan.chunks.iter().cloned())),
    ]);
    steps.push(step(
        "Render",
        plan.bake_rings.then_some("Rings"),
        vec![frame_parameter(), chunks],
        action(&plan.render_args(), true),
    ));
    steps.push(step(
        "Merge",
        Some("Render"),
        vec![frame_parameter()],
        action(&plan.merge_args(), false),
    ));
    steps
}

/// The job parameters, and the PATH values that cannot be defaults (outside `job_dir`).
fn parameters(plan: &Plan, job_dir: &Path) -> (Vec<Yaml>, Vec<(&'static str, String)>) {
    let mut given = Vec::new();
    let string = |name: &str, about: &str, default: String| {
        Yaml::map([
            ("name", Yaml::str(name)),
            ("type", Yaml::str("STRING")),
            ("description", Yaml::str(about)),
            ("default", Yaml::str(default)),
        ])
    };
    let mut path = |spec, value: &str| path_parameter(spec, value, job_dir, &mut given);
    let parameters = vec![
        string(
            "RiftExecutable",
            "The rift program on the worker (a name on PATH, or a path).",
            plan.rift.clone(),
        ),
        path(
            ("ShotFile", "FILE", "IN", "The shot file (TOML)."),
            &plan.shot_file,
        ),
        string(
            "Frames",
            "The frames to render, A-B.",
            format!("{}-{}", plan.frames.first, plan.frames.last),
        ),
        path(
            (
                "Output",
                "FILE",
                "OUT",
                "The finished frames; #s become the frame number.",
            ),
            &plan.output,
        ),
        path(
            (
                "WorkDir",
                "DIRECTORY",
                "INOUT",
                "Parts, ring caches and checkpoints.",
            ),
            &plan.work_dir,
        ),
    ];
    (parameters, given)
}

/// `target` (absolute) relative to `base` (absolute) when it lies inside it. OpenJD joins a PATH
/// parameter's default to the template's directory and refuses one that walks out of it.
fn inside(base: &Path, target: &str) -> Option<String> {
    let normal = |p: &Path| -> Vec<String> {
        let mut parts: Vec<String> = Vec::new();
        for c in p.components() {
            match c {
                Component::Normal(s) => parts.push(s.to_string_lossy().into_owned()),
                Component::ParentDir => {
                    parts.pop();
                }
                _ => {}
            }
        }
        parts
    };
    let (base, target) = (normal(base), normal(Path::new(target)));
    let rest = target.strip_prefix(base.as_slice())?;
    Some(if rest.is_empty() {
        ".".to_owned()
    } else {
        rest.join("/")
    })
}

/// A PATH parameter (farms remap these between machines) whose default is `value` when it lies
/// inside `job_dir`; otherwise it has none and goes into `given`, the values to pass.
fn path_parameter(
    spec: (&'static str, &'static str, &'static str, &'static str),
    value: &str,
    job_dir: &Path,
    given: &mut Vec<(&'static str, String)>,
) -> Yaml {
    let (name, object, flow, about) = spec;
    let mut pairs = vec![
        ("name", Yaml::str(name)),
        ("type", Yaml::str("PATH")),
        ("objectType", Yaml::str(object)),
        ("dataFlow", Yaml::str(flow)),
        ("description", Yaml::str(about)),
    ];
    match inside(job_dir, value) {
        Some(relative) => pairs.push(("default", Yaml::str(relative))),
        None => given.push((name, value.to_owned())),
    }
    Yaml::Map(pairs)
}

fn frame_parameter() -> Yaml {
    Yaml::map([
        ("name", Yaml::str("Frame")),
        ("type", Yaml::str("INT")),
        ("range", Yaml::str("{{Param.Frames}}")),
    ])
}

/// A step with its task parameters (two: every frame with every sample chunk), run by
/// `on_run`, after `after` when given.
fn step(name: &str, after: Option<&str>, parameters: Vec<Yaml>, on_run: Yaml) -> Yaml {
    let mut pairs = vec![("name", Yaml::str(name))];
    if let Some(after) = after {
        pairs.push((
            "dependencies",
            Yaml::List(vec![Yaml::map([("dependsOn", Yaml::str(after))])]),
        ));
    }
    let mut space = Vec::new();
    if parameters.len() > 1 {
        space.push(("combination", Yaml::str("Frame * Samples")));
    }
    space.insert(0, ("taskParameterDefinitions", Yaml::List(parameters)));
    pairs.push(("parameterSpace", Yaml::Map(space)));
    pairs.push((
        "script",
        Yaml::map([("actions", Yaml::map([("onRun", on_run)]))]),
    ));
    Yaml::Map(pairs)
}

/// Running rift with `args`; `notify`: cancelled with SIGTERM first, so it saves its state.
fn action(args: &[Arg], notify: bool) -> Yaml {
    let mut pairs = vec![
        ("command", Yaml::str(spell(&[Piece::Rift]))),
        ("args", Yaml::strs(args.iter().map(|a| spell(a)))),
    ];
    if notify {
        pairs.push((
            "cancelation",
            Yaml::map([
                ("mode", Yaml::str("NOTIFY_THEN_TERMINATE")),
                ("notifyPeriodInSeconds", Yaml::Int(NOTIFY_SECONDS)),
            ]),
        ));
    }
    Yaml::Map(pairs)
}

/// An argument as an OpenJD format string.
fn spell(arg: &[Piece]) -> String {
    arg.iter()
        .map(|piece| match piece {
            Piece::Text(t) => t.clone(),
            Piece::Rift => "{{Param.RiftExecutable}}".into(),
            Piece::ShotFile => "{{Param.ShotFile}}".into(),
            Piece::Output => "{{Param.Output}}".into(),
            Piece::WorkDir => "{{Param.WorkDir}}".into(),
            Piece::Frame => "{{Task.Param.Frame}}".into(),
            Piece::Samples => "{{Task.Param.Samples}}".into(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::inside;
    use std::path::Path;

    #[test]
    fn defaults_are_relative_to_the_template() {
        let base = Path::new("/a/b/jobs");
        assert_eq!(
            inside(base, "/a/b/jobs/out/x.####.exr").unwrap(),
            "out/x.####.exr"
        );
        assert_eq!(inside(base, "/a/b/jobs/../jobs/c").unwrap(), "c");
        assert_eq!(inside(base, "/a/b/jobs").unwrap(), ".");
        assert_eq!(inside(base, "/a/b/shot.toml"), None);
        assert_eq!(inside(base, "/a/b/jobsx/shot.toml"), None);
    }
}
